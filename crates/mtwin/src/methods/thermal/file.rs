//! The thermal model file (TOML):
//!
//! ```toml
//! period_min = 10.0              # sample period T, min
//!
//! [[inputs]]                     # in the order the models take them
//! name = "speed_rpm"             # CSV column
//! scale = 8000.0                 # the model sees (value / scale)^power
//! power = 1                      # optional, 1 to 3 (default 1); the quadratic
//!                                # variant has a second speed_rpm input, power 2
//!
//! [[heights]]
//! z_mm = -50.0
//! a = [1.0, -1.62, 0.65]         # a_0..a_na, a_0 = 1 (e(k) = −Σ a_i e(k−i) + …)
//! b = [[0.0012, -0.0008]]        # per input b_0..b_nb (mm per unit of scaled input)
//! nk = [1]                       # per input delay, samples, >= 1
//!   [heights.fit]                # optional, statistics of the fit
//!   samples = 147
//!   params = 4
//!   fpe = 2.6e-7                 # mm²
//!   aic = -2200.0
//!   one_step_rms_mm = 0.0005
//!   simulation_rms_mm = 0.0009
//!   spectral_radius = 0.95
//!   a_std = [0.01, 0.01]
//!   b_std = [[1e-5, 1e-5]]
//! ```

use std::ops::Range;
use std::path::Path;

use toml_edit::{ArrayOfTables, DocumentMut, Item, Table, TableLike, Value};

use super::model::{HeightModel, HeightStats, InputChannel, ThermalModel};
use crate::io::TomlWriteError;
use crate::io::toml::{TomlReader, parse};
use crate::io::toml_write::{
    blank_line_before, float, float_rows, floats, indent, int, ints, set, with_header,
};
use crate::io::{Diagnostic, Diagnostics};
use crate::sysid::Arx;

impl ThermalModel {
    /// The model file text (schema in this module's docs), numbers at full precision.
    ///
    /// # Errors
    /// A non-finite number (e.g. a fit statistic), named by its key
    /// (`heights[0].fit.aic`): the file could not be read back.
    pub fn to_toml(&self) -> Result<String, TomlWriteError> {
        let mut doc = DocumentMut::new();
        let root = doc.as_table_mut();
        set(
            root,
            "period_min",
            float("period_min", self.period_min())?,
            None,
        );
        let mut inputs = ArrayOfTables::new();
        for (i, c) in self.inputs().iter().enumerate() {
            let mut t = Table::new();
            set(&mut t, "name", Value::from(c.name.as_str()), None);
            set(
                &mut t,
                "scale",
                float(&format!("inputs[{i}].scale"), c.scale)?,
                None,
            );
            if c.power != 1 {
                set(&mut t, "power", int(c.power), None);
            }
            blank_line_before(&mut t);
            inputs.push(t);
        }
        root.insert("inputs", Item::ArrayOfTables(inputs));
        let mut heights = ArrayOfTables::new();
        for (k, h) in self.heights().iter().enumerate() {
            let key = |name: &str| format!("heights[{k}].{name}");
            let m = &h.model;
            let n = m.n_inputs();
            let mut t = Table::new();
            set(&mut t, "z_mm", float(&key("z_mm"), h.z_mm)?, None);
            set(&mut t, "a", floats(&key("a"), m.a())?, None);
            let b: Vec<Vec<f64>> = (0..n).map(|i| m.b(i).to_vec()).collect();
            set(&mut t, "b", float_rows(&key("b"), &b)?, None);
            set(&mut t, "nk", ints((0..n).map(|i| m.nk(i) as i64)), None);
            if let Some(st) = &h.stats {
                let key = |name: &str| format!("heights[{k}].fit.{name}");
                let mut f = Table::new();
                set(&mut f, "samples", int(st.samples as i64), None);
                set(&mut f, "params", int(st.params as i64), None);
                set(&mut f, "fpe", float(&key("fpe"), st.fpe)?, None);
                set(&mut f, "aic", float(&key("aic"), st.aic)?, None);
                let one = float(&key("one_step_rms_mm"), st.one_step_rms_mm)?;
                set(&mut f, "one_step_rms_mm", one, None);
                let sim = float(&key("simulation_rms_mm"), st.simulation_rms_mm)?;
                set(&mut f, "simulation_rms_mm", sim, None);
                let rad = float(&key("spectral_radius"), st.spectral_radius)?;
                set(&mut f, "spectral_radius", rad, None);
                set(&mut f, "a_std", floats(&key("a_std"), &st.a_std)?, None);
                set(&mut f, "b_std", float_rows(&key("b_std"), &st.b_std)?, None);
                indent(&mut f);
                t.insert("fit", Item::Table(f));
            }
            blank_line_before(&mut t);
            heights.push(t);
        }
        root.insert("heights", Item::ArrayOfTables(heights));
        Ok(with_header(
            &doc,
            &[
                "mtwin thermal drift model: one ARX model per measured height,",
                "e(k) = -sum a_i e(k-i) + sum_inputs sum_j b_j u(k-j-nk), u = (value / scale)^power,",
                "drift in mm (tool relative to workpiece, +Z), time in min, cold before t = 0.",
            ],
        ))
    }

