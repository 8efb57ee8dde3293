//! `mtwin twin predict` results as a typed document ([`TwinPredictDoc`]),
//! with the optional per-source breakdown ([`TwinBreakdownDoc`]).

use serde::{Deserialize, Serialize};

use super::{Sources, TwinSummary};

/// Error summary of one run: tool-tip error `ε_p` (mm) and tool-axis error
/// `ε_o` (rad).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TwinErrorsDoc {
    /// Largest `ε_o` (rad).
    pub axis_error_max: f64,
    /// RMS of `ε_o` (rad).
    pub axis_error_rms: f64,
    /// Largest `ε_p` (mm).
    pub tip_error_max: f64,
    /// RMS of `ε_p` (mm).
    pub tip_error_rms: f64,
}

impl From<&TwinSummary> for TwinErrorsDoc {
    fn from(s: &TwinSummary) -> Self {
        TwinErrorsDoc {
            axis_error_max: s.axis_error_max,
            axis_error_rms: s.axis_error_rms,
            tip_error_max: s.tip_error_max,
            tip_error_rms: s.tip_error_rms,
        }
    }
}

/// One value with every source, with the servo alone and with the geometry alone.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BySourceDoc {
    /// Servo and geometry.
    pub all: f64,
    /// Geometric errors alone.
    pub geometry: f64,
    /// Servo models alone.
    pub servo: f64,
}

/// One stretch of the run (a tenth of the samples) in the breakdown.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StretchDoc {
    /// `servo` or `geometry`: the source with the larger tool-tip RMS.
    pub dominant: String,
    /// Command path length at the first and last sample (mm).
    pub path_mm: [f64; 2],
    /// First and last time (s).
    pub t_s: [f64; 2],
    /// Largest `ε_p` (mm).
    pub tip_error_max: BySourceDoc,
    /// RMS of `ε_p` (mm).
    pub tip_error_rms: BySourceDoc,
}

/// `twin predict --breakdown`: the run repeated with the servo alone and
/// with the geometry alone.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TwinBreakdownDoc {
    /// Every source.
    pub all: TwinErrorsDoc,
    /// `servo` or `geometry`: the source with the larger tool-tip RMS overall.
    pub dominant: String,
    /// Geometric errors alone.
    pub geometry: TwinErrorsDoc,
    /// Servo models alone.
    pub servo: TwinErrorsDoc,
    /// Per stretch of the run.
    pub stretches: Vec<StretchDoc>,
}

/// The source whose tool-tip RMS is larger (`servo` on a tie).
pub fn dominant(servo: f64, geometry: f64) -> &'static str {
    if servo >= geometry {
        "servo"
    } else {
        "geometry"
    }
}

impl TwinBreakdownDoc {
    /// The breakdown of run `all` by its runs with the servo alone (`servo`)
    /// and the geometry alone (`geometry`) on the same commands.
    pub fn new(all: &TwinSummary, servo: &TwinSummary, geometry: &TwinSummary) -> Self {
        let stretches = all
            .bins
            .iter()
            .zip(&servo.bins)
            .zip(&geometry.bins)
            .map(|((b, s), g)| StretchDoc {
                dominant: dominant(s.tip_error_rms, g.tip_error_rms).into(),
                path_mm: b.path_length,
                t_s: b.t,
                tip_error_max: BySourceDoc {
                    all: b.tip_error_max,
                    geometry: g.tip_error_max,
                    servo: s.tip_error_max,
                },
                tip_error_rms: BySourceDoc {
                    all: b.tip_error_rms,
                    geometry: g.tip_error_rms,
                    servo: s.tip_error_rms,
                },
            })
            .collect();
        TwinBreakdownDoc {
            all: all.into(),
            dominant: dominant(servo.tip_error_rms, geometry.tip_error_rms).into(),
            geometry: geometry.into(),
            servo: servo.into(),
            stretches,
        }
    }
}

/// `mtwin twin predict`: the summary of the predicted errors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TwinPredictDoc {
    /// Largest tool-axis error `ε_o` (rad).
    pub axis_error_max: f64,
    /// Command path length where it occurs (mm).
    pub axis_error_max_path_mm: f64,
    /// Time where it occurs (s).
    pub axis_error_max_t_s: f64,
    /// RMS of `ε_o` (rad).
    pub axis_error_rms: f64,
    /// The per-source breakdown (`--breakdown`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub breakdown: Option<TwinBreakdownDoc>,
    /// Last minus first time (s).
    pub duration_s: f64,
    /// The PRED.csv written.
    pub out: String,
    /// Command path length (mm).
    pub path_length_mm: f64,
    /// Plot files written (`--plot`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub plots: Vec<String>,
    /// Samples predicted.
    pub samples: u64,
    /// Error sources kept: `all`, `servo` or `geometry`.
    pub sources: String,
    /// Largest tool-tip error `ε_p` (mm).
    pub tip_error_max: f64,
    /// Command path length where it occurs (mm).
    pub tip_error_max_path_mm: f64,
    /// Time where it occurs (s).
    pub tip_error_max_t_s: f64,
    /// RMS of `ε_p` (mm).
    pub tip_error_rms: f64,
}

