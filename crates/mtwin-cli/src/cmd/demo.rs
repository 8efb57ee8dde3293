//! `mtwin demo`: every method end to end on the bundled example machines and
//! on data simulated from known truths, a short summary of each (with the
//! source's headline figure (docs/references.md) beside ours), and the HTML report of everything.
//!
//! Each step is one function returning its summary lines, its JSON summary and
//! its report sections, built by the same library functions `mtwin report`
//! uses on saved files.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use mtwin::fit::Options;
use mtwin::io::Outputs;
use mtwin::kinematics::{IkOptions, IkTarget, Kinematics};
use mtwin::methods::ballbar::{
    self, BallbarMode, ModeData, Pige, Piges, Rig, SimulationSpec, Trunnion, angle_range,
    simulate_modes,
};
use mtwin::methods::compensate::{CompensateOptions, Compensator};
use mtwin::methods::skiving::{self, Geometry, SetupError, closed_form, program::Plan};
use mtwin::methods::thermal::{self, ThermalFitOptions, TruthMachine};
use mtwin::methods::tracker::{self, IdentifyOptions};
use mtwin::model::{Machine, ParameterSet, ServoTable, machine_to_toml};
use mtwin::report::html::{Block, Headline, Report, Section, render};
use mtwin::report::sections;
use mtwin::report::sections::thermal::DriftCurve;
use mtwin::report::twin::TwinRow;
use mtwin::sysid::{Servo, ServoFitOptions, ServoLog, fit_servo};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use serde_json::{Value, json};

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

/// What one step hands back.
struct Step {
    /// Key in the JSON summary.
    key: &'static str,
    /// Heading of the printed summary.
    title: String,
    /// Lines of the printed summary.
    lines: Vec<String>,
    /// JSON summary (headline figures).
    json: Value,
    /// Report sections.
    sections: Vec<Section>,
}

/// Deterministic poses spread over the travels (a low-discrepancy sequence).
fn spread_poses(m: &Machine, n: usize) -> Vec<Vec<f64>> {
    const PRIMES: [f64; 8] = [2.0, 3.0, 5.0, 7.0, 11.0, 13.0, 17.0, 19.0];
    (1..=n)
        .map(|k| {
            m.axes
                .iter()
                .enumerate()
                .map(|(i, a)| {
                    // Van der Corput radical inverse in base PRIMES[i].
                    let (mut f, mut r, mut x) = (1.0, 0.0, k as f64);
                    let b = PRIMES[i % PRIMES.len()];
                    while x > 0.0 {
                        f /= b;
                        r += f * (x % b);
                        x = (x / b).floor();
                    }
                    a.travel[0] + (a.travel[1] - a.travel[0]) * r
                })
                .collect()
        })
        .collect()
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

pub fn run(a: Args) -> anyhow::Result<()> {
    let t0 = Instant::now();
    let mut out = Outputs::plan()
        .folder(&a.out_dir)
        .outputs(FILES.map(|f| a.out_dir.join(f)))
        .begin()?;
    let human = a.format == Format::Human;
    if human {
        println!("mtwin demo — every method end to end on the bundled examples and known truths\n");
    }
    type StepFn = fn(&Args, &mut Outputs) -> anyhow::Result<Step>;
    let steps: [(&str, StepFn); 8] = [
        ("machine", machine_step),
        ("ballbar", ballbar_step),
        ("tracker", tracker_step),
        ("skiving", skiving_step),
        ("thermal", thermal_step),
        ("servo", servo_step),
        ("compensate", compensate_step),
        ("twin", twin_step),
    ];
    let bar = progress(steps.len() as u64, "demo");
    let mut report = Report {
        title: "mtwin demo report".into(),
        subtitle:
            "Every method on the bundled example machines, with data simulated from known truths."
                .into(),
        sections: Vec::new(),
    };
    let mut summary = serde_json::Map::new();
    for (k, (name, f)) in steps.iter().enumerate() {
        bar.set_message(name.to_string());
        let t = Instant::now();
        let step = f(&a, &mut out).with_context(|| format!("demo step `{name}`"))?;
        let dt = t.elapsed().as_secs_f64();
        bar.inc(1);
        if human {
            bar.suspend(|| {
                println!("{}. {} ({dt:.1} s)", k + 1, step.title);
                for l in &step.lines {
                    println!("   {l}");
                }
                println!();
            });
        }
        let mut j = step.json;
        j["seconds"] = json!(dt);
        summary.insert(step.key.into(), j);
        report.sections.extend(step.sections);
    }
    bar.finish_and_clear();
    // The methods first; the machine model they ran on is reference material.
    let (machine, mut methods): (Vec<Section>, Vec<Section>) =
        report.sections.into_iter().partition(|s| s.id == "machine");
    methods.extend(machine);
    report.sections = methods;
    let path = a.out_dir.join("report.html");
    out.write(&path, render(&report).as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))?;
    out.commit()?;
    let total = t0.elapsed().as_secs_f64();
    match a.format {
        Format::Json => {
            summary.insert("report".into(), json!(path.display().to_string()));
            summary.insert("seconds".into(), json!(total));
            print_json(&Value::Object(summary))
        }
        Format::Human => {
            println!("report → {}", path.display());
            note(format!("demo finished in {total:.1} s"));
            Ok(())
        }
    }
}

