//! The documents the ballbar commands print (`--format json` is their serde
//! form, the human text their `Display`), and the one `mtwin report` reads
//! back: [`BallbarIdentifyDoc`].

use std::collections::BTreeMap;
use std::fmt;
use std::marker::PhantomData;

use serde::de::{MapAccess, Visitor};
use serde::ser::SerializeMap;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::{BallbarMode, Compensation, Identification, Pige, SensitivityRow, SetupError};
use crate::fit::{ConfoundedGroup, DeterminedCombination, DroppedDirection};
use crate::io::fmt_f64;

/// Something with a fixed set of names: the eight PIGEs or the four modes.
pub trait Named: Copy + 'static {
    /// Every value, in index order.
    const ALL: &'static [Self];
    /// Its name as a JSON key.
    fn key(self) -> &'static str;
}

impl Named for Pige {
    const ALL: &'static [Pige] = &Pige::ALL;
    fn key(self) -> &'static str {
        self.name()
    }
}

impl Named for BallbarMode {
    const ALL: &'static [BallbarMode] = &BallbarMode::ALL;
    fn key(self) -> &'static str {
        self.label()
    }
}

/// One value per PIGE or per mode, serialised as an object keyed by the PIGE
/// names (`EY0A`, …) or the mode labels (`mode1`, …) in alphabetical order;
/// keys missing on reading take `T::default()`, other keys are ignored.
#[derive(Debug, Clone, PartialEq)]
pub struct PerName<K: Named, T>(pub Vec<T>, PhantomData<K>);

/// One value per PIGE (see [`PerName`]).
pub type PerPige<T> = PerName<Pige, T>;
/// One value per ballbar mode (see [`PerName`]).
pub type PerMode<T> = PerName<BallbarMode, T>;

impl<K: Named, T> PerName<K, T> {
    /// The values in index order of `K::ALL`.
    pub fn new(values: impl IntoIterator<Item = T>) -> Self {
        let v: Vec<T> = values.into_iter().collect();
        assert_eq!(v.len(), K::ALL.len(), "one value per name");
        PerName(v, PhantomData)
    }
}

impl<K: Named + Into<usize>, T> std::ops::Index<K> for PerName<K, T> {
    type Output = T;
    fn index(&self, k: K) -> &T {
        &self.0[k.into()]
    }
}

impl From<Pige> for usize {
    fn from(p: Pige) -> usize {
        p.index()
    }
}

impl From<BallbarMode> for usize {
    fn from(m: BallbarMode) -> usize {
        m.index()
    }
}

impl<K: Named, T: Serialize> Serialize for PerName<K, T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let sorted: BTreeMap<&str, &T> = K::ALL
            .iter()
            .zip(&self.0)
            .map(|(k, v)| (k.key(), v))
            .collect();
        let mut m = s.serialize_map(Some(sorted.len()))?;
        for (k, v) in sorted {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}

impl<'de, K: Named, T: Deserialize<'de> + Default> Deserialize<'de> for PerName<K, T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<K, T>(PhantomData<(K, T)>);
        impl<'de, K: Named, T: Deserialize<'de> + Default> Visitor<'de> for V<K, T> {
            type Value = PerName<K, T>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                let names: Vec<&str> = K::ALL.iter().map(|k| k.key()).collect();
                write!(f, "an object with keys {}", names.join(", "))
            }
            fn visit_map<A: MapAccess<'de>>(self, mut a: A) -> Result<Self::Value, A::Error> {
                let mut out: Vec<T> = K::ALL.iter().map(|_| T::default()).collect();
                while let Some(key) = a.next_key::<String>()? {
                    match K::ALL.iter().position(|k| k.key() == key) {
                        Some(i) => out[i] = a.next_value()?,
                        None => {
                            a.next_value::<serde::de::IgnoredAny>()?;
                        }
                    }
                }
                Ok(PerName(out, PhantomData))
            }
        }
        d.deserialize_map(V(PhantomData))
    }
}

