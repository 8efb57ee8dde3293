//! `mtwin ballbar …` ([R1] in docs/references.md): double-ballbar identification of the eight
//! location errors of the rotary axes of a double-turntable machine.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use mtwin::io::Outputs;
use mtwin::methods::ballbar::{
    self, BallbarMode, BallbarProgramDoc, IdentifyInputs, IdentifyOptions, ModeData, ProgramSpec,
    Rig, SensitivityInputs, SensitivityOptions, SetupErrorInput, SetupOptions, SimulateInputs,
    SimulateOptions, angle_range, read_mode_file, write_mode_file,
};
use mtwin::model::{Machine, machine_to_toml};

use super::common::{diag, load_machine};
use crate::bundled;
use crate::output::{Format, note, print_doc, warn};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// The tool-ball set-up error (eX, eY) from spindle-rotation readings.
    #[command(
        after_help = "Example:\n  mtwin ballbar setup-error --length 100.0 --lmax 100.1 --lmin 99.9 --theta2 242 --format json"
    )]
    SetupError(SetupArgs),
    /// Identify the eight PIGEs from the four mode files (any subset).
    #[command(
        after_help = "Example:\n  mtwin ballbar identify --mode1 m1.csv --mode2 m2.csv --mode3 m3.csv --mode4 m4.csv --length 100 --zb1c 100 --zb1a 100 --ex -0.0403 --ey -0.0765 --format json"
    )]
    Identify(IdentifyArgs),
    /// Which PIGE moves which mode, and by how much (table 2 of the source paper [R1], docs/references.md).
    #[command(after_help = "Example:\n  mtwin ballbar sensitivity --offset 0.010 --tilt 8.7e-5")]
    Sensitivity(SensitivityArgs),
    /// Write the four G-code test programs (static ballbar, dwell at each step).
    #[command(
        after_help = "Example:\n  mtwin ballbar program --out programs --a-range -90,90,5 --c-range 0,360,5"
    )]
    Program(ProgramArgs),
    /// Simulate the four mode files for a machine with errors.
    #[command(
        after_help = "Example:\n  mtwin ballbar simulate --machine examples/machines/ac-trunnion-with-errors.toml --ex -0.0403 --ey -0.0765 --noise 0.0003 --seed 1 --out data"
    )]
    Simulate(SimulateArgs),
    /// ISO 230-4 circular test: G, H, F and the diagnosis (backlash, squareness, …) from cw/ccw traces.
    #[command(
        after_help = "Example:\n  mtwin ballbar circular --cw cw.csv --ccw ccw.csv --radius 150 --format json"
    )]
    Circular(super::ballbar_circular::CircularArgs),
    /// Simulate cw/ccw circular-test traces with known errors and noise.
    #[command(
        after_help = "Example:\n  mtwin ballbar simulate-circular --out traces --radius 150 --backlash-x-um 8 --squareness-um-per-m 40 --noise 0.2"
    )]
    SimulateCircular(super::ballbar_circular::SimulateCircularArgs),
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct SetupArgs {
    /// Bar reading at spindle angle 0°, mm.
    #[arg(long)]
    length: f64,
    /// Largest reading over a spindle turn, mm.
    #[arg(long)]
    lmax: f64,
    /// Smallest reading over a spindle turn, mm.
    #[arg(long)]
    lmin: f64,
    /// Spindle angle of the smallest reading, degrees (M3 sense, clockwise seen from +Z).
    #[arg(long)]
    theta2: f64,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

/// The rig geometry: bar length and tool-ball placements.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct GeometryArgs {
    /// Nominal bar length L, mm.
    #[arg(long, default_value_t = 100.0)]
    length: f64,
    /// Distance of the tool ball from the C line in mode 2, mm.
    #[arg(long, default_value_t = 100.0)]
    zb1c: f64,
    /// Height of the tool ball above the A line in mode 4, mm.
    #[arg(long, default_value_t = 100.0)]
    zb1a: f64,
}

impl GeometryArgs {
    /// The rig with an ideal set-up (no tool-ball set-up error).
    fn ideal_rig(&self) -> Rig {
        Rig {
            length: self.length,
            zb1c: self.zb1c,
            zb1a: self.zb1a,
            setup: ballbar::SetupError { ex: 0.0, ey: 0.0 },
        }
    }
}

