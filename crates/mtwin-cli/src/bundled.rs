//! The example machines shipped in `examples/machines/`, built into the binary so `mtwin demo`
//! runs from any folder with no files around it.

use std::path::Path;

use mtwin::model::{Machine, parse_machine};

/// (file name, TOML text) of every bundled example machine.
pub const MACHINES: &[(&str, &str)] = &[
    (
        "ac-trunnion.toml",
        include_str!("../../../examples/machines/ac-trunnion.toml"),
    ),
    (
        "ac-trunnion-with-errors.toml",
        include_str!("../../../examples/machines/ac-trunnion-with-errors.toml"),
    ),
    (
        "afp-gantry.toml",
        include_str!("../../../examples/machines/afp-gantry.toml"),
    ),
    (
        "afp-gantry-with-errors.toml",
        include_str!("../../../examples/machines/afp-gantry-with-errors.toml"),
    ),
    (
        "skiving.toml",
        include_str!("../../../examples/machines/skiving.toml"),
    ),
    (
        "skiving-with-errors.toml",
        include_str!("../../../examples/machines/skiving-with-errors.toml"),
    ),
];

/// A bundled machine by file name.
pub fn machine(name: &str) -> anyhow::Result<Machine> {
    let (_, text) = MACHINES
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| anyhow::anyhow!("no bundled machine `{name}`"))?;
    parse_machine(Path::new(&format!("examples/machines/{name}")), text)
        .map_err(super::cmd::common_diag)
}
