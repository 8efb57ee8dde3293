//! End-to-end scenarios: each method run on a bundled example machine against
//! data simulated from a known truth, as `mtwin demo` shows them.
//!
//! Every scenario is one module with an `Options` (the demo's settings by
//! default), a `run(inputs, &Options)` that returns a typed result, and a
//! serde document (`…Doc`, its `Display` the printed summary). A result holds
//! what later scenarios take (the identified twin machine, the compensated
//! program) as typed values, and builds its report sections (`sections()`).
//! Files are the caller's business: a scenario writes nothing.
//!
//! | module | method | truth |
//! |---|---|---|
//! | [`volumetric_error`] | machine model, forward and inverse kinematics | the AC trunnion with errors |
//! | [`trunnion_ballbar`] | ballbar, four modes ([R1] in docs/references.md) | the eight location errors of A and C |
//! | [`gantry_tracker`] | laser-tracker identification ([R2]) | the six-axis gantry with errors |
//! | [`skiving_setup`] | skiving set-up error from touch-offs | a known set-up error |
//! | [`thermal_faces`] | spindle-driven Z drift, program compensation ([R4]) | a two-time-constant thermal machine |
//! | [`servo_identification`] | axis transfer functions from command/encoder logs | known second-order servos |
//! | [`five_axis_compensation`] | geometric compensation of a five-axis program | the AC trunnion with errors |
//! | [`five_axis_twin`] | the digital twin of trajectory errors ([R5]) | the identified servos and geometry |
//! | [`axis_positioning`] | ISO 230-2 positioning of an axis, its table into the model | the positioning error `EXX` of the AC trunnion with errors |
//! | [`circular_test`] | ISO 230-4 circular test and its diagnosis, into the model | known backlash, squareness, scale mismatch; the identified X and Y servos |
//!
//! [`DemoDoc`] gathers the documents of one `mtwin demo` run.
//!
//! ```no_run
//! use mtwin::scenarios::skiving_setup;
//!
//! let run = skiving_setup::run(&skiving_setup::Options::default()).unwrap();
//! println!("{}", run.doc); // the set-up error identified, against the truth
//! ```

use std::fmt;

use serde::{Deserialize, Serialize};

pub mod axis_positioning;
pub mod circular_test;
pub mod five_axis_compensation;
pub mod five_axis_twin;
pub mod gantry_tracker;
pub mod servo_identification;
pub mod skiving_setup;
pub mod thermal_faces;
pub mod trunnion_ballbar;
pub mod volumetric_error;

/// Why a scenario could not run: the error of the method that failed.
#[derive(Debug)]
pub struct ScenarioError(Box<dyn std::error::Error + Send + Sync + 'static>);

impl ScenarioError {
    /// The error `e` of a method.
    pub fn new(e: impl Into<Box<dyn std::error::Error + Send + Sync + 'static>>) -> Self {
        ScenarioError(e.into())
    }
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for ScenarioError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}

/// What a scenario returns.
pub type Result<T> = std::result::Result<T, ScenarioError>;

/// The error type inside the scenarios: any method's error, by `?`.
type Inner<T> = std::result::Result<T, Box<dyn std::error::Error + Send + Sync + 'static>>;

/// The summary of one `mtwin demo` run (`--format json`): one document per
/// scenario, keyed by the step, the report written and the total time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DemoDoc {
    /// Step 2.
    pub ballbar: trunnion_ballbar::TrunnionBallbarDoc,
    /// Step 10.
    pub circular: circular_test::CircularTestDoc,
    /// Step 7.
    pub compensate: five_axis_compensation::FiveAxisCompensationDoc,
    /// Step 1.
    pub machine: volumetric_error::VolumetricErrorDoc,
    /// Step 9.
    pub positioning: axis_positioning::AxisPositioningDoc,
    /// The HTML report written.
    pub report: String,
    /// Wall-clock time of the whole demo, s.
    pub seconds: f64,
    /// Step 6.
    pub servo: servo_identification::ServoIdentificationDoc,
    /// Step 4.
    pub skiving: skiving_setup::SkivingSetupScenarioDoc,
    /// Step 5.
    pub thermal: thermal_faces::ThermalFacesDoc,
    /// Step 3.
    pub tracker: gantry_tracker::GantryTrackerDoc,
    /// Step 8.
    pub twin: five_axis_twin::FiveAxisTwinDoc,
}

/// First line of the demo's printed summary.
pub const DEMO_HEADING: &str =
    "mtwin demo — every method end to end on the bundled examples and known truths";

/// One step of the printed summary: `n. title (seconds)`, then the lines of
/// `body` indented by three spaces, then an empty line.
pub fn step_text(n: usize, title: &str, seconds: f64, body: &dyn fmt::Display) -> String {
    let mut s = format!("{n}. {title} ({seconds:.1} s)\n");
    for l in body.to_string().lines() {
        s.push_str("   ");
        s.push_str(l);
        s.push('\n');
    }
    s.push('\n');
    s
}

impl DemoDoc {
    /// The steps in the order the demo runs them: title, seconds, summary.
    pub fn steps(&self) -> [(String, f64, &dyn fmt::Display); 10] {
        [
            (self.machine.title(), self.machine.seconds, &self.machine),
            (
                trunnion_ballbar::TITLE.into(),
                self.ballbar.seconds,
                &self.ballbar,
            ),
            (
                gantry_tracker::TITLE.into(),
                self.tracker.seconds,
                &self.tracker,
            ),
            (
                skiving_setup::TITLE.into(),
                self.skiving.seconds,
                &self.skiving,
            ),
            (
                thermal_faces::TITLE.into(),
                self.thermal.seconds,
                &self.thermal,
            ),
            (
                servo_identification::TITLE.into(),
                self.servo.seconds,
                &self.servo,
            ),
            (
                five_axis_compensation::TITLE.into(),
                self.compensate.seconds,
                &self.compensate,
            ),
            (five_axis_twin::TITLE.into(), self.twin.seconds, &self.twin),
            (
                axis_positioning::TITLE.into(),
                self.positioning.seconds,
                &self.positioning,
            ),
            (
                circular_test::TITLE.into(),
                self.circular.seconds,
                &self.circular,
            ),
        ]
    }
}

/// The printed summary: the heading, every step, the report written.
impl fmt::Display for DemoDoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "{DEMO_HEADING}\n")?;
        for (k, (title, seconds, body)) in self.steps().into_iter().enumerate() {
            f.write_str(&step_text(k + 1, &title, seconds, body))?;
        }
        writeln!(f, "report → {}", self.report)
    }
}

/// Seconds since `t0`.
fn since(t0: std::time::Instant) -> f64 {
    t0.elapsed().as_secs_f64()
}

#[cfg(test)]
mod tests;