/// The rig options shared by several subcommands.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct RigArgs {
    #[command(flatten)]
    geometry: GeometryArgs,
    /// Set-up error eX of the tool ball, mm (from `mtwin ballbar setup-error`).
    #[arg(long, default_value_t = 0.0)]
    ex: f64,
    /// Set-up error eY of the tool ball, mm.
    #[arg(long, default_value_t = 0.0)]
    ey: f64,
}

impl RigArgs {
    fn rig(&self) -> Rig {
        Rig {
            setup: ballbar::SetupError {
                ex: self.ex,
                ey: self.ey,
            },
            ..self.geometry.ideal_rig()
        }
    }
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct IdentifyArgs {
    /// Mode 1 readings (A turns, tool ball on the axis intersection): `angle_deg,length_mm`.
    #[arg(long)]
    mode1: Option<PathBuf>,
    /// Mode 2 readings (A turns, tool ball ZB1C from the C line).
    #[arg(long)]
    mode2: Option<PathBuf>,
    /// Mode 3 readings (C turns, tool ball on the axis intersection).
    #[arg(long)]
    mode3: Option<PathBuf>,
    /// Mode 4 readings (C turns, tool ball ZB1A above the A line).
    #[arg(long)]
    mode4: Option<PathBuf>,
    #[command(flatten)]
    rig: RigArgs,
    /// Machine model (nominal geometry and PDGEs); default: the bundled ac-trunnion.toml.
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Write the machine model with the identified PIGEs here (TOML).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write polar SVG plots of measured and fitted ΔL per mode into this folder.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Rank rule for badly determined directions (truncated SVD toward the
    /// prior: PIGEs 0, bar lengths their start): `std=X` drops directions
    /// whose standard uncertainty would exceed X typical scales (10 µm,
    /// 100 µrad), `rcond=X` those with relative singular value below X,
    /// `off` (default) none. See docs/ballbar.md.
    #[arg(long, value_name = "RULE")]
    truncate: Option<mtwin::fit::Truncation>,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

/// Angle ranges `start,end,step` in degrees.
#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct RangeArgs {
    /// A-axis angles for modes 1 and 2: start,end,step (degrees).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_values_t = [-90.0, 90.0, 5.0])]
    a_range: Vec<f64>,
    /// C-axis angles for modes 3 and 4: start,end,step (degrees).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true, default_values_t = [0.0, 360.0, 5.0])]
    c_range: Vec<f64>,
}

impl RangeArgs {
    fn angles(&self, mode: BallbarMode) -> anyhow::Result<Vec<f64>> {
        let (r, name) = if mode.moves_a() {
            (&self.a_range, "--a-range")
        } else {
            (&self.c_range, "--c-range")
        };
        let [start, end, step] = r[..] else {
            bail!(
                "{name} takes three numbers start,end,step (degrees), got {}",
                r.len()
            );
        };
        // The count before the list: `--a-range -90,90,1e-9` would be 1.8e11 angles.
        if step > 0.0 && end >= start {
            mtwin::limits::check(
                &format!("the number of angles of {name}"),
                ((end - start) / step).floor() + 1.0,
                mtwin::limits::MAX_PROGRAM_POINTS,
                "each angle is a move and a dwell of the program; use a larger step",
            )?;
        }
        let v = angle_range(start, end, step);
        if v.is_empty() {
            bail!(
                "{name} {},{},{} gives no angles: it needs start ≤ end and a positive step",
                r[0],
                r[1],
                r[2]
            );
        }
        if !v.contains(&0.0) {
            bail!(
                "{name} must pass through 0° (the bar is set there): choose start and step so that 0 is a step"
            );
        }
        Ok(v)
    }
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct SensitivityArgs {
    // The table is for an ideal set-up, so it takes the rig geometry only,
    // no --ex/--ey.
    #[command(flatten)]
    rig: GeometryArgs,
    #[command(flatten)]
    range: RangeArgs,
    /// Size of the offsets, mm.
    #[arg(long, default_value_t = 0.010)]
    offset: f64,
    /// Size of the tilts, rad (default 0.005° = 8.7266e-5 rad).
    #[arg(long, default_value_t = 0.005_f64.to_radians())]
    tilt: f64,
    /// Machine model; default: the bundled ac-trunnion.toml.
    #[arg(long)]
    machine: Option<PathBuf>,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct ProgramArgs {
    #[command(flatten)]
    rig: RigArgs,
    #[command(flatten)]
    range: RangeArgs,
    /// Dwell at each step, s (`G4 P` for LinuxCNC, `G4 X` for Fanuc).
    #[arg(long, default_value_t = 2.0)]
    dwell: f64,
    /// Rotary feed, deg/min.
    #[arg(long, default_value_t = 720.0)]
    feed: f64,
    /// Machine model; default: the bundled ac-trunnion.toml.
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Folder for mode1.ngc … mode4.ngc (created if absent).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    dialect: super::common::WriteDialectArgs,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct SimulateArgs {
    #[command(flatten)]
    rig: RigArgs,
    #[command(flatten)]
    range: RangeArgs,
    /// Machine model with the errors to simulate; default: the bundled ac-trunnion-with-errors.toml.
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Standard deviation of the reading noise, mm.
    #[arg(long, default_value_t = 0.0003)]
    noise: f64,
    /// Seed of the random numbers (same seed, same files).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Folder for mode1.csv … mode4.csv (created if absent).
    #[arg(long)]
    out: PathBuf,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::SetupError(a) => run_setup(a),
        Command::Identify(a) => run_identify(a),
        Command::Sensitivity(a) => run_sensitivity(a),
        Command::Program(a) => run_program(a),
        Command::Simulate(a) => run_simulate(a),
        Command::Circular(a) => super::ballbar_circular::run_circular(a),
        Command::SimulateCircular(a) => super::ballbar_circular::run_simulate_circular(a),
    }
}

fn machine_or(path: &Option<PathBuf>, bundled_name: &str) -> anyhow::Result<Machine> {
    match path {
        Some(p) => load_machine(p),
        None => bundled::machine(bundled_name),
    }
}

fn run_setup(a: SetupArgs) -> anyhow::Result<()> {
    let doc = ballbar::setup::run(
        &SetupErrorInput {
            length: a.length,
            lmax: a.lmax,
            lmin: a.lmin,
            theta2_deg: a.theta2,
        },
        &SetupOptions::default(),
    )?;
    print_doc(&doc, a.format)
}

fn run_identify(a: IdentifyArgs) -> anyhow::Result<()> {
    let files = [&a.mode1, &a.mode2, &a.mode3, &a.mode4];
    if files.iter().all(|f| f.is_none()) {
        bail!("give at least one of --mode1 … --mode4");
    }
    // One polar plot per mode given.
    let plot_path = |dir: &Path, m: BallbarMode| dir.join(format!("{}.svg", m.label()));
    let plot_files: Vec<PathBuf> = a
        .plot
        .iter()
        .flat_map(|dir| {
            BallbarMode::ALL
                .into_iter()
                .filter(|m| files[m.index()].is_some())
                .map(|m| plot_path(dir, m))
        })
        .collect();
    let mut out = Outputs::plan()
        .inputs(&a.machine)
        .inputs(files.into_iter().flatten())
        .outputs(&a.out)
        .folders(&a.plot)
        .outputs(&plot_files)
        .begin()?;
    let machine = machine_or(&a.machine, "ac-trunnion.toml")?;
    let mut data: Vec<Option<ModeData>> = Vec::new();
    let mut problems = mtwin::io::Diagnostics::default();
    for f in files {
        data.push(match f {
            Some(p) => match read_mode_file(p) {
                Ok(d) => Some(d),
                Err(d) => {
                    problems.0.extend(d.0);
                    None
                }
            },
            None => None,
        });
    }
    if !problems.is_empty() {
        return Err(diag(problems));
    }
    let refs: [Option<&ModeData>; 4] = [0, 1, 2, 3].map(|i| data[i].as_ref());
    let mut options = IdentifyOptions::default();
    options.out = a.out.as_ref().map(|p| p.display().to_string());
    if let Some(t) = a.truncate {
        options.fit.truncation = t;
    }
    let (id, mut doc) = ballbar::identify::run(
        &IdentifyInputs {
            machine: &machine,
            rig: a.rig.rig(),
            modes: refs,
        },
        &options,
    )?;

    // Outputs first (all or nothing), then the report.
    if let Some(path) = &a.out {
        let header = [
            "Machine model with the rotary-axis PIGEs identified by `mtwin ballbar identify`.",
            "The eight PIGEs of A and C are absolute (relative to the nominal geometry).",
        ];
        out.write(path, machine_to_toml(&id.machine, &header)?.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    let mut plots = Vec::new();
    if let Some(dir) = &a.plot {
        for m in BallbarMode::ALL {
            if let Some(d) = refs[m.index()]
                && let Some(svg) = ballbar::plot::polar_plot(&id, m, d)
            {
                let p = plot_path(dir, m);
                out.write(&p, svg.as_bytes())
                    .with_context(|| format!("cannot write {}", p.display()))?;
                plots.push(p);
            }
        }
    }
    out.commit()?;
    for u in &id.unresolved {
        note(format!("not identified: {}", u.reason));
    }
    for w in &id.warnings {
        warn(w);
    }
    doc.plots = plots.iter().map(|p| p.display().to_string()).collect();
    print_doc(&doc, a.format)
}

fn run_sensitivity(a: SensitivityArgs) -> anyhow::Result<()> {
    let machine = machine_or(&a.machine, "ac-trunnion.toml")?;
    let angles = [
        a.range.angles(BallbarMode::One)?,
        a.range.angles(BallbarMode::Two)?,
        a.range.angles(BallbarMode::Three)?,
        a.range.angles(BallbarMode::Four)?,
    ];
    let mut options = SensitivityOptions::default();
    options.offset = a.offset;
    options.tilt = a.tilt;
    options.angles_deg = angles;
    let doc = ballbar::sensitivity::run(
        &SensitivityInputs {
            machine: &machine,
            rig: a.rig.ideal_rig(),
        },
        &options,
    )?;
    print_doc(&doc, a.format)
}

fn run_program(a: ProgramArgs) -> anyhow::Result<()> {
    let program_path = |m: BallbarMode| a.out.join(format!("{}.ngc", m.label()));
    let mut out = Outputs::plan()
        .inputs(&a.machine)
        .folder(&a.out)
        .outputs(BallbarMode::ALL.map(program_path))
        .begin()?;
    let machine = machine_or(&a.machine, "ac-trunnion.toml")?;
    let mut texts = Vec::new();
    for m in BallbarMode::ALL {
        let spec = ProgramSpec {
            rig: a.rig.rig(),
            angles_deg: a.range.angles(m)?,
            dwell_s: a.dwell,
            feed: a.feed,
            dialect: a.dialect.dialect(),
        };
        texts.push((m, ballbar::program(&machine, m, &spec)?));
    }
    let mut files = Vec::new();
    for (m, t) in &texts {
        let p = program_path(*m);
        out.write(&p, t.as_bytes())
            .with_context(|| format!("cannot write {}", p.display()))?;
        files.push(p);
    }
    out.commit()?;
    for (p, (m, _)) in files.iter().zip(&texts) {
        note(format!("{} → {}", m.label(), p.display()));
    }
    let files: Vec<String> = files.iter().map(|p| p.display().to_string()).collect();
    print_doc(&BallbarProgramDoc { files }, a.format)
}

fn run_simulate(a: SimulateArgs) -> anyhow::Result<()> {
    let data_path = |m: BallbarMode| a.out.join(format!("{}.csv", m.label()));
    let mut out = Outputs::plan()
        .inputs(&a.machine)
        .folder(&a.out)
        .outputs(BallbarMode::ALL.map(data_path))
        .begin()?;
    let machine = machine_or(&a.machine, "ac-trunnion-with-errors.toml")?;
    if !(a.noise >= 0.0 && a.noise.is_finite()) {
        bail!(
            "--noise {} must be a non-negative standard deviation in mm",
            mtwin::limits::fmt_message_number(a.noise)
        );
    }
    let mut options = SimulateOptions::default();
    options.noise = a.noise;
    options.seed = a.seed;
    options.angles_deg = [
        a.range.angles(BallbarMode::One)?,
        a.range.angles(BallbarMode::Two)?,
        a.range.angles(BallbarMode::Three)?,
        a.range.angles(BallbarMode::Four)?,
    ];
    options.files = BallbarMode::ALL
        .map(|m| data_path(m).display().to_string())
        .to_vec();
    let (data, doc) = ballbar::simulate::run(
        &SimulateInputs {
            machine: &machine,
            rig: a.rig.rig(),
        },
        &options,
    )?;
    for (m, d) in BallbarMode::ALL.iter().zip(&data) {
        let p = data_path(*m);
        out.write_with(&p, |w| write_mode_file(w, d))
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    out.commit()?;
    print_doc(&doc, a.format)
}
