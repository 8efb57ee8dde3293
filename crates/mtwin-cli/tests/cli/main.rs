//! The command-line tool's integration tests, one test binary (so `cargo
//! test` links the library and the tool once): each module was once its own
//! file under `tests/`. Run one family with a name filter, e.g.
//! `cargo test -p mtwin-cli --test cli cli_gcode::`.
//!
//! The library's runs on LinuxCNC's simulator (`linuxcnc_sim`,
//! `linuxcnc_closed_loop`, `linuxcnc_thermal`) live here, not in the library's
//! `tests/it`: they mostly wait for the simulator's real time, and here that
//! wait overlaps the Python wheel build and the CPU-bound command tests instead
//! of adding to the run of `tests/it` (BENCHMARKS.md, "Test suite time").

mod common;
#[path = "../../../mtwin/src/test_support.rs"]
mod shared;

mod bad_input;
mod browser;
mod cli_ballbar;
mod cli_ballbar_circular;
mod cli_compensate;
mod cli_dialects;
mod cli_export;
mod cli_gcode;
mod cli_import;
mod cli_model;
mod cli_parquet;
mod cli_planner;
mod cli_positioning;
mod cli_predict;
mod cli_report;
mod cli_servo;
mod cli_skiving;
mod cli_testpiece;
mod cli_thermal;
mod cli_thermal_compensate;
mod cli_thermal_log;
mod cli_tracker;
mod cli_twin;
mod docs;
mod linuxcnc_closed_loop;
mod linuxcnc_sim;
mod linuxcnc_thermal;
mod outputs;
mod python;
