//! `mtwin export` (docs/controller-tables.md): an identified machine model as
//! the compensation tables a controller loads, with the volumetric error
//! they leave.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::Context;
use mtwin::controller::{ExportDoc, ExportOptions, Format as Table, ResidualOptions};

use super::common::{diag, load_machine};
use crate::output::{Format, print_out};

/// A `--to` choice.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum To {
    /// Beckhoff / ISG volumetric compensation: volcomp.lis and volcomp.csv (ISG_CSV).
    Isg,
    /// Etalon exchange format (vendor variant) with its volcomp.lis.
    Etalon,
    /// LinuxCNC: comp_<AXIS>.txt per linear joint (type 1), kinematics.hal on a trunnion, README.txt.
    Linuxcnc,
    /// Siemens 840D sl leadscrew/encoder compensation: AX_EEC.INI.
    SiemensEec,
    /// Siemens 840D sl sag/angularity compensation: NC_CEC.INI.
    SiemensCec,
}

impl To {
    pub(crate) fn table(self) -> Table {
        match self {
            To::Isg => Table::Isg,
            To::Etalon => Table::Etalon,
            To::Linuxcnc => Table::LinuxCnc,
            To::SiemensEec => Table::SiemensEec,
            To::SiemensCec => Table::SiemensCec,
        }
    }
}

/// `AXIS=LO:HI`.
fn parse_range(s: &str) -> Result<(String, [f64; 2]), String> {
    let (axis, r) = s
        .split_once('=')
        .ok_or_else(|| format!("`{s}`: expected AXIS=LO:HI, e.g. X=-200:200"))?;
    let (lo, hi) = r
        .split_once(':')
        .ok_or_else(|| format!("`{s}`: expected AXIS=LO:HI, e.g. X=-200:200"))?;
    let num = |t: &str| {
        t.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("`{t}` is not a finite number"))
    };
    let (lo, hi) = (num(lo)?, num(hi)?);
    if lo >= hi {
        return Err(format!("`{s}`: LO must be below HI"));
    }
    Ok((axis.trim().to_string(), [lo, hi]))
}

#[derive(Debug, clap::Args)]
#[command(allow_negative_numbers = true)]
pub struct Args {
    /// Machine model file (TOML), usually an identified one.
    #[arg(long, required_unless_present = "thermal")]
    machine: Option<PathBuf>,
    /// Thermal drift model of `mtwin thermal fit` (TOML): with `--to linuxcnc`, also
    /// writes it as a live HAL component driving the Z external offset (mtwin_thermal.py,
    /// thermal.hal, thermal-README.txt).
    #[arg(long)]
    thermal: Option<PathBuf>,
    /// Table format(s); several (comma-separated) write one subfolder per format.
    #[arg(long, value_enum, value_delimiter = ',', required = true)]
    to: Vec<To>,
    /// Output folder (created if missing).
    #[arg(long)]
    out: PathBuf,
    /// Spacing of table points on linear axes, mm (LinuxCNC tables are capped at 256 points).
    #[arg(long, default_value_t = 10.0)]
    spacing: f64,
    /// Spacing of table points on rotary axes (volumetric formats), degree.
    #[arg(long, default_value_t = 5.0)]
    spacing_deg: f64,
    /// Table range of an axis, AXIS=LO:HI (mm or deg; default its travel). Repeatable.
    #[arg(long = "range", value_parser = parse_range)]
    ranges: Vec<(String, [f64; 2])>,
    /// Points per linear axis of the workspace grid the residual is evaluated on.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(2..=50))]
    residual_points: u32,
    /// Points per rotary axis of the workspace grid.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u32).range(1..=37))]
    residual_rotary_points: u32,
    /// Output format of the summary.
    #[arg(long, value_enum, default_value_t)]
    format: Format,
}

