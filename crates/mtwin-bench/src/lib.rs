//! Criterion benchmarks of the `mtwin` library, one file per method under
//! `benches/`: `cargo bench -p mtwin-bench --bench kinematics` (see BENCHMARKS.md).
//!
//! A separate package so that `cargo test` at the workspace root, which builds
//! the dev-dependencies of its default members, does not compile criterion.