    /// Write the model file atomically. A non-finite number in the model is
    /// refused ([`ThermalModel::to_toml`]) as an error of kind `InvalidData`.
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let text = self
            .to_toml()
            .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))?;
        crate::io::write_atomic(path, text.as_bytes())
    }
}

/// Read a thermal model file.
pub fn read_model(path: &Path) -> Result<ThermalModel, Diagnostics> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Diagnostic::whole(path, format!("cannot read the file: {e}")))?;
    model_from_toml_str(path, &text)
}

/// Parse a thermal model file; every problem is reported with its line.
pub fn model_from_toml_str(path: &Path, text: &str) -> Result<ThermalModel, Diagnostics> {
    let doc = parse(path, text)?;
    let root = doc.as_table();
    let mut r = TomlReader::new(path, text);
    r.check_keys(
        root,
        &["period_min", "inputs", "heights"],
        "the thermal model",
    );
    let period = r
        .required(root, "period_min", "the thermal model", None)
        .and_then(|i| r.number(i, "`period_min`"));
    if let Some(p) = period.filter(|p| *p <= 0.0) {
        let span = root.get("period_min").and_then(Item::span);
        r.error(
            span,
            format!(
                "`period_min` must be positive, not {}",
                crate::limits::fmt_message_number(p)
            ),
        );
    }

    let mut inputs = Vec::new();
    match root.get("inputs").map(|i| (i, i.as_array_of_tables())) {
        None => r.error(
            None,
            "the thermal model lacks `[[inputs]]` (at least the spindle speed)",
        ),
        Some((i, None)) => r.error(i.span(), "`inputs` must be an array of tables `[[inputs]]`"),
        Some((_, Some(arr))) => {
            for t in arr.iter() {
                let at = t.span();
                r.check_keys(t, &["name", "scale", "power"], "an `[[inputs]]` table");
                let name = r
                    .required(t, "name", "an `[[inputs]]` table", at.clone())
                    .and_then(|i| r.string(i, "`name`"));
                let scale = r
                    .required(t, "scale", "an `[[inputs]]` table", at.clone())
                    .and_then(|i| r.number(i, "`scale`"));
                // Optional, 1 (linear) when absent.
                let power = match t.get("power") {
                    None => Some(1),
                    Some(i) => r.number(i, "`power`").and_then(|p| {
                        let ok = p.fract() == 0.0
                            && (1.0..=f64::from(InputChannel::MAX_POWER)).contains(&p);
                        if !ok {
                            r.error(
                                i.span(),
                                format!(
                                    "`power` must be a whole number from 1 to {}, not {}",
                                    InputChannel::MAX_POWER,
                                    crate::limits::fmt_message_number(p)
                                ),
                            );
                        }
                        ok.then_some(p as u32)
                    }),
                };
                if let Some(s) = scale.filter(|s| *s <= 0.0) {
                    r.error(
                        t.get("scale").and_then(Item::span),
                        format!(
                            "`scale` must be positive, not {}",
                            crate::limits::fmt_message_number(s)
                        ),
                    );
                } else if let (Some(name), Some(scale), Some(power)) = (name, scale, power) {
                    inputs.push(InputChannel { name, scale, power });
                }
            }
        }
    }

    let mut heights = Vec::new();
    let mut spans: Vec<Option<Range<usize>>> = Vec::new();
    match root.get("heights").map(|i| (i, i.as_array_of_tables())) {
        None => r.error(None, "the thermal model lacks `[[heights]]`"),
        Some((i, None)) => r.error(
            i.span(),
            "`heights` must be an array of tables `[[heights]]`",
        ),
        Some((_, Some(arr))) => {
            for t in arr.iter() {
                if let Some(h) = height(&mut r, t, t.span(), inputs.len()) {
                    heights.push(h);
                    spans.push(t.span());
                }
            }
        }
    }
    // Duplicate heights, at the line of the second.
    for i in 0..heights.len() {
        if heights[..i]
            .iter()
            .any(|h: &HeightModel| h.z_mm == heights[i].z_mm)
        {
            r.error(
                spans[i].clone(),
                format!(
                    "the height z = {} mm appears twice",
                    crate::limits::fmt_message_number(heights[i].z_mm)
                ),
            );
        }
    }
    let diags = r.diags;
    if !diags.is_empty() {
        return Err(diags);
    }
    let Some(period) = period else {
        return Err(Diagnostic::whole(path, "`period_min` is missing").into());
    };
    ThermalModel::new(period, inputs, heights)
        .map_err(|e| Diagnostic::whole(path, e.to_string()).into())
}