/// Step 1: The machine model, its volumetric error and inverse kinematics.
fn machine_step(_: &Args, _: &mut Outputs) -> anyhow::Result<Step> {
    let m = bundled::machine("ac-trunnion-with-errors.toml")?;
    let k = Kinematics::new(&m);
    let kn = Kinematics::nominal(&m);
    let poses = spread_poses(&m, 20_000);
    let flat: Vec<f64> = poses.iter().flatten().copied().collect();
    let t = Instant::now();
    let actual = k.poses(&flat);
    let dt = t.elapsed().as_secs_f64();
    let nominal = kn.poses(&flat);
    let (mut max, mut sum2, mut amax) = (0.0f64, 0.0, 0.0f64);
    for (a, n) in actual.iter().zip(&nominal) {
        let e = (a.tip - n.tip).norm();
        max = max.max(e);
        sum2 += e * e;
        amax = amax.max(a.axis.cross(&n.axis).norm().atan2(a.axis.dot(&n.axis)));
    }
    let rms = (sum2 / poses.len() as f64).sqrt();
    // Compensation by inverse kinematics on the actual machine.
    let all = vec![true; m.n_axes()];
    let (mut worst, mut done) = (0.0f64, 0);
    for q in poses.iter().take(2000) {
        let target = kn.pose(q);
        let Ok(sol) = k.inverse(
            &IkTarget {
                tip: target.tip,
                axis: Some(target.axis),
            },
            q,
            &all,
            &IkOptions::default(),
        ) else {
            continue;
        };
        worst = worst.max((k.pose(&sol).tip - target.tip).norm());
        done += 1;
    }
    let mut s = sections::machine::section(
        &m,
        "machine",
        "Machine model: AC double-turntable with errors",
    );
    s.blocks.insert(
        1,
        Block::Text(format!(
            "Volumetric error over {} poses spread through the work volume: largest {:.1} µm, RMS {:.1} µm; \
             tool-axis error up to {:.1} µrad. Inverse kinematics on the actual machine brings {done} poses \
             onto their nominal targets to {:.1e} mm.",
            poses.len(),
            max * 1e3,
            rms * 1e3,
            amax * 1e6,
            worst
        )),
    );
    Ok(Step {
        key: "machine",
        title: format!(
            "Machine model: {} ({} axes, {} geometric error terms)",
            m.name,
            m.n_axes(),
            m.n_error_terms()
        ),
        lines: vec![
            format!(
                "volumetric error over {} poses: max {:.1} µm, RMS {:.1} µm; tool axis max {:.1} µrad",
                poses.len(),
                max * 1e3,
                rms * 1e3,
                amax * 1e6
            ),
            format!(
                "exact forward kinematics with errors: {:.1} million poses/s; inverse kinematics of {done} poses leaves {:.1e} mm",
                poses.len() as f64 / dt / 1e6,
                worst
            ),
        ],
        json: json!({"poses": poses.len(), "max_error_mm": max, "rms_error_mm": rms,
            "max_axis_error_rad": amax, "ik_poses": done, "ik_max_error_mm": worst}),
        sections: vec![s],
    })
}

