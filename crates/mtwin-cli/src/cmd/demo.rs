//! `mtwin demo`: every method end to end on the bundled example machines and
//! on data simulated from known truths, a short summary of each (with the
//! source's headline figure (docs/references.md) beside ours), and the HTML report of everything.
//!
//! The steps are the library's scenarios (`mtwin::scenarios`); this command
//! runs them in order, hands each the typed results of the earlier ones,
//! writes the files the user gets from those results, prints each summary as
//! its step ends and builds the report from their sections.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use mtwin::io::Outputs;
use mtwin::model::machine_to_toml;
use mtwin::report::html::{Report, Section, render};
use mtwin::scenarios::{
    DEMO_HEADING, DemoDoc, axis_positioning, circular_test, five_axis_compensation, five_axis_twin,
    gantry_tracker, servo_identification, skiving_setup, step_text, thermal_faces,
    trunnion_ballbar, volumetric_error,
};

use crate::bundled;
use crate::output::{Format, note, print_json, progress};

#[derive(Debug, clap::Args)]
pub struct Args {
    /// Folder for the report and the files the demo writes (created if absent).
    #[arg(long, default_value = "mtwin-demo")]
    out_dir: PathBuf,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

/// The files the demo writes into `--out-dir`, all or none.
const FILES: [&str; 6] = [
    "report.html",
    "gantry-identified.toml",
    "thermal.toml",
    "faces-comp.nc",
    "ac-trunnion-twin.toml",
    "s-curve-5axis-comp.ngc",
];

/// The steps, for the progress bar.
const STEPS: [&str; 10] = [
    "machine",
    "ballbar",
    "tracker",
    "skiving",
    "thermal",
    "servo",
    "compensate",
    "twin",
    "positioning",
    "circular",
];

/// Prints step `k` (0-based) of `doc`'s summary when the output is for humans,
/// with the progress bar out of the way.
struct Printer {
    human: bool,
    bar: indicatif::ProgressBar,
    done: usize,
}

impl Printer {
    /// One step ended: its heading, time and summary.
    fn step(&mut self, title: &str, seconds: f64, body: &dyn std::fmt::Display) {
        self.done += 1;
        self.bar.inc(1);
        if let Some(next) = STEPS.get(self.done) {
            self.bar.set_message(next.to_string());
        }
        if self.human {
            let text = step_text(self.done, title, seconds, body);
            self.bar.suspend(|| print!("{text}"));
        }
    }
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let t0 = Instant::now();
    let path = |f: &str| a.out_dir.join(f);
    let mut out = Outputs::plan()
        .folder(&a.out_dir)
        .outputs(FILES.map(path))
        .begin()?;
    let human = a.format == Format::Human;
    if human {
        println!("{DEMO_HEADING}\n");
    }
    let bar = progress(STEPS.len() as u64, "demo");
    bar.set_message(STEPS[0]);
    let mut p = Printer {
        human,
        bar,
        done: 0,
    };
    let trunnion = bundled::machine("ac-trunnion.toml")?;
    let trunnion_errors = bundled::machine("ac-trunnion-with-errors.toml")?;
    let step = |name: &str| format!("demo step `{name}`");

    // 1. The machine model.
    let machine = volumetric_error::run(&trunnion_errors, &Default::default())
        .with_context(|| step("machine"))?;
    p.step(&machine.doc.title(), machine.doc.seconds, &machine.doc);

    // 2. Ballbar.
    let ballbar = trunnion_ballbar::run(&trunnion, &trunnion_errors, &Default::default())
        .with_context(|| step("ballbar"))?;
    p.step(trunnion_ballbar::TITLE, ballbar.doc.seconds, &ballbar.doc);

    // 3. Tracker.
    let tracker = gantry_tracker::run(
        &bundled::machine("afp-gantry-with-errors.toml")?,
        &bundled::machine("afp-gantry.toml")?,
        &Default::default(),
    )
    .with_context(|| step("tracker"))?;
    let identified = path("gantry-identified.toml");
    write(
        &mut out,
        &identified,
        machine_to_toml(
            &tracker.identification.machine,
            &["Identified by mtwin demo (tracker step)"],
        )?
        .as_bytes(),
    )?;
    p.step(gantry_tracker::TITLE, tracker.doc.seconds, &tracker.doc);

    // 4. Skiving.
    let skiving = skiving_setup::run(&Default::default()).with_context(|| step("skiving"))?;
    p.step(skiving_setup::TITLE, skiving.doc.seconds, &skiving.doc);

