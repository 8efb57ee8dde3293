//! Writing a machine model back to TOML (the schema of `docs/machine-model.md`),
//! at full precision, through the shared TOML writer (`toml_edit`).

use toml_edit::{ArrayOfTables, DocumentMut, Item, Table, Value};

use super::{Component, ErrorFunction, Machine};
use crate::io::TomlWriteError;
use crate::io::toml_write::{
    blank_line_before, float, floats, indent, inline, int, set, strings, with_header,
};

fn function(key: &str, f: &ErrorFunction) -> Result<Value, TomlWriteError> {
    Ok(match f {
        ErrorFunction::Constant(c) => float(key, *c)?,
        ErrorFunction::Poly(c) => inline([("poly", floats(&format!("{key}.poly"), c)?)]),
        ErrorFunction::Cheb(c) => inline([("cheb", floats(&format!("{key}.cheb"), c)?)]),
        ErrorFunction::Table { q, e } => inline([(
            "table",
            inline([
                ("q", floats(&format!("{key}.table.q"), q)?),
                ("e", floats(&format!("{key}.table.e"), e)?),
            ]),
        )]),
    })
}

/// The machine as machine-file TOML. `header` lines are written first as `#` comments.
/// Zero location errors and absent PDGEs are omitted; everything else is written at full
/// precision, so reading the text back gives an identical [`Machine`]. Names are quoted
/// and escaped by `toml_edit`.
///
/// # Errors
/// A non-finite number (NaN, ±infinity) anywhere in the model, named by its key
/// (e.g. `axes.X.errors.EXX.poly[2]`): the file could not be read back.
pub fn machine_to_toml(m: &Machine, header: &[&str]) -> Result<String, TomlWriteError> {
    let mut doc = DocumentMut::new();
    let root = doc.as_table_mut();
    let chain = |c: &[usize]| strings(c.iter().map(|&i| m.axes[i].name.as_str()));
    set(root, "name", Value::from(m.name.as_str()), None);
    set(
        root,
        "tool_chain",
        chain(&m.tool_chain),
        Some("base -> spindle"),
    );
    set(
        root,
        "workpiece_chain",
        chain(&m.workpiece_chain),
        Some("base -> table"),
    );
    if m.rapid_feed != super::machine::DEFAULT_RAPID_FEED {
        set(
            root,
            "rapid_feed",
            float("rapid_feed", m.rapid_feed)?,
            Some("mm/min"),
        );
    }

    let mut tool = Table::new();
    set(
        &mut tool,
        "tip",
        floats("tool.tip", m.tool_tip.as_slice())?,
        None,
    );
    let dir = floats("tool.direction", m.tool_direction.as_slice())?;
    set(&mut tool, "direction", dir, None);
    blank_line_before(&mut tool);
    root.insert("tool", Item::Table(tool));

    let mut wp = Table::new();
    let origin = floats("workpiece.origin", m.workpiece_origin.as_slice())?;
    set(&mut wp, "origin", origin, None);
    blank_line_before(&mut wp);
    root.insert("workpiece", Item::Table(wp));

    let mut axes = ArrayOfTables::new();
    for a in &m.axes {
        let k = |key: &str| format!("axes.{}.{key}", a.name);
        let mut t = Table::new();
        set(&mut t, "name", Value::from(a.name.as_str()), None);
        set(&mut t, "kind", Value::from(a.kind.as_str()), None);
        set(
            &mut t,
            "direction",
            floats(&k("direction"), a.direction.as_slice())?,
            None,
        );
        set(
            &mut t,
            "origin",
            floats(&k("origin"), a.origin.as_slice())?,
            None,
        );
        set(&mut t, "travel", floats(&k("travel"), &a.travel)?, None);
        if let Some(v) = a.max_velocity {
            set(&mut t, "max_velocity", float(&k("max_velocity"), v)?, None);
        }
        if let Some(v) = a.max_acceleration {
            set(
                &mut t,
                "max_acceleration",
                float(&k("max_acceleration"), v)?,
                None,
            );
        }
        if let Some(v) = a.max_jerk {
            set(&mut t, "max_jerk", float(&k("max_jerk"), v)?, None);
        }
        let mut errors = Table::new();
        for c in Component::ALL {
            if let Some(f) = &a.errors.pdge[c.index()] {
                let name = format!("E{}{}", c.letter(), a.name);
                let v = function(&k(&format!("errors.{name}")), f)?;
                set(&mut errors, &name, v, None);
            }
        }
        for c in Component::ALL {
            let v = a.errors.location[c.index()];
            if v != 0.0 {
                let name = format!("E{}0{}", c.letter(), a.name);
                let v = float(&k(&format!("errors.{name}")), v)?;
                set(&mut errors, &name, v, None);
            }
        }
        if !errors.is_empty() {
            indent(&mut errors);
            t.insert("errors", Item::Table(errors));
        }
        if let Some(sv) = &a.servo {
            let mut servo = Table::new();
            set(&mut servo, "ts", float(&k("servo.ts"), sv.ts)?, None);
            set(&mut servo, "b", floats(&k("servo.b"), &sv.b)?, None);
            set(&mut servo, "a", floats(&k("servo.a"), &sv.a)?, None);
            set(&mut servo, "nk", int(sv.nk as i64), None);
            indent(&mut servo);
            t.insert("servo", Item::Table(servo));
        }
        blank_line_before(&mut t);
        axes.push(t);
    }
    if !axes.is_empty() {
        root.insert("axes", Item::ArrayOfTables(axes));
    }
    Ok(with_header(&doc, header))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::parse_machine;
    use std::path::Path;

    #[test]
    fn round_trip_of_shipped_examples() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines");
        let mut n = 0;
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "toml") {
                let m = crate::model::read_machine(&p).unwrap_or_else(|e| panic!("{e}"));
                let text = machine_to_toml(&m, &["round trip"]).unwrap();
                let back = parse_machine(Path::new("back.toml"), &text)
                    .unwrap_or_else(|e| panic!("{e}\n{text}"));
                assert_eq!(m, back, "{}", p.display());
                n += 1;
            }
        }
        assert!(n >= 3);
    }

    #[test]
    fn non_finite_numbers_are_refused_with_their_key() {
        let p = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/machines/ac-trunnion-with-errors.toml");
        let m = crate::model::read_machine(&p).unwrap();
        let mut bad = m.clone();
        bad.tool_tip.y = f64::NAN;
        let e = machine_to_toml(&bad, &[]).unwrap_err();
        assert_eq!(e.key, "tool.tip[1]");
        let mut bad = m.clone();
        bad.rapid_feed = f64::INFINITY;
        assert_eq!(machine_to_toml(&bad, &[]).unwrap_err().key, "rapid_feed");
        let mut bad = m.clone();
        let last = bad.axes.len() - 1;
        bad.axes[last].errors.pdge[1] = Some(ErrorFunction::Table {
            q: vec![0.0, 1.0],
            e: vec![0.5, f64::NEG_INFINITY],
        });
        let name = bad.axes[last].name.clone();
        let e = machine_to_toml(&bad, &[]).unwrap_err();
        assert_eq!(e.key, format!("axes.{name}.errors.EY{name}.table.e[1]"));
        assert!(e.to_string().contains("-inf"), "{e}");
    }

    #[test]
    fn layout_of_a_written_file() {
        let p =
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/machines/ac-trunnion.toml");
        let mut m = crate::model::read_machine(&p).unwrap();
        m.name = "tab\t \"quoted\" back\\slash\nnew line".into();
        m.axes[0].errors.location[0] = 0.001;
        m.axes[0].errors.pdge[5] = Some(ErrorFunction::Poly(vec![1e-6, 2.5e-9]));
        let text = machine_to_toml(&m, &["first", "second"]).unwrap();
        let a0 = &m.axes[0].name;
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines[..2], ["# first", "# second"]);
        assert!(lines[2].starts_with("name = "));
        assert!(text.contains("workpiece_chain = ["));
        assert!(text.contains("]  # base -> spindle\n"));
        let expect = [
            "\n[tool]\ntip = [".to_string(),
            "\n[workpiece]\norigin = [".to_string(),
            format!("\n[[axes]]\nname = \"{a0}\"\nkind = \""),
            format!("  [axes.errors]\n  EC{a0} = {{ poly = [1e-6, 2.5e-9] }}\n  EX0{a0} = 0.001\n"),
        ];
        let mut at = 0;
        for e in &expect {
            let i = text[at..]
                .find(e.as_str())
                .unwrap_or_else(|| panic!("{e:?} after {at} in\n{text}"));
            at += i + e.len();
        }
        assert_eq!(parse_machine(Path::new("m.toml"), &text).unwrap(), m);
    }

    mod round_trip {
        use super::super::*;
        use crate::model::{Axis, AxisErrors, AxisKind, ServoTable, parse_machine};
        use nalgebra::Vector3;
        use proptest::prelude::*;
        use std::path::Path;

        // Numbers the reader accepts: within `limits::MAX_ABS_VALUE`, and error
        // functions whose value and slope stay within `limits::MAX_ERROR_VALUE`
        // over the travel (|q| ≤ 2e4, travel at least 0.1 wide).
        use crate::limits::strategies::{finite, positive, small};
        fn unit() -> impl Strategy<Value = Vector3<f64>> {
            (-1.0..1.0f64, -1.0..1.0f64, -1.0..1.0f64)
                .prop_filter("not too short", |(x, y, z)| x * x + y * y + z * z > 1e-3)
                .prop_map(|(x, y, z)| Vector3::new(x, y, z).normalize())
        }

        fn vec3() -> impl Strategy<Value = Vector3<f64>> {
            (finite(), finite(), finite()).prop_map(|(x, y, z)| Vector3::new(x, y, z))
        }

        /// Coefficient k scaled by 1e-4^k: |c_k q^k| ≤ 1e-3 · 2^k over |q| ≤ 2e4.
        fn poly_coeffs() -> impl Strategy<Value = Vec<f64>> {
            prop::collection::vec(small(1e-3), 1..5).prop_map(|c| {
                c.into_iter()
                    .enumerate()
                    .map(|(k, ck)| ck * 1e-4f64.powi(k as i32))
                    .collect()
            })
        }

        fn function() -> impl Strategy<Value = ErrorFunction> {
            prop_oneof![
                finite().prop_map(|v| ErrorFunction::Constant(v % 1e6)),
                poly_coeffs().prop_map(ErrorFunction::Poly),
                prop::collection::vec(small(1e-3), 1..5).prop_map(ErrorFunction::Cheb),
                // Table positions at least 0.01 apart: slopes below 0.2.
                (
                    -1e4..1e4f64,
                    prop::collection::vec((0.01..1e3f64, small(1e-3)), 1..5)
                )
                    .prop_map(|(q0, steps)| {
                        let mut q = Vec::new();
                        let mut e = Vec::new();
                        let mut at = q0;
                        for (step, v) in steps {
                            q.push(at);
                            e.push(v);
                            at += step;
                        }
                        ErrorFunction::Table { q, e }
                    }),
            ]
        }

        fn servo() -> impl Strategy<Value = ServoTable> {
            (
                positive(),
                prop::collection::vec(finite(), 1..5),
                prop::collection::vec(finite(), 0..4),
                0usize..50,
            )
                .prop_map(|(ts, b, tail, nk)| {
                    let mut a = vec![1.0];
                    a.extend(tail);
                    ServoTable { ts, b, a, nk }
                })
        }

        fn axis() -> impl Strategy<Value = Axis> {
            (
                (any::<bool>(), unit(), vec3()),
                (-1e4..1e4f64, 0.1..1e4f64).prop_map(|(lo, w)| (lo, lo + w)),
                (
                    prop::array::uniform6(prop::option::of(function())),
                    prop::array::uniform6(finite()),
                ),
                (
                    prop::option::of(positive()),
                    prop::option::of(positive()),
                    prop::option::of(positive()),
                ),
                prop::option::of(servo()),
            )
                .prop_map(
                    |(
                        (rotary, direction, origin),
                        (a, b),
                        (pdge, location),
                        (v, acc, jerk),
                        servo,
                    )| {
                        Axis {
                            name: String::new(),
                            kind: if rotary {
                                AxisKind::Rotary
                            } else {
                                AxisKind::Linear
                            },
                            direction,
                            origin,
                            travel: [a.min(b), a.max(b)],
                            errors: AxisErrors { pdge, location },
                            max_velocity: v,
                            max_acceleration: acc,
                            max_jerk: jerk,
                            servo,
                        }
                    },
                )
        }

        fn machine() -> impl Strategy<Value = Machine> {
            (
                prop::collection::vec(any::<char>(), 0..24)
                    .prop_map(|c| c.into_iter().collect::<String>()),
                prop::collection::btree_set("[A-Za-z][A-Za-z0-9_]{0,6}", 0..5).prop_map(|names| {
                    // Axis names are unique regardless of case.
                    let mut seen = std::collections::BTreeSet::new();
                    names
                        .into_iter()
                        .filter(|n| seen.insert(n.to_ascii_lowercase()))
                        .collect::<Vec<_>>()
                }),
                prop::collection::vec(axis(), 5),
                prop::collection::vec(any::<bool>(), 5),
                (vec3(), unit(), vec3(), positive()),
            )
                .prop_map(|(name, names, axes, on_tool, (tip, dir, origin, rapid))| {
                    let axes: Vec<Axis> = names
                        .into_iter()
                        .zip(axes)
                        .map(|(n, a)| Axis { name: n, ..a })
                        .collect();
                    let (tool, work): (Vec<usize>, Vec<usize>) =
                        (0..axes.len()).partition(|&i| on_tool[i]);
                    Machine {
                        name,
                        axes,
                        tool_chain: tool,
                        workpiece_chain: work,
                        tool_tip: tip,
                        tool_direction: dir,
                        workpiece_origin: origin,
                        rapid_feed: rapid,
                    }
                })
        }

        proptest! {
            /// Any name (any character: quotes, backslashes, newlines, control
            /// characters), any axis names the schema allows and any finite numbers
            /// read back identical; a non-finite number anywhere is refused.
            #[test]
            fn any_machine_round_trips(m in machine(), header in ".{0,20}") {
                let text = machine_to_toml(&m, &[header.as_str()]).unwrap();
                let back = parse_machine(Path::new("m.toml"), &text);
                prop_assert!(back.is_ok(), "{:?}\n{}", back.err(), text);
                prop_assert_eq!(back.unwrap(), m);
            }

            /// Every machine the reader accepts passes the in-memory check.
            #[test]
            fn any_machine_that_reads_back_validates(m in machine()) {
                prop_assert!(m.validate().is_ok(), "{:?}", m.validate().err());
            }

            #[test]
            fn any_non_finite_number_is_refused(m in machine(), pick in 0usize..4, bad in prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)]) {
                let mut m = m;
                match (pick, m.axes.first_mut()) {
                    (1, Some(a)) => a.origin.z = bad,
                    (2, Some(a)) => a.errors.location[3] = bad,
                    (3, Some(a)) => a.travel[0] = bad,
                    _ => m.workpiece_origin.x = bad,
                }
                prop_assert!(machine_to_toml(&m, &[]).is_err());
            }
        }
    }
}
