//! `mtwin model check`: read a machine file, report its chains, axes and errors, or every problem.

use std::path::PathBuf;

use mtwin::model::{Component, Machine};
use serde_json::json;

use super::common::load_machine;
use crate::output::{Format, print_json};

#[derive(Debug, clap::Subcommand)]
pub enum Command {
    /// Check a machine model file and summarise it (chains, axes, errors).
    #[command(after_help = "Example:\n  mtwin model check examples/machines/ac-trunnion.toml")]
    Check {
        /// The machine model file (TOML, spec 00 §5).
        machine: PathBuf,
        /// Output format.
        #[arg(long, value_enum, default_value_t)]
        format: Format,
    },
}

pub fn run(c: Command) -> anyhow::Result<()> {
    match c {
        Command::Check { machine, format } => {
            let m = load_machine(&machine)?;
            match format {
                Format::Json => print_json(&summary_json(&m)),
                Format::Human => {
                    print!("{}", summary_text(&m, &machine.display().to_string()));
                    Ok(())
                }
            }
        }
    }
}

fn chain_names(m: &Machine, chain: &[usize]) -> Vec<String> {
    chain.iter().map(|&i| m.axes[i].name.clone()).collect()
}

fn error_list(m: &Machine) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for a in &m.axes {
        for c in Component::ALL {
            if let Some(f) = &a.errors.pdge[c.index()] {
                out.push((format!("E{}{}", c.letter(), a.name), f.form().label()));
            }
        }
        for c in Component::ALL {
            let v = a.errors.location[c.index()];
            if v != 0.0 {
                let unit = if c.is_rotation() { "rad" } else { "mm" };
                out.push((
                    format!("E{}0{}", c.letter(), a.name),
                    format!("{} {unit}", mtwin::io::fmt_f64(v)),
                ));
            }
        }
    }
    out
}

pub fn summary_json(m: &Machine) -> serde_json::Value {
    json!({
        "ok": true,
        "name": m.name,
        "tool_chain": chain_names(m, &m.tool_chain),
        "workpiece_chain": chain_names(m, &m.workpiece_chain),
        "axes": m.axes.iter().map(|a| json!({
            "name": a.name, "kind": a.kind.as_str(),
            "direction": a.direction.as_slice(), "origin": a.origin.as_slice(),
            "travel": a.travel, "servo": a.servo.is_some(),
        })).collect::<Vec<_>>(),
        "errors": error_list(m).into_iter().map(|(n, f)| json!({"name": n, "form": f})).collect::<Vec<_>>(),
        "error_terms": m.n_error_terms(),
    })
}

pub fn summary_text(m: &Machine, file: &str) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(s, "{file}: OK — \"{}\"", m.name);
    let chain = |c: &[usize]| {
        if c.is_empty() {
            "(empty)".to_string()
        } else {
            chain_names(m, c).join(" → ")
        }
    };
    let _ = writeln!(s, "  tool chain:      M → {} → T", chain(&m.tool_chain));
    let _ = writeln!(
        s,
        "  workpiece chain: M → {} → W",
        chain(&m.workpiece_chain)
    );
    let _ = writeln!(
        s,
        "\n  axis  kind    direction           origin (mm)               travel"
    );
    for a in &m.axes {
        let v = |x: &mtwin::nalgebra::Vector3<f64>| format!("[{}, {}, {}]", x[0], x[1], x[2]);
        let _ = writeln!(
            s,
            "  {:<5} {:<7} {:<19} {:<25} [{}, {}] {}{}",
            a.name,
            a.kind.as_str(),
            v(&a.direction),
            v(&a.origin),
            a.travel[0],
            a.travel[1],
            a.kind.unit(),
            if a.servo.is_some() { "  servo" } else { "" }
        );
    }
    let errs = error_list(m);
    if errs.is_empty() {
        let _ = writeln!(s, "\n  no geometric errors (a nominal machine)");
    } else {
        let _ = writeln!(s, "\n  {} geometric error terms:", m.n_error_terms());
        for chunk in errs.chunks(4) {
            let line: Vec<String> = chunk
                .iter()
                .map(|(n, f)| format!("{n:<6} {f:<18}"))
                .collect();
            let _ = writeln!(s, "    {}", line.join(" "));
        }
    }
    s
}