impl TwinPredictDoc {
    /// The document of run `s`, written to `out`, with its optional
    /// `breakdown` and the `plots` written.
    pub fn new(
        s: &TwinSummary,
        out: &str,
        breakdown: Option<TwinBreakdownDoc>,
        plots: &[String],
    ) -> Self {
        TwinPredictDoc {
            axis_error_max: s.axis_error_max,
            axis_error_max_path_mm: s.axis_error_max_at.path_length,
            axis_error_max_t_s: s.axis_error_max_at.t,
            axis_error_rms: s.axis_error_rms,
            breakdown,
            duration_s: s.t[1] - s.t[0],
            out: out.to_string(),
            path_length_mm: s.path_length,
            plots: plots.to_vec(),
            samples: s.samples,
            sources: s.sources.as_str().into(),
            tip_error_max: s.tip_error_max,
            tip_error_max_path_mm: s.tip_error_max_at.path_length,
            tip_error_max_t_s: s.tip_error_max_at.t,
            tip_error_rms: s.tip_error_rms,
        }
    }
}

/// The summary (µm, µrad), then the breakdown table and the plot files.
impl std::fmt::Display for TwinPredictDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let what = match self.sources.as_str() {
            s if s == Sources::Servo.as_str() => "servo only",
            s if s == Sources::Geometry.as_str() => "geometry only",
            _ => "servo + geometry",
        };
        writeln!(
            f,
            "{} samples, {:.3} s, command path {:.3} mm ({what}) → {}",
            self.samples, self.duration_s, self.path_length_mm, self.out
        )?;
        writeln!(
            f,
            "tool-tip error ε_p:  max {:.3} µm at t = {:.3} s (path {:.3} mm), RMS {:.3} µm",
            self.tip_error_max * 1e3,
            self.tip_error_max_t_s,
            self.tip_error_max_path_mm,
            self.tip_error_rms * 1e3
        )?;
        writeln!(
            f,
            "tool-axis error ε_o: max {:.3} µrad at t = {:.3} s (path {:.3} mm), RMS {:.3} µrad",
            self.axis_error_max * 1e6,
            self.axis_error_max_t_s,
            self.axis_error_max_path_mm,
            self.axis_error_rms * 1e6
        )?;
        if let Some(b) = &self.breakdown {
            write!(f, "{b}")?;
        }
        for p in &self.plots {
            writeln!(f, "plot → {p}")?;
        }
        Ok(())
    }
}

/// The per-source table (µm, µrad) and the table of stretches.
impl std::fmt::Display for TwinBreakdownDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "\nbreakdown (tool-tip error ε_p in µm, tool-axis error ε_o in µrad):"
        )?;
        writeln!(
            f,
            "  {:<10} {:>12} {:>12} {:>12}",
            "source", "ε_p max", "ε_p RMS", "ε_o max"
        )?;
        for (n, s) in [
            ("all", &self.all),
            ("servo", &self.servo),
            ("geometry", &self.geometry),
        ] {
            writeln!(
                f,
                "  {:<10} {:>12.3} {:>12.3} {:>12.3}",
                n,
                s.tip_error_max * 1e3,
                s.tip_error_rms * 1e3,
                s.axis_error_max * 1e6
            )?;
        }
        writeln!(f, "  dominant overall: {}", self.dominant)?;
        writeln!(
            f,
            "\n  {:>21} {:>12} {:>12} {:>12}  dominant",
            "path, mm", "all RMS", "servo RMS", "geom. RMS"
        )?;
        for b in &self.stretches {
            writeln!(
                f,
                "  {:>10.3}–{:<10.3} {:>12.3} {:>12.3} {:>12.3}  {}",
                b.path_mm[0],
                b.path_mm[1],
                b.tip_error_rms.all * 1e3,
                b.tip_error_rms.servo * 1e3,
                b.tip_error_rms.geometry * 1e3,
                b.dominant
            )?;
        }
        Ok(())
    }
}
