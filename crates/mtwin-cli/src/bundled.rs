//! The example machines bundled in the library ([`mtwin::examples`]), so `mtwin demo` runs from
//! any folder with no files around it.

use mtwin::model::Machine;

/// A bundled machine by file name (`ac-trunnion.toml`).
pub fn machine(name: &str) -> anyhow::Result<Machine> {
    mtwin::examples::machine(name).map_err(super::cmd::common_diag)
}