fn height(
    r: &mut TomlReader<'_>,
    t: &dyn TableLike,
    at: Option<Range<usize>>,
    n_inputs: usize,
) -> Option<HeightModel> {
    let what = "a `[[heights]]` table";
    r.check_keys(t, &["z_mm", "a", "b", "nk", "fit"], what);
    let z = r
        .required(t, "z_mm", what, at.clone())
        .and_then(|i| r.number(i, "`z_mm`"));
    let a = r
        .required(t, "a", what, at.clone())
        .and_then(|i| r.numbers(i, "`a`"));
    let b = r
        .required(t, "b", what, at.clone())
        .and_then(|i| r.number_rows(i, "`b`"));
    let nk_item = r.required(t, "nk", what, at.clone());
    let nk: Option<Vec<usize>> = nk_item.and_then(|i| r.numbers(i, "`nk`")).and_then(|v| {
        let ok = v.iter().all(|x| *x >= 1.0 && x.fract() == 0.0);
        if !ok {
            r.error(
                nk_item.and_then(Item::span),
                "every `nk` must be an integer >= 1 (an input given at t acts from t + T on)",
            );
        }
        ok.then(|| v.iter().map(|x| *x as usize).collect())
    });
    let stats = match t.get("fit") {
        None => None,
        Some(item) => match item.as_table_like() {
            None => {
                r.error(item.span(), "`fit` must be a table");
                None
            }
            Some(f) => fit_stats(r, f, item.span()),
        },
    };
    let (z, a, b, nk) = (z?, a?, b?, nk?);
    if a.first() != Some(&1.0) {
        r.error(
            t.get("a").and_then(Item::span),
            "`a` must start with a_0 = 1",
        );
        return None;
    }
    if b.len() != n_inputs || nk.len() != n_inputs || b.iter().any(Vec::is_empty) {
        r.error(
            t.get("b").and_then(Item::span),
            format!(
                "`b` and `nk` need one entry per input ({n_inputs}), and every `b` array at least b_0; \
                 found {} and {}",
                b.len(),
                nk.len()
            ),
        );
        return None;
    }
    let model = Arx::new(a, b.into_iter().zip(nk).collect()).ok()?;
    Some(HeightModel {
        z_mm: z,
        model,
        stats,
    })
}