/// What `--thermal` wrote (`--format json`: the key `thermal`).
#[derive(Debug, serde::Serialize)]
struct ThermalDoc {
    files: Vec<String>,
    component: &'static str,
    period_min: f64,
    inputs: Vec<String>,
    heights_mm: Vec<f64>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let machine = a.machine.as_deref().map(load_machine).transpose()?;
    let thermal = match &a.thermal {
        Some(p) => {
            if a.to != [To::Linuxcnc] {
                anyhow::bail!(
                    "--thermal: only `--to linuxcnc` carries a live thermal model (a HAL component); \
                     give it alone"
                );
            }
            Some(mtwin::methods::thermal::read_model(p).map_err(diag)?)
        }
        None => None,
    };
    let opts = ExportOptions {
        spacing_mm: Some(a.spacing),
        spacing_deg: Some(a.spacing_deg),
        ranges: a.ranges.clone(),
    };
    let mut to = a.to.clone();
    to.dedup();
    let several = to.len() > 1;
    let mut exported = Vec::new();
    if let Some(machine) = &machine {
        for t in &to {
            let e = mtwin::controller::export(machine, t.table(), &opts)?;
            exported.push(e);
        }
    }
    let thermal_files = match &thermal {
        Some(m) => mtwin::controller::linuxcnc_thermal::export(m)?,
        None => Vec::new(),
    };
    // Plan every output before writing any.
    let mut plan = mtwin::io::Outputs::plan().folder(&a.out);
    for input in a.machine.iter().chain(&a.thermal) {
        plan = plan.input(input);
    }
    let dir_of = |e: &mtwin::controller::Exported| {
        if several {
            a.out.join(e.format.name())
        } else {
            a.out.clone()
        }
    };
    for e in &exported {
        let dir = dir_of(e);
        plan = plan.folder(&dir);
        for (name, _) in &e.files {
            plan = plan.output(dir.join(name));
        }
    }
    for (name, _) in &thermal_files {
        plan = plan.output(a.out.join(name));
    }
    let mut out = plan.begin()?;
    let ropts = ResidualOptions {
        linear_points: a.residual_points as usize,
        rotary_points: a.residual_rotary_points as usize,
    };
    let mut docs = BTreeMap::new();
    let mut order = Vec::new();
    for e in &exported {
        let dir = dir_of(e);
        for (name, text) in &e.files {
            let p = dir.join(name);
            out.write(&p, text.as_bytes())
                .with_context(|| format!("cannot write {}", p.display()))?;
        }
        let machine = machine.as_ref().expect("tables come from a machine");
        let r = mtwin::controller::residual(machine, &e.correction, &ropts);
        let prefix = if several {
            format!("{}/", e.format.name())
        } else {
            String::new()
        };
        order.push(e.format.name().to_string());
        docs.insert(e.format.name().to_string(), ExportDoc::new(e, r, &prefix));
    }
    for (name, text) in &thermal_files {
        let p = a.out.join(name);
        out.write(&p, text.as_bytes())
            .with_context(|| format!("cannot write {}", p.display()))?;
    }
    out.commit()?;
    let thermal_doc = thermal.as_ref().map(|m| ThermalDoc {
        files: thermal_files.iter().map(|f| f.0.clone()).collect(),
        component: mtwin::controller::linuxcnc_thermal::COMPONENT_NAME,
        period_min: m.period_min(),
        inputs: m.columns().to_vec(),
        heights_mm: m.heights().iter().map(|h| h.z_mm).collect(),
    });
    match a.format {
        Format::Json => {
            let mut v = serde_json::to_value(&docs)?;
            if let Some(t) = &thermal_doc {
                v["thermal"] = serde_json::to_value(t)?;
            }
            print_out(format_args!("{}\n", serde_json::to_string_pretty(&v)?))
        }
        Format::Human => {
            for name in order {
                print_out(format_args!("{}", docs[&name]));
            }
            if let Some(t) = &thermal_doc {
                print_out(format_args!(
                    "linuxcnc thermal: wrote {}\n  HAL component {} (model period {} min, inputs {}, heights {} mm); ini lines in thermal-README.txt\n",
                    t.files.join(", "),
                    t.component,
                    mtwin::io::fmt_f64(t.period_min),
                    t.inputs.join(", "),
                    t.heights_mm
                        .iter()
                        .map(|z| mtwin::io::fmt_f64(*z))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
        }
    }
    Ok(())
}
