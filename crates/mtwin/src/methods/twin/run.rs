//! `mtwin twin predict` in the library's one shape: [`PredictOptions`] in,
//! a [`PredictRun`] (summary, plots, [`TwinPredictDoc`]) out; the rows of
//! `PRED.csv` ([`pred_row`], columns [`crate::report::twin::COLUMNS`]) go
//! to the caller's sink as they are predicted.

use std::io::{self, BufRead};

use super::TwinError;
use super::breakdown::{Commands, breakdown, predict};
use super::doc::TwinPredictDoc;
use super::pipeline::{Progress, Sources, TwinSample, TwinSummary};
use super::plot::{self, PlotCollector};
use crate::model::Machine;

/// The plot files of a run with [`PredictOptions::plot`], in the order of
/// [`PredictRun::plots`].
pub const PLOT_FILES: [&str; 3] = ["path.svg", "tip_error.svg", "axis_error.svg"];

/// Points kept per plot (the run is decimated to about this many).
const PLOT_POINTS: usize = 2000;

/// Options of [`run`].
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct PredictOptions {
    /// Error sources kept in the run (default: all).
    pub sources: Sources,
    /// Also run servo-only and geometry-only ([`breakdown`]); the input is
    /// read again for each.
    pub breakdown: bool,
    /// Draw the three plots of [`PLOT_FILES`].
    pub plot: bool,
    /// The name of the `PRED.csv` the caller writes, for the document.
    pub out: String,
}

/// What [`run`] predicted.
#[derive(Debug, Clone)]
pub struct PredictRun {
    /// The run's summary.
    pub summary: TwinSummary,
    /// The SVG plots, named as [`PLOT_FILES`] (empty without
    /// [`PredictOptions::plot`]).
    pub plots: Vec<(&'static str, String)>,
    /// The document; its `plots` are left empty for the caller, who knows
    /// where they are written.
    pub doc: TwinPredictDoc,
}

/// The values of one `PRED.csv` row, in the order of
/// [`crate::report::twin::COLUMNS`]: `t_s`, command tip and axis, actual tip
/// and axis (mm, unit vectors, in W), `tip_error` (mm), `axis_error` (rad).
pub fn pred_row(r: &TwinSample) -> [f64; 15] {
    [
        r.t,
        r.cmd_tip.x,
        r.cmd_tip.y,
        r.cmd_tip.z,
        r.cmd_axis.x,
        r.cmd_axis.y,
        r.cmd_axis.z,
        r.tip.x,
        r.tip.y,
        r.tip.z,
        r.axis.x,
        r.axis.y,
        r.axis.z,
        r.tip_error,
        r.axis_error,
    ]
}

/// `mtwin twin predict`: the twin of `machine` on `commands`, read from
/// `open()` (once, and twice more for the breakdown), every sample to
/// `sink`; `progress` gets the sources of the run it reports on.
pub fn run<R, O, F>(
    machine: &Machine,
    commands: Commands<'_>,
    mut open: O,
    options: &PredictOptions,
    mut sink: F,
    progress: &mut dyn FnMut(Sources, Progress),
) -> Result<PredictRun, TwinError>
where
    R: BufRead,
    O: FnMut() -> io::Result<R>,
    F: FnMut(&TwinSample) -> io::Result<()>,
{
    let sources = options.sources;
    let mut collector = options.plot.then(|| PlotCollector::new(PLOT_POINTS));
    let input = open().map_err(TwinError::Read)?;
    let summary = predict(
        machine,
        sources,
        commands,
        input,
        |r| {
            if let Some(p) = collector.as_mut() {
                p.add(r);
            }
            sink(r)
        },
        &mut |p| progress(sources, p),
    )?;
    let by_source = if options.breakdown {
        Some(breakdown(machine, commands, &summary, &mut open, progress)?)
    } else {
        None
    };
    let plots = match &collector {
        Some(p) => {
            let pts = p.points();
            PLOT_FILES
                .into_iter()
                .zip([
                    plot::path_svg(&pts),
                    plot::tip_error_svg(&pts),
                    plot::axis_error_svg(&pts),
                ])
                .collect()
        }
        None => Vec::new(),
    };
    let doc = TwinPredictDoc::new(&summary, &options.out, by_source, &[]);
    Ok(PredictRun {
        summary,
        plots,
        doc,
    })
}