/// `mtwin ballbar setup-error`: the tool-ball set-up error (mm).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BallbarSetupDoc {
    /// Offset of the tool-ball centre from the spindle axis along x (mm).
    pub ex: f64,
    /// Offset along y (mm).
    pub ey: f64,
}

impl From<SetupError> for BallbarSetupDoc {
    fn from(e: SetupError) -> Self {
        BallbarSetupDoc { ex: e.ex, ey: e.ey }
    }
}

impl fmt::Display for BallbarSetupDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "tool-ball set-up error: eX = {} mm, eY = {} mm ({:.1} µm, {:.1} µm)",
            fmt_f64(self.ex),
            fmt_f64(self.ey),
            self.ex * 1e3,
            self.ey * 1e3
        )
    }
}

/// `mtwin ballbar identify`: the eight PIGEs of A and C (absolute, mm and rad),
/// their standard uncertainties, the fit per mode and the corrected axis-line
/// positions. `mtwin report --ballbar` reads this document back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BallbarIdentifyDoc {
    /// Identified value of each PIGE (mm, rad); `null` when not identified.
    #[serde(flatten)]
    pub value: PerPige<Option<f64>>,
    /// Fitted bar length of each mode taking part (mm).
    pub bar_length: PerMode<Option<f64>>,
    /// Where the actual axis lines pass (mm).
    pub compensation: Compensation,
    /// The identified machine file written (`--out`), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub out: Option<String>,
    /// The polar plots written (`--plot`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub plots: Vec<String>,
    /// Residual RMS of each mode taking part (mm).
    pub residual_rms: PerMode<Option<f64>>,
    /// Standard uncertainty of each estimated PIGE (mm, rad).
    pub uncertainty: PerPige<Option<f64>>,
    /// The PIGEs the modes given cannot determine, by name, with the reason.
    pub unidentified: BTreeMap<String, String>,
    /// Warnings about the fit.
    pub warnings: Vec<String>,
    /// How the gauge was fixed: `prior` (PIGEs pulled to 0, bar lengths to
    /// their start; see `mtwin::fit::gauge`), absent without gauge fixing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gauge: Option<String>,
    /// The rank rule for badly determined directions (`off`, `rcond=X`,
    /// `std=X`), absent without gauge fixing.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub truncation: Option<String>,
    /// Groups of parameters (PIGEs, bar lengths `L.modeN`) the readings
    /// determine only in combination, with the combinations they determine
    /// (fit units mm, rad); absent when every parameter is determined.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub confounded_groups: Vec<ConfoundedGroup>,
    /// The badly determined directions the truncation rule set to the
    /// prior, with the bias each introduces (fit units).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub dropped_directions: Vec<DroppedDirection>,
    /// PIGEs the modes given structurally cannot separate (mode 3 alone:
    /// `EY0A` and `EY0C`), grouped: `determined` the combinations the
    /// readings determine, with value and standard uncertainty (mm, rad; the
    /// unit of the leading term), `undetermined_directions` the changes
    /// they cannot see. Absent when no PIGE is confounded.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unseparable_combinations: Vec<ConfoundedGroup>,
}

impl BallbarIdentifyDoc {
    /// The document of `id`, with the files written beside it.
    pub fn new(id: &Identification, out: Option<String>, plots: Vec<String>) -> Self {
        let unresolved = |p: Pige| id.unresolved.iter().any(|u| u.pige == p);
        BallbarIdentifyDoc {
            value: PerName::new(Pige::ALL.map(|p| (!unresolved(p)).then(|| id.piges.get(p)))),
            bar_length: PerName::new(id.lengths),
            compensation: id.compensation(),
            out,
            plots,
            residual_rms: PerName::new(id.residual_rms),
            uncertainty: PerName::new(id.uncertainty),
            unidentified: id
                .unresolved
                .iter()
                .map(|u| (u.pige.name().to_string(), u.reason.clone()))
                .collect(),
            warnings: id.warnings.clone(),
            gauge: id.report.gauge.as_ref().map(|g| g.kind.clone()),
            truncation: id.report.gauge.as_ref().map(|g| g.truncation.clone()),
            confounded_groups: id
                .report
                .gauge
                .as_ref()
                .map(|g| g.groups.clone())
                .unwrap_or_default(),
            dropped_directions: id
                .report
                .gauge
                .as_ref()
                .map(|g| g.dropped.clone())
                .unwrap_or_default(),
            unseparable_combinations: id.combinations.clone(),
        }
    }