/// Step 2: Ballbar: four modes simulated on the machine with errors, the eight
/// PIGEs identified on the nominal model, the offsets compensated.
fn ballbar_step(_: &Args, _: &mut Outputs) -> anyhow::Result<Step> {
    // The truth: the nominal trunnion with the eight PIGEs of the example
    // machine with errors (the ballbar sees the rotary axes; the source paper [R1] takes
    // the linear axes as calibrated).
    let nominal = bundled::machine("ac-trunnion.toml")?;
    let with_errors = bundled::machine("ac-trunnion-with-errors.toml")?;
    let t = Trunnion::of(&nominal)?;
    let true_piges = Piges::from_machine(&with_errors, &Trunnion::of(&with_errors)?);
    let mut truth = nominal.clone();
    true_piges.write_to(&mut truth, &t);
    let mut rig = Rig::source_paper();
    rig.setup = ballbar::SetupError {
        ex: -0.0403,
        ey: -0.0765,
    };
    let specs: Vec<(BallbarMode, SimulationSpec)> = BallbarMode::ALL
        .iter()
        .map(|&m| {
            let angles = if m.moves_a() {
                angle_range(-90.0, 90.0, 5.0)
            } else {
                angle_range(0.0, 360.0, 5.0)
            };
            (
                m,
                SimulationSpec {
                    rig,
                    noise: 0.0003,
                    angles_deg: angles,
                },
            )
        })
        .collect();
    let data = simulate_modes(&truth, &specs, 1)?;
    let refs: [Option<&ModeData>; 4] = [0, 1, 2, 3].map(|i| Some(&data[i]));
    let id = ballbar::identify(&nominal, &rig, &refs, &Options::default())?;
    // The headline of the source paper [R1] (its table 4): the largest absolute location offset
    // identified before compensation, and identified again from a second
    // measurement of the machine after the four offsets were compensated
    // (its offsets minus the identified ones).
    const OFFSETS: [Pige; 4] = [Pige::EY0A, Pige::EZ0A, Pige::EX0C, Pige::EY0C];
    let mut corrected = true_piges;
    for p in OFFSETS {
        corrected.set(p, true_piges.get(p) - id.piges.get(p));
    }
    let mut after_machine = truth.clone();
    corrected.write_to(&mut after_machine, &t);
    let again = simulate_modes(&after_machine, &specs, 2)?;
    let refs_again: [Option<&ModeData>; 4] = [0, 1, 2, 3].map(|i| Some(&again[i]));
    let id_again = ballbar::identify(&nominal, &rig, &refs_again, &Options::default())?;
    let largest_offset = |p: &Piges| {
        OFFSETS
            .iter()
            .map(|&o| p.get(o).abs())
            .fold(0.0f64, f64::max)
    };
    let (before, after) = (largest_offset(&id.piges), largest_offset(&id_again.piges));
    // The ballbar's own view: largest ΔL of an ideally set bar (no set-up
    // error, no noise) before and after; the tilts, not compensated, remain.
    let clean: Vec<(BallbarMode, SimulationSpec)> = specs
        .iter()
        .map(|(m, s)| {
            let mut s = s.clone();
            s.noise = 0.0;
            s.rig.setup = ballbar::SetupError::default();
            (*m, s)
        })
        .collect();
    let largest_dl = |machine: &Machine| -> anyhow::Result<f64> {
        Ok(simulate_modes(machine, &clean, 1)?
            .iter()
            .flat_map(|m| m.lengths.iter())
            .map(|l| (l - rig.length).abs())
            .fold(0.0f64, f64::max))
    };
    let (dl_before, dl_after) = (largest_dl(&truth)?, largest_dl(&after_machine)?);
    let mut worst_err = 0.0f64;
    for p in Pige::ALL {
        worst_err = worst_err
            .max((id.piges.get(p) - true_piges.get(p)).abs() * if p.is_tilt() { 1e6 } else { 1e3 });
    }
    let figures: Vec<(String, String)> = BallbarMode::ALL
        .iter()
        .filter_map(|&m| {
            ballbar::plot::polar_plot(&id, m, &data[m.index()]).map(|svg| {
                (
                    format!(
                        "{}: measured ΔL, the identified model's fit, and the prediction after compensating the four offsets (µm).",
                        m.label()
                    ),
                    svg,
                )
            })
        })
        .collect();
    let mut s = sections::ballbar::section(
        &ballbar::BallbarIdentifyDoc::new(&id, None, Vec::new()),
        "ballbar identify",
        figures,
    )?;
    s.blocks.insert(
        1,
        Block::Headlines(vec![Headline {
            label: "largest location offset of A and C: identified before → re-identified after compensating the four offsets".into(),
            ours: format!("{:.1} → {:.2} µm", before * 1e3, after * 1e3),
            source: "203.5 → 5.1 µm".into(),
        }]),
    );
    Ok(Step {
        key: "ballbar",
        title: "Ballbar: the eight location errors (PIGEs) of A and C from four modes".into(),
        lines: vec![
            format!(
                "identified on the nominal model from {} simulated readings (0.3 µm noise); largest difference from the truth {:.2} µm / µrad",
                data.iter().map(|d| d.lengths.len()).sum::<usize>(),
                worst_err
            ),
            format!(
                "largest location offset {:.1} µm → {:.2} µm re-identified after compensating the four offsets (source paper [R1]: 203.5 → 5.1 µm)",
                before * 1e3,
                after * 1e3
            ),
            format!(
                "largest ballbar ΔL {:.1} µm → {:.1} µm (the four tilts are not compensated, as in the source paper [R1])",
                dl_before * 1e3,
                dl_after * 1e3
            ),
        ],
        json: json!({"largest_offset_before_mm": before, "largest_offset_after_mm": after,
            "largest_deviation_before_mm": dl_before, "largest_deviation_after_mm": dl_after,
            "source_before_mm": 0.2035, "source_after_mm": 0.0051, "largest_error_vs_truth_um_or_urad": worst_err}),
        sections: vec![s],
    })
}

/// Poses along the four body diagonals of the linear axes' box (80 % of the
/// travels), other axes at mid travel; `n` per diagonal.
fn body_diagonals(m: &Machine, n: usize) -> Vec<Vec<f64>> {
    let lin: Vec<usize> = (0..m.n_axes())
        .filter(|&i| m.axes[i].kind == mtwin::model::AxisKind::Linear)
        .take(3)
        .collect();
    let mut out = Vec::new();
    for corner in 0..4u32 {
        for k in 0..n {
            let s = 0.1 + 0.8 * k as f64 / (n - 1) as f64;
            let q = m
                .axes
                .iter()
                .enumerate()
                .map(|(i, a)| {
                    let (lo, hi) = (a.travel[0], a.travel[1]);
                    match lin.iter().position(|&j| j == i) {
                        // Diagonal `corner` flips the direction of axis j when bit j is set.
                        Some(j) if j > 0 && corner & (1 << (j - 1)) != 0 => {
                            lo + (hi - lo) * (1.0 - s)
                        }
                        Some(_) => lo + (hi - lo) * s,
                        None => 0.5 * (lo + hi),
                    }
                })
                .collect();
            out.push(q);
        }
    }
    out
}

