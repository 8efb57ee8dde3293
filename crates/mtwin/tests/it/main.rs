//! The library's integration tests, one test binary (so `cargo test` links
//! the library once): each module was once its own file under `tests/`. Run
//! one family with a name filter, e.g. `cargo test -p mtwin --test it gcode_props::`.
//!
//! Proptest keeps the regression seeds of `gcode_props` in
//! `tests/proptest-regressions/gcode_props.txt` (its rule: the sibling
//! `proptest-regressions` folder of the folder holding `main.rs`).

#[path = "../../src/test_support.rs"]
mod shared;

mod common;

mod ballbar_circular;
mod controller_demo;
mod controller_formats;
mod controller_roundtrip;
mod cutter_comp;
mod gcode_conformance;
mod gcode_corpus;
mod gcode_props;
mod generated_programs;
mod planner;
mod planner_jerk;
mod positioning;
mod rs274;
mod thermal_inputs;
mod thermal_probing;
mod thermal_real;
mod thermal_truth;
