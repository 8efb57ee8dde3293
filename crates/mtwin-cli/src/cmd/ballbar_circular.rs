//! `mtwin ballbar circular` and `mtwin ballbar simulate-circular`: the
//! ISO 230-4 circular test and its diagnosis (docs/ballbar.md). Units: mm for
//! the radius, µm for deviations, degrees for angles.

use std::path::{Path, PathBuf};

use anyhow::Context;
use mtwin::io::{Diagnostic, Table};
use mtwin::methods::ballbar::circular::{CircularOptions, Plane, Trace, circular, plot_svg};
use mtwin::methods::ballbar::circular_model::update_machine;
use mtwin::methods::ballbar::circular_sim::{CircularErrors, ServoPair, simulate_circular};
use mtwin::model::machine_to_toml;

use super::common::{diag, load_machine};
use crate::output::{Format, note, print_doc};

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct CircularArgs {
    /// Clockwise run, CSV `angle_deg,deviation_um` (angle counter-clockwise from +X in the test plane).
    #[arg(long)]
    cw: Option<PathBuf>,
    /// Counter-clockwise run, same columns.
    #[arg(long)]
    ccw: Option<PathBuf>,
    /// Nominal radius (ballbar length), mm.
    #[arg(long)]
    radius: f64,
    /// Pitch of the cyclic error (screw lead), mm.
    #[arg(long, default_value_t = 10.0)]
    cyclic_pitch: f64,
    /// Decay angle of a reversal spike, degrees.
    #[arg(long, default_value_t = 3.0)]
    spike_width: f64,
    /// Test plane: names the axes of the diagnostics (xy: backlash_x_um, backlash_y_um; yz: _y_, _z_; zx: _z_, _x_).
    #[arg(long, value_enum, default_value_t)]
    plane: PlaneArg,
    /// Write the polar plot of the traces (about the fitted centre) as SVG.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Machine model (TOML) to receive the measured squareness and scale mismatch (with --out-model; never overwritten).
    #[arg(long, requires = "out_model")]
    update_model: Option<PathBuf>,
    /// Where to write the updated machine model (a new file; not an input).
    #[arg(long, requires = "update_model")]
    out_model: Option<PathBuf>,
    /// Output format.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

/// The test plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum PlaneArg {
    /// X then Y (θ from +X towards +Y).
    #[default]
    Xy,
    /// Y then Z (θ from +Y towards +Z).
    Yz,
    /// Z then X (θ from +Z towards +X).
    Zx,
}

