//! The example machines shipped in `examples/machines/`, built into the
//! library so a program (and `mtwin demo`) can use them from any folder.
//!
//! ```
//! let m = mtwin::examples::machine("ac-trunnion").unwrap();
//! assert_eq!(m.n_axes(), 5);
//! assert!(mtwin::examples::NAMES.contains(&"skiving-with-errors"));
//! ```

use std::path::Path;

use crate::io::Diagnostics;
use crate::model::{Machine, parse_machine};

/// (name, TOML text) of every bundled example machine; the name is the file
/// name in `examples/machines/` without `.toml`.
pub const MACHINES: &[(&str, &str)] = &[
    (
        "ac-trunnion",
        include_str!("../../../examples/machines/ac-trunnion.toml"),
    ),
    (
        "ac-trunnion-with-errors",
        include_str!("../../../examples/machines/ac-trunnion-with-errors.toml"),
    ),
    (
        "ac-trunnion-twin",
        include_str!("../../../examples/machines/ac-trunnion-twin.toml"),
    ),
    (
        "afp-gantry",
        include_str!("../../../examples/machines/afp-gantry.toml"),
    ),
    (
        "afp-gantry-with-errors",
        include_str!("../../../examples/machines/afp-gantry-with-errors.toml"),
    ),
    (
        "skiving",
        include_str!("../../../examples/machines/skiving.toml"),
    ),
    (
        "skiving-with-errors",
        include_str!("../../../examples/machines/skiving-with-errors.toml"),
    ),
];

/// Names of the bundled machines, in the order of [`MACHINES`].
pub const NAMES: &[&str] = &[
    "ac-trunnion",
    "ac-trunnion-with-errors",
    "ac-trunnion-twin",
    "afp-gantry",
    "afp-gantry-with-errors",
    "skiving",
    "skiving-with-errors",
];

/// The TOML text of the bundled machine `name` (with or without `.toml`).
pub fn machine_toml(name: &str) -> Option<&'static str> {
    let name = name.strip_suffix(".toml").unwrap_or(name);
    MACHINES.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
}

/// The bundled machine `name` (with or without `.toml`), e.g.
/// `"ac-trunnion-with-errors"`.
///
/// # Errors
/// An unknown name, as a diagnostic listing the known ones; a bundled file
/// that does not read (a defect, caught by this module's tests).
pub fn machine(name: &str) -> Result<Machine, Diagnostics> {
    let base = name.strip_suffix(".toml").unwrap_or(name);
    let path = format!("examples/machines/{base}.toml");
    let Some(text) = machine_toml(base) else {
        return Err(crate::io::Diagnostic::whole(
            Path::new(&path),
            format!(
                "no bundled machine `{name}` (bundled: {})",
                NAMES.join(", ")
            ),
        )
        .into());
    };
    parse_machine(Path::new(&path), text)
}

/// A Cartesian three-axis machine built in code: linear axes `X`, `Y`, `Z`
/// along the machine's x, y, z, all in the tool chain (no workpiece axes),
/// travel ±`half_travel` mm on each, tool tip at the spindle point, no
/// geometric errors, no velocity, acceleration or jerk limits, a rapid feed
/// of 6000 mm/min: the smallest machine a G-code program runs on. Set the
/// limits on [`Machine::axes`] where a planner needs them.
///
/// ```
/// let m = mtwin::examples::xyz(500.0);
/// assert_eq!(m.n_axes(), 3);
/// assert_eq!(m.axes[2].travel, [-500.0, 500.0]);
/// ```
pub fn xyz(half_travel: f64) -> Machine {
    use crate::model::{Axis, AxisKind};
    let axes = [
        ("X", [1.0, 0.0, 0.0]),
        ("Y", [0.0, 1.0, 0.0]),
        ("Z", [0.0, 0.0, 1.0]),
    ]
    .into_iter()
    .map(|(name, d)| {
        Axis::new(
            name,
            AxisKind::Linear,
            d,
            [0.0; 3],
            [-half_travel, half_travel],
        )
    })
    .collect();
    Machine {
        name: "xyz".into(),
        axes,
        tool_chain: vec![0, 1, 2],
        workpiece_chain: vec![],
        tool_tip: nalgebra::Vector3::zeros(),
        tool_direction: nalgebra::Vector3::z(),
        workpiece_origin: nalgebra::Vector3::zeros(),
        rapid_feed: 6000.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_bundled_machine_reads_validates_and_is_listed() {
        assert_eq!(MACHINES.len(), NAMES.len());
        for ((n, _), listed) in MACHINES.iter().zip(NAMES) {
            assert_eq!(n, listed);
            let m = machine(n).unwrap_or_else(|e| panic!("{n}: {e}"));
            m.validate().unwrap_or_else(|e| panic!("{n}: {e}"));
            assert_eq!(machine(&format!("{n}.toml")).unwrap(), m);
        }
        // Every file of the folder is bundled.
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/machines");
        let mut files: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|f| f.ends_with(".toml"))
            .collect();
        files.sort();
        let mut names: Vec<String> = NAMES.iter().map(|n| format!("{n}.toml")).collect();
        names.sort();
        assert_eq!(files, names);
    }

    #[test]
    fn only_five_axis_machines_with_two_rotary_axes_orient_the_tool() {
        let ac = machine("ac-trunnion").unwrap();
        assert!(ac.orients_tool()); // X Y Z + A C
        assert!(!machine("afp-gantry").unwrap().orients_tool()); // six axes
        let mut three_rotary = ac.clone();
        let x = three_rotary.axis_index("X").unwrap();
        three_rotary.axes[x].kind = crate::model::AxisKind::Rotary;
        assert_eq!(three_rotary.n_rotary(), 3);
        assert!(!three_rotary.orients_tool());
        let mut four = ac;
        let c = four.axis_index("C").unwrap();
        four.axes.remove(c);
        assert!(!four.orients_tool());
    }

    #[test]
    fn unknown_names_are_refused_with_the_list() {
        let e = machine("no-such").unwrap_err().to_string();
        assert!(
            e.contains("no bundled machine `no-such`") && e.contains("skiving"),
            "{e}"
        );
    }

    #[test]
    fn validate_refuses_what_the_reader_refuses() {
        let good = machine("ac-trunnion-with-errors").unwrap();
        let mut m = good.clone();
        m.tool_chain.push(m.workpiece_chain[0]);
        let e = m.validate().unwrap_err().to_string();
        assert!(e.contains("appears 2 times"), "{e}");
        let mut m = good.clone();
        m.tool_chain.push(17);
        assert!(m.validate().unwrap_err().to_string().contains("index 17"));
        let mut m = good.clone();
        m.tool_tip.x = f64::NAN;
        assert!(m.validate().is_err());
        let mut m = good;
        m.axes[0].name = "1bad".into();
        assert!(
            m.validate()
                .unwrap_err()
                .to_string()
                .contains("must start with a letter")
        );
    }
}