    // 5. Thermal.
    let thermal = thermal_faces::run(&Default::default()).with_context(|| step("thermal"))?;
    write(
        &mut out,
        &path("thermal.toml"),
        thermal.model.to_toml()?.as_bytes(),
    )?;
    write(
        &mut out,
        &path("faces-comp.nc"),
        &thermal.compensation.output,
    )?;
    p.step(thermal_faces::TITLE, thermal.doc.seconds, &thermal.doc);

    // 6. Servo: the twin machine, the trunnion with errors and the servos identified.
    let mut servo = servo_identification::run(&trunnion_errors, &Default::default())
        .with_context(|| step("servo"))?;
    let twin_machine = path("ac-trunnion-twin.toml");
    write(
        &mut out,
        &twin_machine,
        machine_to_toml(
            &servo.twin,
            &["The AC trunnion with errors and the servos identified by mtwin demo"],
        )?
        .as_bytes(),
    )?;
    servo.doc.machine = twin_machine.display().to_string();
    p.step(servo_identification::TITLE, servo.doc.seconds, &servo.doc);

    // 7. Geometric compensation of the five-axis program.
    let mut compensate = five_axis_compensation::run(
        &trunnion_errors,
        "s-curve-5axis.ngc",
        five_axis_compensation::S_CURVE_PROGRAM.as_bytes(),
        &Default::default(),
    )
    .with_context(|| step("compensate"))?;
    let compensated = path("s-curve-5axis-comp.ngc");
    write(&mut out, &compensated, &compensate.output)?;
    compensate.doc.compensation.out = compensated.display().to_string();
    p.step(
        five_axis_compensation::TITLE,
        compensate.doc.seconds,
        &compensate.doc,
    );

    // 8. The twin of the servo step's machine on the original and the compensated program.
    let twin = five_axis_twin::run(
        &servo.twin,
        five_axis_compensation::S_CURVE_PROGRAM.as_bytes(),
        &compensate.output,
    )
    .with_context(|| step("twin"))?;
    p.step(five_axis_twin::TITLE, twin.doc.seconds, &twin.doc);

    // 9. ISO 230-2 positioning of X, from the machine's known EXX.
    let positioning = axis_positioning::run(&trunnion_errors, &trunnion, &Default::default())
        .with_context(|| step("positioning"))?;
    p.step(
        axis_positioning::TITLE,
        positioning.doc.seconds,
        &positioning.doc,
    );

    // 10. ISO 230-4 circular test through the servos of step 6.
    let circular = circular_test::run(&servo.twin, &trunnion, &Default::default())
        .with_context(|| step("circular"))?;
    p.step(circular_test::TITLE, circular.doc.seconds, &circular.doc);
    p.bar.finish_and_clear();

    // The report: the methods first; the machine model they ran on is reference material.
    let mut sections: Vec<Section> = Vec::new();
    sections.extend(ballbar.sections()?);
    sections.extend(tracker.sections(&identified.display().to_string()));
    sections.extend(skiving.sections());
    sections.extend(thermal.sections());
    sections.extend(servo.sections());
    sections.extend(compensate.sections());
    sections.extend(twin.sections());
    sections.extend(positioning.sections());
    sections.extend(circular.sections());
    sections.extend(machine.sections());
    let report = Report {
        title: "mtwin demo report".into(),
        subtitle:
            "Every method on the bundled example machines, with data simulated from known truths."
                .into(),
        sections,
    };
    let report_path = path("report.html");
    write(&mut out, &report_path, render(&report).as_bytes())?;
    out.commit()?;
    let doc = DemoDoc {
        ballbar: ballbar.doc,
        circular: circular.doc,
        compensate: compensate.doc,
        machine: machine.doc,
        positioning: positioning.doc,
        report: report_path.display().to_string(),
        seconds: t0.elapsed().as_secs_f64(),
        servo: servo.doc,
        skiving: skiving.doc,
        thermal: thermal.doc,
        tracker: tracker.doc,
        twin: twin.doc,
    };
    match a.format {
        Format::Json => print_json(&serde_json::to_value(&doc)?),
        Format::Human => {
            println!("report → {}", doc.report);
            note(format!("demo finished in {:.1} s", doc.seconds));
            Ok(())
        }
    }
}

/// Stages `bytes` as the output file `path`.
fn write(out: &mut Outputs, path: &std::path::Path, bytes: &[u8]) -> anyhow::Result<()> {
    out.write(path, bytes)
        .with_context(|| format!("cannot write {}", path.display()))
}
