//! `mtwin testpiece …`: machining test pieces as five-axis programs for a
//! given machine. Units: mm, degrees, feeds in mm/min.

use std::path::PathBuf;

use anyhow::Context;
use mtwin::methods::testpiece::{self, SShape, SShapeProgram, SShapeProgramDoc};

use super::common::load_machine;
use crate::output::{Format, note, print_doc};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// The ISO 10791-7 style S-shaped test piece: a flank-milled ruled surface between two S curves.
    #[command(
        after_help = "Example:\n  mtwin testpiece s-shape --machine examples/machines/ac-trunnion.toml --segments 200 --feed 1000 --out s.nc\n  mtwin testpiece s-shape --machine examples/machines/ac-trunnion.toml --tcp --inverse-time --out s-tcp.nc"
    )]
    SShape(SShapeArgs),
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct SShapeArgs {
    /// Machine model file (TOML); its nominal inverse kinematics gives the axis words.
    #[arg(long)]
    machine: PathBuf,
    /// Output program.
    #[arg(long)]
    out: PathBuf,
    /// Length of the lower S curve along x, mm.
    #[arg(long, default_value_t = 160.0)]
    length: f64,
    /// Width of the lower S (peak to peak along y), mm.
    #[arg(long, default_value_t = 40.0)]
    width: f64,
    /// Height of the upper curve above the lower one, mm.
    #[arg(long, default_value_t = 30.0)]
    height: f64,
    /// Upper-curve length over lower-curve length.
    #[arg(long, default_value_t = 0.875)]
    top_length_ratio: f64,
    /// Upper-curve width over lower-curve width.
    #[arg(long, default_value_t = 0.8)]
    top_width_ratio: f64,
    /// Lean of the wall towards −y, degrees.
    #[arg(long, default_value_t = 15.0)]
    lean: f64,
    /// Multiply length, width and height by this factor.
    #[arg(long, default_value_t = 1.0)]
    scale: f64,
    /// Straight segments along the curve.
    #[arg(long, default_value_t = 200)]
    segments: usize,
    /// Feed of the tool tip, mm/min.
    #[arg(long, default_value_t = 1000.0)]
    feed: f64,
    /// G93 inverse-time feeds (F = 1/minutes of each segment) instead of G94.
    #[arg(long)]
    inverse_time: bool,
    /// A TCP program (G43.4 H0 … G49; X Y Z = tool tip in W) instead of joint-space axis words.
    #[arg(long)]
    tcp: bool,
    #[command(flatten)]
    dialect: super::common::WriteDialectArgs,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::SShape(a) => s_shape(a),
    }
}

fn s_shape(a: SShapeArgs) -> anyhow::Result<()> {
    super::common::positive("--scale", a.scale)?;
    let mut out = mtwin::io::Outputs::plan()
        .input(&a.machine)
        .output(&a.out)
        .begin()?;
    let machine = load_machine(&a.machine)?;
    let shape = SShape {
        length: a.length,
        width: a.width,
        height: a.height,
        top_length_ratio: a.top_length_ratio,
        top_width_ratio: a.top_width_ratio,
        lean_deg: a.lean,
    }
    .scaled(a.scale);
    let opts = SShapeProgram {
        segments: a.segments,
        feed: a.feed,
        inverse_time: a.inverse_time,
        tcp: a.tcp,
        dialect: a.dialect.dialect(),
    };
    let (text, doc) = testpiece::run(&machine, &shape, &opts)
        .with_context(|| format!("the S-shaped piece on {}", a.machine.display()))?;
    out.write(&a.out, text.as_bytes())
        .with_context(|| format!("cannot write {}", a.out.display()))?;
    out.commit()?;
    let doc = SShapeProgramDoc {
        out: a.out.display().to_string(),
        ..doc
    };
    print_doc(&doc, a.format)?;
    if a.format == Format::Human {
        note(if a.tcp {
            "TCP program: X Y Z are the tool tip in W; interpolate with `mtwin gcode interpolate` (G43.4 switches TCP on)"
        } else {
            "joint-space program from the machine's nominal inverse kinematics"
        });
    }
    Ok(())
}
