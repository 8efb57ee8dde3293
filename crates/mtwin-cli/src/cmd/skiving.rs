//! `mtwin skiving`: workpiece set-up error of a power-skiving machine from
//! touch-offs ([R3] in docs/references.md): identify it, write the touch-off program, simulate
//! touches.

use std::path::PathBuf;

use anyhow::Context;
use mtwin::gcode::Dialect;
use mtwin::io::{Outputs, columns, fmt_f64};
use mtwin::methods::skiving::doc::SkivingProgramDoc;
use mtwin::methods::skiving::program::{self, Motion, Plan};
use mtwin::methods::skiving::simulate::SimulateOptions;
use mtwin::methods::skiving::touch::{DEFAULT_PLAUSIBILITY_MM, read_touches};
use mtwin::methods::skiving::{self, Geometry, Options, SetupError};

use super::common::{diag, load_table};
use crate::output::{Format, note, print_doc, warn};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// Identify the four set-up errors (δgx, δgy, εxz, εzy) from touch-offs.
    #[command(
        after_help = "Example:\n  mtwin skiving setup-error --data touches.csv --h 80 --L 150 --rt 40 --rg 60 --noise 0.001 --explain"
    )]
    SetupError(SetupErrorArgs),
    /// Write the touch-off program (G-code with probing moves).
    #[command(
        after_help = "Example:\n  mtwin skiving program --x 0 --h 80 --L 150 --rt 40 --rg 60 --dialect linuxcnc --out touchoff.ngc"
    )]
    Program(ProgramArgs),
    /// Simulate the touches of the plan for known set-up errors (exact contacts).
    #[command(
        after_help = "Example:\n  mtwin skiving simulate --x 0 --h 80 --L 150 --rt 40 --rg 60 --dgx 0.03 --dgy -0.02 --exz 2e-4 --ezy -1e-4 --out touches.csv"
    )]
    Simulate(SimulateArgs),
}

/// The machine dimensions every subcommand needs.
#[derive(Debug, clap::Args)]
pub struct GeometryArgs {
    /// Clamping height h: the workpiece top face lies at machine z = −h (mm).
    #[arg(long = "h")]
    h: f64,
    /// Swing length L of the tool head (mm).
    #[arg(long = "L")]
    l: f64,
    /// Tool tip radius rt (mm).
    #[arg(long)]
    rt: f64,
    /// Workpiece radius rg (mm).
    #[arg(long)]
    rg: f64,
}