    /// True when `p` is identified.
    pub fn is_identified(&self, p: Pige) -> bool {
        !self.unidentified.contains_key(p.name()) && self.value[p].is_some()
    }
}

impl fmt::Display for BallbarIdentifyDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "Identified PIGEs (absolute, ± standard uncertainty):")?;
        for p in Pige::ALL {
            let (k, unit) = if p.is_tilt() {
                (1e6, "µrad")
            } else {
                (1e3, "µm")
            };
            let v = self.value[p].unwrap_or(0.0);
            match self.uncertainty[p] {
                _ if self.unidentified.contains_key(p.name()) => {
                    writeln!(f, "  {p}  not identified by the modes given")?
                }
                Some(s) => writeln!(f, "  {p}  {:>9.2} ± {:.2} {unit}", v * k, s * k)?,
                None => writeln!(f, "  {p}  {:>9.2} {unit}", v * k)?,
            }
        }
        writeln!(f, "Residual RMS per mode:")?;
        for m in BallbarMode::ALL {
            if let Some(r) = self.residual_rms[m] {
                writeln!(f, "  {}  {:.3} µm", m.label(), r * 1e3)?;
            }
        }
        let c = &self.compensation;
        writeln!(f, "Compensation (corrected axis-line positions, mm):")?;
        writeln!(
            f,
            "  A-axis line passes through Y = {}, Z = {} (in M)",
            fmt_f64(c.a_y),
            fmt_f64(c.a_z)
        )?;
        writeln!(
            f,
            "  C-axis line passes through X = {}, Y = {} (in the A frame)",
            fmt_f64(c.c_x),
            fmt_f64(c.c_y)
        )?;
        if !self.confounded_groups.is_empty() {
            writeln!(
                f,
                "Combinations the readings determine (the rest set by the gauge):"
            )?;
            for g in &self.confounded_groups {
                for c in &g.determined {
                    writeln!(f, "  {}", combination_sentence(c))?;
                }
                for d in &g.undetermined_directions {
                    writeln!(f, "  {} (free)", d.describe())?;
                }
            }
        }
        if !self.unseparable_combinations.is_empty() {
            writeln!(
                f,
                "PIGEs the modes given cannot separate: only these combinations are measured \
                 (the PIGE held at 0 counts 0 in the values above):"
            )?;
            for g in &self.unseparable_combinations {
                for c in &g.determined {
                    writeln!(f, "  {}", combination_sentence(c))?;
                }
                for d in &g.undetermined_directions {
                    writeln!(f, "  {} (not seen: any amount)", d.describe())?;
                }
            }
        }
        if !self.dropped_directions.is_empty() {
            writeln!(
                f,
                "Badly determined directions set to the prior ({}):",
                self.truncation.as_deref().unwrap_or("off")
            )?;
            for d in &self.dropped_directions {
                let (k, unit) = pige_unit(&d.parameter);
                writeln!(
                    f,
                    "  s/s_max {:.2e}: {} moved by {:.2} {unit} (bias ≤ {:.2} {unit}); keeping it changes the readings by {:.3} µm RMS",
                    d.relative_singular_value,
                    d.parameter,
                    d.shift * k,
                    d.bias_bound * k,
                    d.rms_change * 1e3
                )?;
            }
        }
        if let Some(out) = &self.out {
            writeln!(f, "identified machine → {out}")?;
        }
        for p in &self.plots {
            writeln!(f, "plot → {p}")?;
        }
        Ok(())
    }
}

/// Display scale and unit of a fit parameter: tilts in µrad, offsets and
/// bar lengths in µm.
fn pige_unit(name: &str) -> (f64, &'static str) {
    if Pige::from_name(name).is_some_and(Pige::is_tilt) {
        (1e6, "µrad")
    } else {
        (1e3, "µm")
    }
}