/// Step 3: Tracker: plan 180 poses, simulate the measurement of the gantry with
/// errors, identify `pdge:cheb3,location`, validate on the body diagonals.
fn tracker_step(a: &Args, out: &mut Outputs) -> anyhow::Result<Step> {
    let truth = bundled::machine("afp-gantry-with-errors.toml")?;
    let model = bundled::machine("afp-gantry.toml")?;
    let spec = "pdge:cheb3,location";
    let params = ParameterSet::from_spec(&model, spec).map_err(|e| anyhow::anyhow!("{e}"))?;
    let plan = tracker::plan::plan(&model, &params, 1000, 180, 0.010, 1)?;
    let points = tracker::simulate::simulate_seeded(&truth, &plan.poses, 0.010, 1);
    let id = tracker::identify(
        &model,
        &params,
        &points,
        &IdentifyOptions::default(),
        &|_| {},
    )?;
    let identified = a.out_dir.join("gantry-identified.toml");
    out.write(
        &identified,
        machine_to_toml(&id.machine, &["Identified by mtwin demo (tracker step)"])?.as_bytes(),
    )
    .with_context(|| format!("cannot write {}", identified.display()))?;
    let diag = body_diagonals(&model, 25);
    let check = tracker::simulate::simulate_seeded(&truth, &diag, 0.010, 2);
    let v = tracker::validate(&id.machine, &check);
    let r = &id.report;
    let id_doc =
        tracker::TrackerIdentifyDoc::new(&id, points.len(), &identified.display().to_string());
    let before: Vec<f64> = v.errors_before.iter().map(|e| e.norm()).collect();
    let after: Vec<f64> = v.errors_after.iter().map(|e| e.norm()).collect();
    let mut vs = sections::tracker::validate_section(
        &tracker::TrackerValidateDoc::from(&v),
        Some((&before, &after)),
    );
    let ch = &v.change.distance;
    vs.blocks.insert(
        1,
        Block::Headlines(vec![
            Headline {
                label: "body diagonals, change of the largest |Δp|".into(),
                ours: format!("{:.0} %", ch.max),
                source: "−70 %".into(),
            },
            Headline {
                label: "body diagonals, change of the mean |Δp|".into(),
                ours: format!("{:.0} %", ch.mean),
                source: "−81 %".into(),
            },
        ]),
    );
    Ok(Step {
        key: "tracker",
        title: "Tracker: volumetric error model of the six-axis gantry".into(),
        lines: vec![
            format!(
                "planned {} of 1000 candidate poses (D-optimal), simulated with 10 µm noise; fit `{spec}`: rank {} of {} parameters, condition number {:.2e}",
                plan.poses.len(),
                r.identifiability.rank,
                r.estimates.len(),
                r.condition_number
            ),
            format!(
                "validation on the four body diagonals ({} points): |Δp| max {:.0} → {:.0} µm ({:.0} %), mean {:.0} → {:.0} µm ({:.0} %) (source paper [R2]: max −70 %, mean −81 %)",
                v.points,
                v.before.distance.max * 1e3,
                v.after.distance.max * 1e3,
                ch.max,
                v.before.distance.mean * 1e3,
                v.after.distance.mean * 1e3,
                ch.mean
            ),
        ],
        json: json!({"rank": r.identifiability.rank, "parameters": r.estimates.len(),
            "diagonal_change_max_percent": ch.max, "diagonal_change_mean_percent": ch.mean,
            "source_change_max_percent": -70.0, "source_change_mean_percent": -81.0}),
        sections: vec![
            sections::tracker::identify_section(&id_doc),
            vs,
            sections::machine::section_against(
                &id.machine,
                Some(&truth),
                "gantry-identified",
                "Identified gantry: error curves over the travels",
            ),
        ],
    })
}