impl GeometryArgs {
    fn geometry(&self) -> anyhow::Result<Geometry> {
        Geometry::new(self.h, self.l, self.rt, self.rg).context("invalid machine dimensions")
    }
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct SetupErrorArgs {
    /// Touches: CSV with columns x,y,z,a,b,c,point,contact (mm, degrees;
    /// point face|tip, contact top|side), one touch per row.
    #[arg(long)]
    data: PathBuf,
    #[command(flatten)]
    geometry: GeometryArgs,
    /// Known standard deviation of one touch (mm). Without it σ is estimated
    /// from the residuals (2 degrees of freedom for six touches) and touches
    /// are flagged against an assumed 0.002 mm.
    #[arg(long)]
    noise: Option<f64>,
    /// Reject a touch farther than this from its surface at zero set-up error (mm).
    #[arg(long, default_value_t = DEFAULT_PLAUSIBILITY_MM)]
    tolerance: f64,
    /// Also print the first-order closed forms beside the exact solution.
    #[arg(long)]
    explain: bool,
    /// Output format.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

#[derive(Debug, clap::Args)]
pub struct PlanArgs {
    /// X position held during the touches (mm).
    #[arg(long, allow_hyphen_values = true)]
    x: f64,
    /// |y| of the face touches (mm); default rg/2.
    #[arg(long)]
    face_offset: Option<f64>,
    /// Depth of the side touches below the top face (mm).
    #[arg(long, default_value_t = 10.0)]
    side_depth: f64,
}

impl PlanArgs {
    fn plan(&self, g: &Geometry) -> Plan {
        let mut p = Plan::standard(self.x, g);
        if let Some(f) = self.face_offset {
            p.face_offset = f;
        }
        p.side_depth = self.side_depth;
        p
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DialectArg {
    /// LinuxCNC, G38.2, results logged to skiving-touches.csv.
    Linuxcnc,
    /// Fanuc Macro B, G31, results in #501… and DPRNT.
    Fanuc,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct ProgramArgs {
    #[command(flatten)]
    plan: PlanArgs,
    #[command(flatten)]
    geometry: GeometryArgs,
    /// Start of each probing move before the nominal contact (mm).
    #[arg(long, default_value_t = 2.0)]
    approach: f64,
    /// End of each probing move beyond the nominal contact (mm).
    #[arg(long, default_value_t = 1.0)]
    overtravel: f64,
    /// Safe height above the top face between touches (mm).
    #[arg(long, default_value_t = 20.0)]
    clearance: f64,
    /// Probing feed (mm/min).
    #[arg(long, default_value_t = 20.0)]
    feed: f64,
    /// Controller dialect.
    #[arg(long, value_enum)]
    dialect: DialectArg,
    /// Output G-code file.
    #[arg(long)]
    out: PathBuf,
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct SimulateArgs {
    #[command(flatten)]
    plan: PlanArgs,
    #[command(flatten)]
    geometry: GeometryArgs,
    /// True offset δgx (mm).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    dgx: f64,
    /// True offset δgy (mm).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    dgy: f64,
    /// True tilt εxz about Y (rad).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    exz: f64,
    /// True tilt εzy about X (rad).
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    ezy: f64,
    /// Standard deviation of Gaussian noise on each probed coordinate (mm).
    #[arg(long, default_value_t = 0.0)]
    noise: f64,
    /// Seed of the noise.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Repeat the six touches this many times (noise drawn anew each time).
    #[arg(long, default_value_t = 1)]
    repeat: u32,
    /// Output TOUCHES.csv.
    #[arg(long)]
    out: PathBuf,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::SetupError(a) => setup_error(a),
        Command::Program(a) => write_program(a),
        Command::Simulate(a) => simulate_touches(a),
    }
}

fn setup_error(a: SetupErrorArgs) -> anyhow::Result<()> {
    let g = a.geometry.geometry()?;
    let t = load_table(&a.data)?;
    let touches = read_touches(&t, &g, a.tolerance).map_err(diag)?;
    let (s, _, mut doc) = skiving::run(&touches, &g, &Options::with_noise(a.noise))
        .with_context(|| format!("{}: cannot identify the set-up error", a.data.display()))?;
    doc.source = Some(a.data.display().to_string());
    for (i, row) in doc.rows.iter_mut().enumerate() {
        row.line = t.line(i);
    }
    let inconsistent: Vec<usize> = s
        .flags
        .iter()
        .enumerate()
        .filter(|(_, f)| **f == mtwin::methods::skiving::TouchFlag::Inconsistent)
        .map(|(i, _)| i)
        .collect();
    // The engine's own outlier scan is replaced by the leverage-aware flags below.
    for w in &s.fit.warnings {
        if !matches!(w, mtwin::fit::Warning::Outliers { .. }) {
            warn(w.to_string());
        }
    }
    for &i in &inconsistent {
        warn(format!(
            "{}:{}: touch {} is inconsistent with the others (residual {} µm, {} times its expected size)",
            a.data.display(),
            t.line(i),
            i + 1,
            mtwin::limits::fmt_message_fixed(s.residuals[i] * 1e3, 2),
            mtwin::limits::fmt_message_fixed(s.standardized[i].unwrap_or(f64::NAN).abs(), 1)
        ));
    }
    if s.flags
        .contains(&mtwin::methods::skiving::TouchFlag::Unchecked)
    {
        note(
            "touches marked `unchecked` are not checked by any other touch: an error in them goes straight into the result (repeat them to check)",
        );
    }
    if a.explain && a.format == Format::Human {
        print!("{doc:#}");
        Ok(())
    } else {
        print_doc(&doc, a.format)
    }
}

fn write_program(a: ProgramArgs) -> anyhow::Result<()> {
    let mut out = Outputs::plan().output(&a.out).begin()?;
    let g = a.geometry.geometry()?;
    let motion = Motion {
        approach: a.approach,
        overtravel: a.overtravel,
        clearance: a.clearance,
        feed: a.feed,
    };
    let dialect = match a.dialect {
        DialectArg::Linuxcnc => Dialect::LinuxCnc,
        // Every number is written with a decimal point: the program reads
        // the same with and without decimal point programming.
        DialectArg::Fanuc => Dialect::Fanuc {
            decimal_point_programming: false,
        },
    };
    let text = program::program(&a.plan.plan(&g), &g, &motion, dialect)
        .context("cannot write the touch-off program")?;
    out.write(&a.out, text.as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    let doc = SkivingProgramDoc {
        out: a.out.display().to_string(),
        probing_moves: 6,
    };
    print_doc(&doc, a.format)?;
    if a.format == Format::Human {
        note(format!(
            "touch-off program (6 probing moves) → {}",
            a.out.display()
        ));
    }
    Ok(())
}

fn simulate_touches(a: SimulateArgs) -> anyhow::Result<()> {
    let mut out = Outputs::plan().output(&a.out).begin()?;
    let g = a.geometry.geometry()?;
    let plan = a
        .plan
        .plan(&g)
        .touches(&g)
        .context("cannot plan the touches")?;
    let truth = SetupError {
        dgx: a.dgx,
        dgy: a.dgy,
        exz: a.exz,
        ezy: a.ezy,
    };
    if a.repeat == 0 {
        anyhow::bail!("--repeat must be at least 1");
    }
    let mut options = SimulateOptions::default();
    options.sigma = a.noise;
    options.seed = a.seed;
    options.repeat = a.repeat;
    options.out = a.out.display().to_string();
    let (touches, doc) = skiving::simulate::run(&plan, &g, &truth, &options)
        .context("cannot simulate the touches")?;
    out.write_with(&a.out, |w| -> std::io::Result<()> {
        writeln!(
            w,
            "{},{}",
            columns::header(&columns::SKIVING_TOUCH_POSITION),
            columns::header(&columns::SKIVING_TOUCH_LABELS)
        )?;
        for t in &touches {
            let q = t.at;
            let nums = [q.x, q.y, q.z, q.a, q.b, q.c].map(fmt_f64).join(",");
            writeln!(w, "{nums},{},{}", t.point.name(), t.contact.name())?;
        }
        Ok(())
    })
    .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    print_doc(&doc, a.format)
}