/// `EX0C + 1.0000·L.mode1 = 12.34 ± 0.56 µm` (unit of the leading term).
fn combination_sentence(c: &DeterminedCombination) -> String {
    let (k, unit) = c.terms.first().map_or((1.0, ""), |t| pige_unit(&t.name));
    let u = c
        .uncertainty
        .map_or(String::new(), |u| format!(" ± {:.2}", u * k));
    format!("{} = {:.2}{u} {unit}", c.describe(), c.value * k)
}

/// Peak `|ΔL|` of one mode per PIGE (mm), keyed `mode1` … `mode4`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SensitivityDocRow {
    /// Largest `|ΔL|` over the angles of each mode (mm).
    pub peak_delta_l: PerMode<f64>,
    /// The PIGE.
    pub pige: String,
    /// The error size applied (mm or rad).
    pub size: f64,
}

/// `mtwin ballbar sensitivity`: the peak `|ΔL|` of each mode for one PIGE at a
/// time (a JSON array, one object per PIGE).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(transparent)]
pub struct BallbarSensitivityDoc(pub Vec<SensitivityDocRow>);

impl From<&[SensitivityRow]> for BallbarSensitivityDoc {
    fn from(rows: &[SensitivityRow]) -> Self {
        BallbarSensitivityDoc(
            rows.iter()
                .map(|r| SensitivityDocRow {
                    peak_delta_l: PerName::new(r.peak),
                    pige: r.pige.name().to_string(),
                    size: r.size,
                })
                .collect(),
        )
    }
}

impl fmt::Display for BallbarSensitivityDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "Peak |ΔL| (µm) per mode for one PIGE at a time (ideal set-up):"
        )?;
        writeln!(
            f,
            "  PIGE  size            mode1    mode2    mode3    mode4"
        )?;
        for r in &self.0 {
            let tilt = Pige::from_name(&r.pige).is_some_and(Pige::is_tilt);
            let size = if tilt {
                format!("{:.3e} rad", r.size)
            } else {
                format!("{:.4} mm", r.size)
            };
            let cells: Vec<String> = r
                .peak_delta_l
                .0
                .iter()
                .map(|&p| {
                    if p < 1e-6 {
                        format!("{:>8}", "·")
                    } else {
                        format!("{:>8.3}", p * 1e3)
                    }
                })
                .collect();
            writeln!(f, "  {}  {:<14} {}", r.pige, size, cells.join(" "))?;
        }
        writeln!(f, "(· : below 0.001 µm — the PIGE does not move that mode)")
    }
}

/// `mtwin ballbar program`: the four test programs written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BallbarProgramDoc {
    /// One G-code file per mode.
    pub files: Vec<String>,
}

/// The files are announced as notes on stderr: no human text on stdout.
impl fmt::Display for BallbarProgramDoc {
    fn fmt(&self, _: &mut fmt::Formatter<'_>) -> fmt::Result {
        Ok(())
    }
}

/// `mtwin ballbar simulate`: the synthetic readings written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BallbarSimulateDoc {
    /// One CSV per mode.
    pub files: Vec<String>,
    /// Standard deviation of the reading noise (mm).
    pub noise: f64,
    /// Random seed of the noise.
    pub seed: u64,
}