/// Step 4: Skiving: twelve touch-offs simulated with a known set-up error.
fn skiving_step(_: &Args, _: &mut Outputs) -> anyhow::Result<Step> {
    let g = Geometry::new(80.0, 150.0, 40.0, 60.0)?;
    let plan = Plan::standard(0.0, &g).touches(&g)?;
    let truth = SetupError {
        dgx: 0.03,
        dgy: -0.02,
        exz: 2e-4,
        ezy: -1e-4,
    };
    let mut touches = Vec::new();
    for seed in 1..=2 {
        touches.extend(skiving::simulate::simulate(
            &plan,
            &g,
            &truth,
            Some(skiving::simulate::Noise { sigma: 0.001, seed }),
        )?);
    }
    let sol = skiving::identify(&touches, &g, &skiving::Options::with_noise(Some(0.001)))?;
    let first = closed_form::first_order(&touches[..6], &g).ok();
    let e = sol.estimate;
    let s = sections::skiving::section(&skiving::doc::SkivingSetupDoc::new(
        &sol,
        first,
        touches.len(),
    ));
    let err = [
        (e.dgx - truth.dgx) * 1e3,
        (e.dgy - truth.dgy) * 1e3,
        (e.exz - truth.exz) * 1e6,
        (e.ezy - truth.ezy) * 1e6,
    ];
    Ok(Step {
        key: "skiving",
        title: "Skiving: workpiece set-up error from touch-offs".into(),
        lines: vec![
            format!(
                "{} touches (1 µm noise): δgx {:.2} µm, δgy {:.2} µm, εxz {:.1} µrad, εzy {:.1} µrad",
                touches.len(),
                e.dgx * 1e3,
                e.dgy * 1e3,
                e.exz * 1e6,
                e.ezy * 1e6
            ),
            format!(
                "truth 30, −20 µm, 200, −100 µrad: off by {:.2}, {:.2} µm, {:.2}, {:.2} µrad",
                err[0], err[1], err[2], err[3]
            ),
        ],
        json: json!({"dgx": e.dgx, "dgy": e.dgy, "exz": e.exz, "ezy": e.ezy,
            "truth": {"dgx": truth.dgx, "dgy": truth.dgy, "exz": truth.exz, "ezy": truth.ezy}}),
        sections: vec![s],
    })
}

const FACE_Z: f64 = -50.0;

/// A face milled at Z = −50 (20 passes tagged `(face n)`).
fn face(n: u32, out: &mut String) {
    out.push_str(&format!("G0 X0 Y0\nG1 Z{FACE_Z} F500\n"));
    for i in 0..20 {
        let x = if i % 2 == 0 { 200 } else { 0 };
        out.push_str(&format!("G1 X{x} F2000 (face {n})\nG1 Y{}\n", (i + 1) * 5));
    }
    out.push_str("G0 Z5\n");
}

/// Step 5: Thermal: probing runs of a known two-time-constant machine, ARX fit per
/// height, and the check of the source paper [R4]: a face milled cold and again after an hour at
/// varying speed, without and with the program compensated.
fn thermal_step(a: &Args, out: &mut Outputs) -> anyhow::Result<Step> {
    let mut truth = TruthMachine::demo();
    truth.fast_gain_mm *= 0.5;
    truth.slow_gain_mm *= 0.5;
    let measured = [-50.0, -150.0, -250.0, -350.0];
    let steps = [2000.0, 6000.0, 0.0, 8000.0, 4000.0, 1000.0, 7000.0, 3000.0];
    let runs = vec![
        ("const4000", vec![4000.0; 48]),
        ("const8000", vec![8000.0; 48]),
        ("steps", steps.iter().flat_map(|&s| [s; 6]).collect()),
    ];
    let text = truth.training_csv(&runs, &measured, 1e-4, 11);
    let table = mtwin::io::Table::from_reader(std::path::Path::new("TRAIN.csv"), text.as_bytes())
        .map_err(super::common::diag)?;
    let data = thermal::training_from_table(&table, &[]).map_err(super::common::diag)?;
    let fit = thermal::fit(&data, &ThermalFitOptions::default())?;
    let model = fit.model;
    out.write(a.out_dir.join("thermal.toml"), model.to_toml()?.as_bytes())
        .context("cannot write thermal.toml")?;
    // The check of the source paper [R4] as a program.
    let mut program = String::from("%\nG21 G90 G94 G17\nG0 Z5\nS6000 M3\n");
    face(1, &mut program);
    for (rpm, seconds) in [
        (3000, 600),
        (8000, 900),
        (5000, 600),
        (7000, 900),
        (2000, 600),
    ] {
        program.push_str(&format!("S{rpm}\nG4 P{seconds}\n"));
    }
    program.push_str("S6000\n");
    face(2, &mut program);
    program.push_str("M5\nM30\n%\n");
    let comp = thermal::compensate(
        &model,
        program.as_bytes(),
        &thermal::CompensateOptions::default(),
    )?;
    out.write(a.out_dir.join("faces-comp.nc"), &comp.output)
        .context("cannot write faces-comp.nc")?;
    // True drift at the face height over the program's speed programme.
    let speeds: Vec<f64> = (0..comp.programme.len())
        .map(|k| comp.programme.sample(k)[0])
        .collect();
    let drift = truth.drift(&speeds, FACE_Z);
    let at = |t: f64| {
        let p = t / truth.period_min;
        let k = (p.floor() as usize).min(drift.len().saturating_sub(2));
        drift[k] + (p - k as f64) * (drift[k + 1] - drift[k])
    };
    // Each face starts with its plunge to FACE_Z; the correction written
    // there holds over the face's passes (two minutes, short against the
    // drift's time constants), so the face sits at FACE_Z − correction + e(t).
    let plunges: Vec<&thermal::ZBlock> = comp
        .z_blocks
        .iter()
        .filter(|b| (b.machine_z_mm - FACE_Z).abs() < 1e-9)
        .collect();
    let [f1, f2] = plunges[..] else {
        anyhow::bail!("the test program should plunge to Z{FACE_Z} twice");
    };
    let d_raw = (at(f2.end_min) - at(f1.end_min)).abs();
    let d_cor = ((at(f2.end_min) - f2.correction_mm) - (at(f1.end_min) - f1.correction_mm)).abs();
    let curves = vec![
        DriftCurve {
            name: format!("true drift at z = {FACE_Z} mm"),
            points: (0..drift.len())
                .map(|k| (k as f64 * truth.period_min, drift[k]))
                .collect(),
        },
        DriftCurve {
            name: "model prediction".into(),
            points: (0..drift.len())
                .map(|k| {
                    let t = k as f64 * truth.period_min;
                    (t, model.drift_at(&comp.programme, t, FACE_Z).mm)
                })
                .collect(),
        },
        DriftCurve {
            name: "left after compensation".into(),
            points: comp
                .z_blocks
                .iter()
                .filter(|b| !b.g53)
                .map(|b| (b.end_min, at(b.end_min) - b.correction_mm))
                .collect(),
        },
    ];
    let mut s = sections::thermal::section(
        &model,
        &curves,
        "Drift at the face height during the test program",
    );
    s.blocks.insert(
        1,
        Block::Headlines(vec![Headline {
            label: "cold face vs face after an hour: height difference without → with compensation"
                .into(),
            ours: format!("{:.1} → {:.1} µm", d_raw * 1e3, d_cor * 1e3),
            source: "7 → 2 µm".into(),
        }]),
    );
    Ok(Step {
        key: "thermal",
        title: "Thermal: spindle-speed-driven Z drift, fit and program compensation".into(),
        lines: vec![
            format!(
                "ARX model per height fitted on 3 probing runs at {} heights; largest simulation RMS {:.2} µm",
                model.heights().len(),
                model
                    .heights()
                    .iter()
                    .filter_map(|h| h.stats.as_ref().map(|s| s.simulation_rms_mm))
                    .fold(0.0f64, f64::max)
                    * 1e3
            ),
            format!(
                "test program ({:.0} min, {} blocks): faces cold and after an hour differ by {:.1} µm without and {:.1} µm with compensation (source paper [R4]: 7 → 2 µm)",
                comp.duration_min,
                comp.blocks,
                d_raw * 1e3,
                d_cor * 1e3
            ),
        ],
        json: json!({"face_difference_mm": d_raw, "face_difference_compensated_mm": d_cor,
            "source_face_difference_mm": 0.007, "source_face_difference_compensated_mm": 0.002}),
        sections: vec![s],
    })
}

