//! The workspace's integration tests, one test binary (so that `cargo test`
//! links the library and the tool once): the command-line tool's tests
//! (`cli_*`, `docs`, `outputs`, `bad_input`, `python`, `browser`), the
//! library's own integration tests (G-code conformance and the `rs274`
//! differential, planners, thermal, ballbar, controller formats) and the runs
//! on LinuxCNC's simulator (`linuxcnc_*`). Run one family with a name filter,
//! e.g. `cargo test --test cli gcode_props::` or `cargo test --test cli cli_gcode::`.
//!
//! One binary also means one test run: the simulator runs mostly wait for its
//! real time, and that wait overlaps the CPU-bound tests of every family
//! instead of adding to them (BENCHMARKS.md, "Test suite time").
//!
//! Proptest keeps the regression seeds of `gcode_props` in
//! `tests/proptest-regressions/gcode_props.txt` (its rule: the sibling
//! `proptest-regressions` folder of the folder holding `main.rs`).

mod common;
#[path = "../../../mtwin/src/test_support.rs"]
mod shared;

mod bad_input;
mod ballbar_circular;
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
mod cli_tree;
mod cli_twin;
mod controller_demo;
mod controller_formats;
mod controller_roundtrip;
mod cutter_comp;
mod docs;
mod gcode_conformance;
mod gcode_corpus;
mod gcode_props;
mod generated_programs;
mod linuxcnc_closed_loop;
mod linuxcnc_sim;
mod linuxcnc_thermal;
mod outputs;
mod planner;
mod planner_jerk;
mod positioning;
mod python;
mod rs274;
mod thermal_inputs;
mod thermal_probing;
mod thermal_real;
mod thermal_truth;