impl fmt::Display for BallbarSimulateDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for w in &self.files {
            writeln!(f, "{w}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::Options;
    use crate::methods::ballbar::{
        Rig, SimulationSpec, angle_range, identify, sensitivity_table, simulate_modes,
    };
    use crate::model::{Machine, parse_machine};
    use std::path::Path;

    fn machine(name: &str, text: &str) -> Machine {
        parse_machine(Path::new(name), text).unwrap()
    }

    fn angles(m: BallbarMode) -> Vec<f64> {
        if m.moves_a() {
            angle_range(-90.0, 90.0, 10.0)
        } else {
            angle_range(0.0, 360.0, 10.0)
        }
    }

    fn round_trip<D>(doc: &D) -> D
    where
        D: Serialize + for<'de> Deserialize<'de>,
    {
        serde_json::from_str(&serde_json::to_string_pretty(doc).unwrap()).unwrap()
    }

    #[test]
    fn identify_document_round_trips_and_keeps_the_flat_pige_keys() {
        let truth = machine(
            "ac-trunnion-with-errors.toml",
            include_str!("../../../../../examples/machines/ac-trunnion-with-errors.toml"),
        );
        let nominal = machine(
            "ac-trunnion.toml",
            include_str!("../../../../../examples/machines/ac-trunnion.toml"),
        );
        let rig = Rig::source_paper();
        // Modes 1 and 2 only: the C-line PIGEs stay unidentified.
        let specs: Vec<(BallbarMode, SimulationSpec)> = [BallbarMode::One, BallbarMode::Two]
            .map(|m| {
                (
                    m,
                    SimulationSpec {
                        rig,
                        noise: 0.0,
                        angles_deg: angles(m),
                    },
                )
            })
            .to_vec();
        let data = simulate_modes(&truth, &specs, 1).unwrap();
        let refs = [Some(&data[0]), Some(&data[1]), None, None];
        let id = identify(&nominal, &rig, &refs, &Options::default()).unwrap();
        let doc = BallbarIdentifyDoc::new(&id, None, vec![]);
        assert!(!doc.unidentified.is_empty());
        assert!(
            doc.residual_rms[BallbarMode::One].is_some()
                && doc.residual_rms[BallbarMode::Three].is_none()
        );
        assert_eq!(round_trip(&doc), doc);
        // The document's JSON layout: PIGEs at the top level, per-mode objects.
        let v = serde_json::to_value(&doc).unwrap();
        for p in Pige::ALL {
            assert!(v.get(p.name()).is_some(), "{p}");
            let identified = !doc.unidentified.contains_key(p.name());
            assert_eq!(v[p.name()].is_null(), !identified, "{p}");
        }
        assert_eq!(v["residual_rms"].as_object().unwrap().len(), 4);
        assert!(v["compensation"]["A_line_y"].is_number());
        assert!(v.get("out").is_none() && v.get("plots").is_none());
        let with_files =
            BallbarIdentifyDoc::new(&id, Some("m.toml".into()), vec!["mode1.svg".into()]);
        assert_eq!(round_trip(&with_files), with_files);
        assert!(
            with_files
                .to_string()
                .contains("identified machine → m.toml")
        );
    }

    #[test]
    fn sensitivity_setup_program_and_simulate_documents_round_trip() {
        let nominal = machine(
            "ac-trunnion.toml",
            include_str!("../../../../../examples/machines/ac-trunnion.toml"),
        );
        let rows = sensitivity_table(
            &nominal,
            &Rig::source_paper(),
            0.010,
            1e-4,
            &BallbarMode::ALL.map(angles),
        )
        .unwrap();
        let doc = BallbarSensitivityDoc::from(rows.as_slice());
        assert_eq!(doc.0.len(), 8);
        assert_eq!(round_trip(&doc), doc);
        let v = serde_json::to_value(&doc).unwrap();
        assert!(v.is_array() && v[0]["peak_delta_l"]["mode4"].is_number());

        let setup = BallbarSetupDoc::from(
            crate::methods::ballbar::setup_error(&crate::methods::ballbar::SetupErrorInput {
                length: 100.0,
                lmax: 100.1,
                lmin: 99.9,
                theta2_deg: 242.0,
            })
            .unwrap(),
        );
        assert_eq!(round_trip(&setup), setup);
        let p = BallbarProgramDoc {
            files: vec!["mode1.ngc".into()],
        };
        assert_eq!(round_trip(&p), p);
        assert_eq!(p.to_string(), "");
        let s = BallbarSimulateDoc {
            files: vec!["a.csv".into(), "b.csv".into()],
            noise: 3e-4,
            seed: 7,
        };
        assert_eq!(round_trip(&s), s);
        assert_eq!(s.to_string(), "a.csv\nb.csv\n");
    }
}