fn fit_stats(
    r: &mut TomlReader<'_>,
    f: &dyn TableLike,
    at: Option<Range<usize>>,
) -> Option<HeightStats> {
    let what = "a `[heights.fit]` table";
    let keys = [
        "samples",
        "params",
        "fpe",
        "aic",
        "one_step_rms_mm",
        "simulation_rms_mm",
        "spectral_radius",
        "a_std",
        "b_std",
    ];
    r.check_keys(f, &keys, what);
    let num = |r: &mut TomlReader<'_>, k: &str| {
        r.required(f, k, what, at.clone())
            .and_then(|i| r.number(i, &format!("`{k}`")))
    };
    let fpe = num(r, "fpe");
    let aic = num(r, "aic");
    let one = num(r, "one_step_rms_mm");
    let sim = num(r, "simulation_rms_mm");
    let rad = num(r, "spectral_radius");
    let samples = r
        .required(f, "samples", what, at.clone())
        .and_then(|i| r.count(i, "`samples`"));
    let params = r
        .required(f, "params", what, at.clone())
        .and_then(|i| r.count(i, "`params`"));
    let a_std = r
        .required(f, "a_std", what, at.clone())
        .and_then(|i| r.numbers(i, "`a_std`"));
    let b_std = r
        .required(f, "b_std", what, at.clone())
        .and_then(|i| r.number_rows(i, "`b_std`"));
    Some(HeightStats {
        samples: samples?,
        params: params?,
        fpe: fpe?,
        aic: aic?,
        one_step_rms_mm: one?,
        simulation_rms_mm: sim?,
        spectral_radius: rad?,
        a_std: a_std?,
        b_std: b_std?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model() -> ThermalModel {
        let stats = HeightStats {
            samples: 147,
            params: 4,
            fpe: 2.5e-7,
            aic: -2200.125,
            one_step_rms_mm: 0.0005,
            simulation_rms_mm: 1.0 / 3.0,
            spectral_radius: 0.95,
            a_std: vec![0.01, 0.02],
            b_std: vec![vec![1e-5, 2e-5], vec![3e-6]],
        };
        let h1 = HeightModel {
            z_mm: -50.0,
            model: Arx::new(
                vec![1.0, -1.6, 0.64],
                vec![(vec![0.1, -0.05], 1), (vec![0.3], 2)],
            )
            .unwrap(),
            stats: Some(stats),
        };
        let h2 = HeightModel {
            z_mm: -150.0,
            model: Arx::new(
                vec![1.0, -0.9],
                vec![(vec![0.1], 1), (vec![0.2, 0.1, 0.05], 1)],
            )
            .unwrap(),
            stats: None,
        };
        let inputs = vec![
            InputChannel::linear("speed_rpm", 8000.0),
            InputChannel::linear("temp \"ambient\"", 0.1 + 0.2),
        ];
        ThermalModel::new(10.0, inputs, vec![h1, h2]).unwrap()
    }

    #[test]
    fn powers_round_trip_and_bad_powers_are_refused() {
        let arx = Arx::new(vec![1.0, -0.8], vec![(vec![0.1], 1), (vec![0.05], 1)]).unwrap();
        let quadratic = ThermalModel::new(
            10.0,
            vec![
                InputChannel::linear("speed_rpm", 8000.0),
                InputChannel {
                    name: "speed_rpm".into(),
                    scale: 8000.0,
                    power: 2,
                },
            ],
            vec![HeightModel {
                z_mm: -50.0,
                model: arx,
                stats: None,
            }],
        )
        .unwrap();
        let text = quadratic.to_toml().unwrap();
        assert_eq!(text.matches("power = 2").count(), 1, "{text}");
        let p = Path::new("T.toml");
        assert_eq!(model_from_toml_str(p, &text).unwrap(), quadratic);
        for bad in ["power = 0", "power = 1.5", "power = 4"] {
            let t = text.replacen("power = 2", bad, 1);
            let line = t.lines().position(|l| l == bad).unwrap() + 1;
            let e = model_from_toml_str(p, &t).unwrap_err();
            assert!(
                e.0.iter()
                    .any(|d| d.line == line && d.message.contains("`power`")),
                "{bad}: {e}"
            );
        }
        // The same input and power twice is refused.
        let t = text.replacen("power = 2", "power = 1", 1);
        assert!(model_from_toml_str(p, &t).is_err());
    }

    #[test]
    fn round_trip_is_exact() {
        let m = model();
        let text = m.to_toml().unwrap();
        let back = model_from_toml_str(Path::new("T.toml"), &text).unwrap();
        assert_eq!(back, m);
    }

    #[test]
    fn bad_files_report_lines() {
        let p = Path::new("T.toml");
        let good = model().to_toml().unwrap();
        // Unknown key, at its own line.
        let text = good.replacen("period_min = 10.0\n", "period_min = 10.0\ncolour = 3\n", 1);
        let line = text.lines().position(|l| l.starts_with("colour")).unwrap() + 1;
        let e = model_from_toml_str(p, &text).unwrap_err();
        assert!(
            e.0.iter()
                .any(|d| d.line == line && d.message.contains("`colour`")),
            "{e}"
        );
        // a_0 ≠ 1 and nk = 0.
        let text = good
            .replacen("a = [1.0, -0.9]", "a = [2.0, -0.9]", 1)
            .replacen("nk = [1, 2]", "nk = [0, 2]", 1);
        let e = model_from_toml_str(p, &text).unwrap_err();
        let a_line = text
            .lines()
            .position(|l| l.starts_with("a = [2.0"))
            .unwrap()
            + 1;
        let nk_line = text.lines().position(|l| l.starts_with("nk = [0")).unwrap() + 1;
        assert!(
            e.0.iter()
                .any(|d| d.line == a_line && d.message.contains("a_0 = 1")),
            "{e}"
        );
        assert!(
            e.0.iter()
                .any(|d| d.line == nk_line && d.message.contains("nk")),
            "{e}"
        );
        // Duplicate height.
        let text = good.replacen("z_mm = -150.0", "z_mm = -50.0", 1);
        let e = model_from_toml_str(p, &text).unwrap_err();
        assert!(
            e.0.iter()
                .any(|d| d.message.contains("twice") && d.line > 0),
            "{e}"
        );
        // Syntax error.
        let e = model_from_toml_str(p, "period_min = 10.0\n[[heights]\n").unwrap_err();
        assert_eq!(e.0[0].line, 2, "{e}");
        // Missing key, at the table header.
        let text = good.replacen("z_mm = -150.0\n", "", 1);
        let e = model_from_toml_str(p, &text).unwrap_err();
        assert!(
            e.0.iter()
                .any(|d| d.message.contains("`z_mm`") && d.line > 0),
            "{e}"
        );
    }

    mod round_trip {
        use super::*;
        use proptest::prelude::*;

        // Any finite number the reader accepts (within `limits::MAX_ABS_VALUE`).
        use crate::limits::strategies::{finite, positive};

        fn name() -> impl Strategy<Value = String> {
            prop::collection::vec(any::<char>(), 0..16).prop_map(|c| c.into_iter().collect())
        }

        fn stats(n: usize) -> impl Strategy<Value = HeightStats> {
            (
                (0usize..1_000_000, 0usize..1000),
                (finite(), finite(), finite(), finite(), finite()),
                prop::collection::vec(finite(), 0..4),
                prop::collection::vec(prop::collection::vec(finite(), 0..3), n),
            )
                .prop_map(
                    |((samples, params), (fpe, aic, one, sim, rad), a_std, b_std)| HeightStats {
                        samples,
                        params,
                        fpe,
                        aic,
                        one_step_rms_mm: one,
                        simulation_rms_mm: sim,
                        spectral_radius: rad,
                        a_std,
                        b_std,
                    },
                )
        }

        fn height(n: usize) -> impl Strategy<Value = HeightModel> {
            (
                finite(),
                prop::collection::vec(finite(), 0..4),
                prop::collection::vec((prop::collection::vec(finite(), 1..4), 1usize..30), n),
                prop::option::of(stats(n)),
            )
                .prop_map(|(z_mm, tail, inputs, stats)| {
                    let mut a = vec![1.0];
                    a.extend(tail);
                    HeightModel {
                        z_mm,
                        model: Arx::new(a, inputs).unwrap(),
                        stats,
                    }
                })
        }

        fn model() -> impl Strategy<Value = ThermalModel> {
            (
                positive(),
                prop::collection::btree_set(name(), 1..4),
                prop::collection::vec((positive(), 1u32..=InputChannel::MAX_POWER), 4),
            )
                .prop_flat_map(|(period, names, scales)| {
                    let inputs: Vec<InputChannel> = names
                        .into_iter()
                        .zip(scales)
                        .map(|(name, (scale, power))| InputChannel { name, scale, power })
                        .collect();
                    let n = inputs.len();
                    (
                        Just(period),
                        Just(inputs),
                        prop::collection::vec(height(n), 1..4),
                    )
                })
                .prop_filter_map(
                    "distinct heights",
                    |(period, inputs, mut heights)| {
                        heights.sort_by(|a, b| a.z_mm.total_cmp(&b.z_mm));
                        heights.dedup_by(|a, b| a.z_mm == b.z_mm);
                        ThermalModel::new(period, inputs, heights).ok()
                    },
                )
        }

        proptest! {
            /// Any input name (any character: quotes, backslashes, newlines) and any
            /// finite numbers read back identical; a non-finite statistic is refused
            /// with its key.
            #[test]
            fn any_model_round_trips(m in model()) {
                let text = m.to_toml().unwrap();
                let back = model_from_toml_str(Path::new("T.toml"), &text);
                prop_assert!(back.is_ok(), "{:?}\n{}", back.err(), text);
                prop_assert_eq!(back.unwrap(), m.clone());
                let mut bad = m;
                let mut h = bad.heights()[0].clone();
                let mut st = h.stats.clone().unwrap_or(HeightStats {
                    samples: 1, params: 1, fpe: 0.0, aic: 0.0, one_step_rms_mm: 0.0,
                    simulation_rms_mm: 0.0, spectral_radius: 0.0, a_std: vec![], b_std: vec![],
                });
                st.aic = f64::NAN;
                h.stats = Some(st);
                bad = ThermalModel::new(bad.period_min(), bad.inputs().to_vec(), {
                    let mut hs = bad.heights().to_vec();
                    hs[0] = h;
                    hs
                })
                .unwrap();
                let e = bad.to_toml().unwrap_err();
                prop_assert_eq!(e.key, "heights[0].fit.aic");
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn parser_never_panics(s in ".{0,200}") {
            let _ = model_from_toml_str(Path::new("p.toml"), &s);
        }

        #[test]
        fn parser_never_panics_on_edits(pos in 0usize..2000, junk in "[\\[\\]=,.0-9a-z\" \n-]{0,8}") {
            let good = model().to_toml().unwrap();
            let mut cut = pos.min(good.len());
            while !good.is_char_boundary(cut) {
                cut -= 1;
            }
            let text = format!("{}{}{}", &good[..cut], junk, &good[cut..]);
            let _ = model_from_toml_str(Path::new("p.toml"), &text);
        }
    }
}