/// The servo of each axis of the demo's "real" machine (the truth), and its
/// excitation: a sine sweep of 20 mm (or degrees) from 0.5 to 8 Hz over 4 s.
fn true_servo(k: usize) -> anyhow::Result<Servo> {
    // A double pole at p gives DC gain 1 with b0 = (1 − p)².
    let p = [0.80, 0.82, 0.78, 0.85, 0.83][k];
    Ok(Servo::new(
        0.001,
        vec![(1.0 - p) * (1.0 - p)],
        vec![1.0, -2.0 * p, p * p],
        1,
    )?)
}

fn excitation(ts: f64) -> Vec<f64> {
    let n = 4000;
    let mut phase = 0.0;
    (0..n)
        .map(|k| {
            let t = k as f64 * ts;
            let f = 0.5 + 7.5 * t / (n as f64 * ts);
            phase += 2.0 * std::f64::consts::PI * f * ts;
            20.0 * phase.sin()
        })
        .collect()
}

/// Step 6: Servo: command/encoder logs of each axis simulated with known transfer
/// functions and 20 nm encoder noise, fitted by ARX with order selection.
fn servo_step(a: &Args, out: &mut Outputs) -> anyhow::Result<Step> {
    let m = bundled::machine("ac-trunnion-with-errors.toml")?;
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let noise = Normal::new(0.0, 0.00002)?;
    let mut fits = Vec::new();
    let mut lines = Vec::new();
    let mut twin_machine = m.clone();
    let mut worst_lag = 0.0f64;
    for (k, axis) in m.axes.iter().enumerate() {
        let truth = true_servo(k)?;
        let cmd = excitation(truth.ts());
        let fb: Vec<f64> = truth
            .simulate(&cmd)
            .into_iter()
            .map(|y| y + noise.sample(&mut rng))
            .collect();
        let fit = fit_servo(
            &ServoLog::new(truth.ts(), cmd, fb)?,
            &ServoFitOptions::default(),
        )?;
        let lag_true = truth.velocity_lag_s()?;
        let lag = fit.velocity_lag_s.unwrap_or(f64::NAN);
        worst_lag = worst_lag.max((lag - lag_true).abs());
        lines.push(format!(
            "{}: orders {}, velocity lag {:.3} ms (truth {:.3} ms), simulation RMS {:.2} µm",
            axis.name,
            fit.selection.table[fit.selection.best].orders,
            lag * 1e3,
            lag_true * 1e3,
            fit.simulation_rms * 1e3
        ));
        twin_machine.axes[k].servo = Some(ServoTable {
            ts: fit.servo.ts(),
            b: fit.servo.b().to_vec(),
            a: fit.servo.a().to_vec(),
            nk: fit.servo.nk(),
        });
        fits.push((axis.name.clone(), mtwin::sysid::ServoFitDoc::new(&fit)));
    }
    let path = a.out_dir.join("ac-trunnion-twin.toml");
    out.write(
        &path,
        machine_to_toml(
            &twin_machine,
            &["The AC trunnion with errors and the servos identified by mtwin demo"],
        )?
        .as_bytes(),
    )
    .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(Step {
        key: "servo",
        title: "Servo: axis transfer functions from command/encoder logs".into(),
        lines,
        json: json!({"axes": fits.len(), "largest_velocity_lag_error_s": worst_lag,
            "machine": path.display().to_string()}),
        sections: vec![sections::servo::section(&fits)],
    })
}