impl PlaneArg {
    fn plane(self) -> Plane {
        match self {
            PlaneArg::Xy => Plane::Xy,
            PlaneArg::Yz => Plane::Yz,
            PlaneArg::Zx => Plane::Zx,
        }
    }
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct SimulateCircularArgs {
    /// Folder for cw.csv and ccw.csv.
    #[arg(long)]
    out: PathBuf,
    /// Nominal radius, mm.
    #[arg(long, default_value_t = 150.0)]
    radius: f64,
    /// Samples per turn and direction.
    #[arg(long, default_value_t = 3600)]
    samples: usize,
    /// Standard deviation of the reading noise, µm.
    #[arg(long, default_value_t = 0.0)]
    noise: f64,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Pitch of the cyclic error, mm.
    #[arg(long, default_value_t = 10.0)]
    cyclic_pitch: f64,
    /// Decay angle of a reversal spike, degrees.
    #[arg(long, default_value_t = 3.0)]
    spike_width: f64,
    /// Known error `backlash_x_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    backlash_x_um: f64,
    /// Known error `backlash_y_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    backlash_y_um: f64,
    /// Known error `lateral_play_x_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    lateral_play_x_um: f64,
    /// Known error `lateral_play_y_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    lateral_play_y_um: f64,
    /// Known error `reversal_spike_x_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    reversal_spike_x_um: f64,
    /// Known error `reversal_spike_y_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    reversal_spike_y_um: f64,
    /// Known error `cyclic_error_x_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    cyclic_error_x_um: f64,
    /// Known error `cyclic_error_y_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    cyclic_error_y_um: f64,
    /// Phase of the cyclic errors, degrees.
    #[arg(long, default_value_t = 0.0)]
    cyclic_phase_deg: f64,
    /// Known error `servo_mismatch_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    servo_mismatch_um: f64,
    /// Known error `squareness_um_per_m` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    squareness_um_per_m: f64,
    /// Known error `straightness_x_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    straightness_x_um: f64,
    /// Known error `straightness_y_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    straightness_y_um: f64,
    /// Known error `scale_mismatch_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    scale_mismatch_um: f64,
    /// Known error `centre_x_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    centre_x_um: f64,
    /// Known error `centre_y_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    centre_y_um: f64,
    /// Known error `radius_offset_um` (unit in the name; models in docs/ballbar.md).
    #[arg(long, default_value_t = 0.0)]
    radius_offset_um: f64,
    /// Servo model files (SERVO.toml of `mtwin servo fit`) of the first and the second axis, given twice in that order: the circle at --feed runs through them.
    #[arg(long, num_args = 1, requires = "feed")]
    servo_model: Vec<PathBuf>,
    /// Feed along the circle, mm/min (with --servo-model).
    #[arg(long, requires = "servo_model")]
    feed: Option<f64>,
}

fn read_trace(path: &Path) -> anyhow::Result<Trace> {
    let t = Table::read(path).map_err(diag)?;
    let rows = t
        .number_rows(&mtwin::io::columns::BALLBAR_CIRCULAR)
        .map_err(diag)?;
    if rows.len() < 8 {
        return Err(diag(
            Diagnostic::at(
                path,
                t.header_line(),
                1,
                format!(
                    "a trace needs at least 8 samples, this one has {}",
                    rows.len()
                ),
            )
            .into(),
        ));
    }
    Ok(Trace {
        angle_deg: rows.iter().map(|r| r[0]).collect(),
        deviation_um: rows.iter().map(|r| r[1]).collect(),
    })
}

pub fn run_circular(a: CircularArgs) -> anyhow::Result<()> {
    super::common::positive("--radius", a.radius)?;
    super::common::positive("--cyclic-pitch", a.cyclic_pitch)?;
    super::common::positive("--spike-width", a.spike_width)?;
    if a.cw.is_none() && a.ccw.is_none() {
        anyhow::bail!("give the clockwise run (--cw), the counter-clockwise run (--ccw), or both");
    }
    let mut plan = mtwin::io::Outputs::plan()
        .inputs(a.cw.iter().chain(&a.ccw))
        .outputs(a.plot.iter());
    if let (Some(m), Some(o)) = (&a.update_model, &a.out_model) {
        plan = plan.input(m).output(o);
    }
    let mut out = plan.begin()?;
    let cw = a.cw.as_deref().map(read_trace).transpose()?;
    let ccw = a.ccw.as_deref().map(read_trace).transpose()?;
    let o = CircularOptions {
        radius_mm: a.radius,
        cyclic_pitch_mm: a.cyclic_pitch,
        spike_width_deg: a.spike_width,
        plane: a.plane.plane(),
    };
    let doc = circular(cw.as_ref(), ccw.as_ref(), &o).map_err(anyhow::Error::msg)?;
    let mut changes = Vec::new();
    if let (Some(mpath), Some(opath)) = (&a.update_model, &a.out_model) {
        let machine = load_machine(mpath)?;
        let (m, ch) = update_machine(&machine, &doc)
            .map_err(|e| anyhow::anyhow!("{}: {e}", mpath.display()))?;
        let header = [
            format!(
                "Machine model {} with the squareness and scale mismatch of the circular test",
                mpath.display()
            ),
            format!(
                "(plane {}, R = {} mm) written by `mtwin ballbar circular --update-model`.",
                doc.plane.as_str().to_uppercase(),
                mtwin::io::fmt_f64(doc.radius_mm)
            ),
        ];
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        out.write(opath, machine_to_toml(&m, &header)?.as_bytes())
            .with_context(|| format!("cannot write {}", opath.display()))?;
        changes = ch;
    }
    if let Some(p) = &a.plot {
        out.write(p, plot_svg(&doc).as_bytes())
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    out.commit()?;
    print_doc(&doc, a.format)?;
    for c in &changes {
        note(format!("{}: {}", c.error, c.note));
    }
    if let Some(p) = &a.out_model {
        note(format!("updated model written to {}", p.display()));
    }
    if let Some(p) = &a.plot {
        note(format!("plot written to {}", p.display()));
    }
    Ok(())
}

pub fn run_simulate_circular(a: SimulateCircularArgs) -> anyhow::Result<()> {
    super::common::positive("--radius", a.radius)?;
    super::common::positive("--cyclic-pitch", a.cyclic_pitch)?;
    super::common::positive("--spike-width", a.spike_width)?;
    if a.samples < 8 || a.samples > 10_000_000 {
        anyhow::bail!("--samples must be from 8 to 10000000");
    }
    if !(a.noise.is_finite() && a.noise >= 0.0) {
        anyhow::bail!("--noise must be zero or positive");
    }
    let servos = match (&a.servo_model[..], a.feed) {
        ([], _) => None,
        ([first, second], Some(feed)) => {
            super::common::positive("--feed", feed)?;
            let read = |p: &PathBuf| -> anyhow::Result<mtwin::sysid::Servo> {
                let s = mtwin::sysid::read_servo_toml(p).map_err(diag)?;
                if let mtwin::sysid::Stability::Unstable { .. } = s.arx().stability() {
                    anyhow::bail!(
                        "{}: the servo model is unstable (a pole on or outside the unit circle)",
                        p.display()
                    );
                }
                Ok(s)
            };
            Some(ServoPair {
                first: read(first)?,
                second: read(second)?,
                feed_mm_min: feed,
            })
        }
        (m, _) => anyhow::bail!(
            "give --servo-model twice (the first axis, then the second), not {} time(s)",
            m.len()
        ),
    };
    let e = CircularErrors {
        servos,
        backlash_x_um: a.backlash_x_um,
        backlash_y_um: a.backlash_y_um,
        lateral_play_x_um: a.lateral_play_x_um,
        lateral_play_y_um: a.lateral_play_y_um,
        reversal_spike_x_um: a.reversal_spike_x_um,
        reversal_spike_y_um: a.reversal_spike_y_um,
        cyclic_error_x_um: a.cyclic_error_x_um,
        cyclic_error_y_um: a.cyclic_error_y_um,
        cyclic_phase_deg: a.cyclic_phase_deg,
        servo_mismatch_um: a.servo_mismatch_um,
        squareness_um_per_m: a.squareness_um_per_m,
        straightness_x_um: a.straightness_x_um,
        straightness_y_um: a.straightness_y_um,
        scale_mismatch_um: a.scale_mismatch_um,
        centre_x_um: a.centre_x_um,
        centre_y_um: a.centre_y_um,
        radius_offset_um: a.radius_offset_um,
    };
    let o = CircularOptions {
        radius_mm: a.radius,
        cyclic_pitch_mm: a.cyclic_pitch,
        spike_width_deg: a.spike_width,
        plane: Plane::Xy,
    };
    let (cw_path, ccw_path) = (a.out.join("cw.csv"), a.out.join("ccw.csv"));
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
    let mut out = mtwin::io::Outputs::plan()
        .inputs(&a.servo_model)
        .output(&cw_path)
        .output(&ccw_path)
        .begin()?;
    for (ccw, path) in [(false, &cw_path), (true, &ccw_path)] {
        let t = simulate_circular(&e, &o, ccw, a.samples, a.noise, a.seed);
        if t.deviation_um.iter().any(|d| !d.is_finite()) {
            anyhow::bail!("the simulated trace is not finite (a servo model that diverges?)");
        }
        let mut text = format!(
            "{}\n",
            mtwin::io::columns::header(&mtwin::io::columns::BALLBAR_CIRCULAR)
        );
        for (th, d) in t.angle_deg.iter().zip(&t.deviation_um) {
            text.push_str(&format!(
                "{},{}\n",
                mtwin::io::fmt_f64(*th),
                mtwin::io::fmt_f64(*d)
            ));
        }
        out.write(path, text.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    out.commit()?;
    note(format!(
        "wrote {} and {} ({} samples each)",
        cw_path.display(),
        ccw_path.display(),
        a.samples
    ));
    Ok(())
}