/// The bundled five-axis test program (TCP).
const PROGRAM: &str = include_str!("../../../../examples/programs/s-curve-5axis.ngc");

/// Step 7: Geometric compensation of the five-axis program on the machine with errors.
fn compensate_step(a: &Args, staged: &mut Outputs) -> anyhow::Result<Step> {
    let m = bundled::machine("ac-trunnion-with-errors.toml")?;
    let mut opts = CompensateOptions::default();
    opts.tol = 0.001;
    opts.max_correction = 2.0;
    let comp = Compensator::new(&m, opts)?;
    let mut out = Vec::new();
    let summary = comp.run(std::io::BufReader::new(PROGRAM.as_bytes()), &mut out)?;
    let path = a.out_dir.join("s-curve-5axis-comp.ngc");
    staged
        .write(&path, &out)
        .with_context(|| format!("cannot write {}", path.display()))?;
    let doc = mtwin::methods::compensate::CompensateDoc::new(&summary, &path.display().to_string());
    Ok(Step {
        key: "compensate",
        title: "Geometric compensation of a five-axis program".into(),
        lines: vec![format!(
            "s-curve-5axis.ngc: {} blocks, {} changed, largest correction {:.1} µm, largest deviation left at a checked midpoint {:.3} µm → {}",
            summary.blocks,
            summary.blocks_changed,
            summary.largest_correction * 1e3,
            summary.largest_midpoint_deviation * 1e3,
            path.display()
        )],
        sections: vec![sections::compensate::section(&doc)],
        json: serde_json::to_value(&doc)?,
    })
}

// ─── Digital twin ([R5]) ────────────────────────────────────────────────────

/// The twin's prediction of `program` on `machine` (servos + geometric errors,
/// `ac-trunnion-twin.toml` written by the servo step): one [`TwinRow`] per servo
/// sample, interpolated at the servos' sample period.
fn twin_predict(
    machine: &Machine,
    program: &[u8],
    sources: mtwin::methods::twin::Sources,
) -> anyhow::Result<Vec<TwinRow>> {
    use mtwin::gcode::InterpolateOptions;
    use mtwin::methods::twin::{self, Twin};
    let ts = machine
        .axes
        .iter()
        .find_map(|a| a.servo.as_ref().map(|s| s.ts))
        .unwrap_or(0.001);
    let model = Twin::new(machine, sources)?;
    let mut rows = Vec::new();
    twin::predict_gcode(
        &model,
        machine,
        std::io::BufReader::new(program),
        &InterpolateOptions::new(ts),
        |s| {
            rows.push(TwinRow {
                t_s: s.t,
                tip_cmd: s.cmd_tip.into(),
                axis_cmd: s.cmd_axis.into(),
                tip: s.tip.into(),
                axis: s.axis.into(),
                tip_error: s.tip_error,
                axis_error: s.axis_error,
            });
            Ok(())
        },
        &mut |_| {},
    )?;
    Ok(rows)
}

/// `rows` (actual samples of a compensated program) measured against the
/// command path of the *original* program: the twin's own errors are against
/// the program it runs, and a compensated program deliberately commands a
/// path off the part. Exact global nearest point, as in the twin.
fn against_original(original: &[TwinRow], rows: &[TwinRow]) -> Vec<TwinRow> {
    use mtwin::methods::twin::{CommandPath, angle_between};
    use mtwin::nalgebra::Vector3;
    let path = CommandPath::new(
        original.iter().map(|r| Vector3::from(r.tip_cmd)).collect(),
        original.iter().map(|r| Vector3::from(r.axis_cmd)).collect(),
    );
    let mut scratch = Vec::new();
    rows.iter()
        .enumerate()
        .map(|(j, r)| {
            let tip = Vector3::from(r.tip);
            let near = path.nearest(&tip, j.min(original.len() - 1), &mut scratch);
            TwinRow {
                tip_cmd: near.point.into(),
                axis_cmd: near.axis.into(),
                tip_error: near.distance,
                axis_error: angle_between(&Vector3::from(r.axis), &near.axis),
                ..*r
            }
        })
        .collect()
}

/// Time, s, at which `program`'s first feed move (`G1`, `G2`, `G3`) starts on
/// `machine`, interpolated at the servos' sample period as the twin does.
fn cutting_starts(machine: &Machine, program: &[u8]) -> anyhow::Result<f64> {
    use mtwin::gcode::InterpolateOptions;
    let text = std::str::from_utf8(program).context("the program is not UTF-8")?;
    let first_feed = text
        .lines()
        .position(|l| {
            let l = l.trim_start().to_ascii_uppercase();
            ["G1 ", "G2 ", "G3 ", "G01 ", "G02 ", "G03 "]
                .iter()
                .any(|g| l.starts_with(g))
        })
        .context("the program has no feed move")? as u64
        + 1;
    let ts = machine
        .axes
        .iter()
        .find_map(|a| a.servo.as_ref().map(|s| s.ts))
        .unwrap_or(0.001);
    let mut t_cut = None;
    mtwin::gcode::interpolate(program, machine, &InterpolateOptions::new(ts), |s| {
        if t_cut.is_none() && s.line >= first_feed {
            t_cut = Some(s.t);
        }
        Ok(())
    })?;
    t_cut.context("the program's feed moves gave no samples")
}

/// Step 8: The digital twin on the five-axis program, before and after geometric
/// compensation: the whole error (servo + geometry) and the geometric part alone
/// (`--only geometry`), both measured against the original program's path.
fn twin_step(a: &Args, out: &mut Outputs) -> anyhow::Result<Step> {
    use mtwin::methods::twin::Sources;
    use mtwin::report::twin::summary;
    // The files of the servo and compensate steps, as staged (written at the end).
    let machine_path = a.out_dir.join("ac-trunnion-twin.toml");
    let machine_text = String::from_utf8(out.staged(&machine_path)?)?;
    let machine =
        mtwin::model::parse_machine(&machine_path, &machine_text).map_err(super::common::diag)?;
    let compensated = out
        .staged(a.out_dir.join("s-curve-5axis-comp.ngc"))
        .context("cannot read the compensated program")?;
    let before = twin_predict(&machine, PROGRAM.as_bytes(), Sources::All)?;
    anyhow::ensure!(!before.is_empty(), "the five-axis program gave no samples");
    let after = against_original(
        &before,
        &twin_predict(&machine, &compensated, Sources::All)?,
    );
    let geo_before = twin_predict(&machine, PROGRAM.as_bytes(), Sources::Geometry)?;
    let geo_after = against_original(
        &geo_before,
        &twin_predict(&machine, &compensated, Sources::Geometry)?,
    );
    // The comparisons are taken while cutting: from the program's first feed
    // move on. Before it the machine stands at its start position, which no
    // program compensation can move, and rapids to the part.
    let t_cut = cutting_starts(&machine, PROGRAM.as_bytes())?;
    let cutting = |rows: Vec<TwinRow>| -> Vec<TwinRow> {
        rows.into_iter().filter(|r| r.t_s >= t_cut).collect()
    };
    let (before_cut, after) = (cutting(before.clone()), cutting(after));
    let (geo_before, geo_after) = (cutting(geo_before), cutting(geo_after));
    let (b, af) = (summary(&before_cut), summary(&after));
    let (gb, ga) = (summary(&geo_before), summary(&geo_after));
    let line = |what: &str, s: (f64, f64, f64)| {
        format!(
            "{what}: tool tip up to {:.1} µm (RMS {:.1} µm), tool axis up to {:.1} µrad",
            s.0 * 1e3,
            s.1 * 1e3,
            s.2 * 1e6
        )
    };
    let mut lines = vec![
        format!(
            "{} samples at 1 ms, {} while cutting (from t = {:.3} s); the source patent's [R5] S-piece: tip −1.2…1.5 mm, axis −4.5e-3…4e-3 rad",
            before.len(),
            before_cut.len(),
            t_cut
        ),
        line("original program, servo + geometry", b),
        line("compensated program, servo + geometry", af),
        line("original program, geometry only", gb),
        line("compensated program, geometry only", ga),
    ];
    lines.push(format!(
        "geometric compensation removes {:.1} % of the geometric tip error (RMS, while cutting); what is left is servo lag, which a geometric model cannot correct",
        100.0 * (1.0 - ga.1 / gb.1.max(f64::MIN_POSITIVE))
    ));
    let sum = |s: (f64, f64, f64)| json!({"tip_error_max": s.0, "tip_error_rms": s.1, "axis_error_max": s.2});
    Ok(Step {
        key: "twin",
        title: "Digital twin: trajectory errors of the five-axis program".into(),
        lines,
        json: json!({"samples": before.len(), "cutting_from_s": t_cut,
            "tip_error_max": b.0, "tip_error_rms": b.1, "axis_error_max": b.2,
            "compensated": sum(af),
            "geometry_only": {"original": sum(gb), "compensated": sum(ga)}}),
        sections: vec![
            mtwin::report::twin::section_from_rows(
                "twin",
                "Digital twin: the five-axis program",
                &before,
            ),
            mtwin::report::twin::comparison_section(
                "twin-compensated",
                "Digital twin: original and compensated program (against the original path)",
                ("original", &before_cut),
                ("compensated", &after),
            ),
            mtwin::report::twin::comparison_section(
                "twin-geometry",
                "Geometric part alone: original and compensated program",
                ("original", &geo_before),
                ("compensated", &geo_after),
            ),
        ],
    })
}
