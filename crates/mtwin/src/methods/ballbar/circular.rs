//! The ISO 230-4 circular test with a ballbar ([ISO 230-4] in
//! docs/references.md) and the diagnosis of its trace.
//!
//! Input: per direction (clockwise, counter-clockwise) samples of the angle θ
//! (degrees, counter-clockwise from the first axis, called X, in the test
//! plane; the second axis is called Y) and the deviation Δr of the measured
//! radius from the nominal radius R (µm). The test plane ([`Plane`]) names
//! the two axes: the keys below are those of the XY plane; in YZ their `x`
//! and `y` become `y` and `z`, in ZX `z` and `x` ([`Plane::key`]).
//!
//! **ISO 230-4 figures.** `G` circular deviation: the largest, over the two
//! directions, of the radial spread of the trace about its least-squares
//! circle centre. `H` circular hysteresis: the largest radial difference
//! between the two traces (both about their common least-squares centre,
//! compared on a 0.5° grid by linear interpolation). `F` radial deviation: the
//! largest |Δr| about the nominal centre (`F_max`, `F_min` the extremes).
//!
//! **Diagnosis.** With `s = +1` counter-clockwise, `−1` clockwise, each
//! error has a first-order radial signature; all of them, with the
//! set-up terms (centre offset `cx cos θ + cy sin θ`, radius offset), are
//! fitted jointly to both traces by linear least squares:
//!
//! | key | error model | signature Δr(θ) |
//! | --- | --- | --- |
//! | `backlash_x_um` = b | X lags b/2 against its motion: dx = −(b/2)·sign(vx) | (b/2)·s·sign(sin θ)·cos θ |
//! | `backlash_y_um` = b | dy = −(b/2)·sign(vy) | −(b/2)·s·sign(cos θ)·sin θ |
//! | `lateral_play_x_um` = l | X moves sideways when it reverses: dy = −(l/2)·sign(vx) | (l/2)·s·|sin θ| |
//! | `lateral_play_y_um` = l | dx = −(l/2)·sign(vy) | −(l/2)·s·|cos θ| |
//! | `reversal_spike_x_um` = h | transient at the reversal of X (θ = 90°, 270°) | h·exp(−φ/w), φ the angle travelled since the reversal, w = `spike_width_deg` |
//! | `reversal_spike_y_um` = h | at the reversal of Y (θ = 0°, 180°) | as for X |
//! | `cyclic_error_x_um` = A | dx = A·sin(2πx/p + φ), p = `cyclic_pitch_mm` | (a·sin(2πx/p) + c·cos(2πx/p))·cos θ, A = √(a² + c²) |
//! | `cyclic_error_y_um` = A | dy likewise in y | (…)·sin θ |
//! | `servo_mismatch_um` = m | X lags Y by τ: m = v·τ (feed v) | (m/2)·s·sin 2θ |
//! | `squareness_um_per_m` = α | x = x + α·y (α in µm/m) | (α·R/2)·sin 2θ |
//! | `straightness_x_um` = q | X axis bowed: dy = q·(x/R)² | q·cos²θ·sin θ |
//! | `straightness_y_um` = q | dx = q·(y/R)² | q·sin²θ·cos θ |
//! | `scale_mismatch_um` = k | X scale longer than Y by k over R | (k/2)·cos 2θ |
//!
//! A scale error common to both axes changes the radius like the length of
//! the bar and is not separable from it (`radius_offset_um`); the centre
//! offset is the set-up of the centre pivot. Every fitted parameter gets a
//! standard uncertainty from the residual and the covariance; parameters
//! whose estimates correlate above 0.995 in the given set-up (for example
//! servo mismatch and squareness from one direction only) are reported as
//! not separable and left out (`null`), not guessed. The diagnostics are
//! ranked by the peak of their fitted signature on the trace.
//!
//! **Traces.** The document keeps each direction's trace, decimated to at
//! most [`TRACE_POINTS_MAX`] points ([`DocTrace`]), and [`plot_svg`] draws
//! the polar plot from it: `--plot` and the report's section draw the same.

use std::f64::consts::PI;

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// One trace: angle (deg, counter-clockwise from X) and radial deviation (µm).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Trace {
    /// θ, degrees.
    pub angle_deg: Vec<f64>,
    /// Δr, µm.
    pub deviation_um: Vec<f64>,
}

/// The test plane: its first and second axis (the angle θ runs
/// counter-clockwise from the first towards the second, seen from the
/// positive side of the third).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Plane {
    /// First axis X, second Y (normal +z).
    #[default]
    Xy,
    /// First axis Y, second Z (normal +x).
    Yz,
    /// First axis Z, second X (normal +y).
    Zx,
}

impl Plane {
    /// Indices (0 = x, 1 = y, 2 = z) of the first and second axis and of the normal.
    pub fn indices(self) -> [usize; 3] {
        match self {
            Plane::Xy => [0, 1, 2],
            Plane::Yz => [1, 2, 0],
            Plane::Zx => [2, 0, 1],
        }
    }

    /// Lower-case letters of the first and second axis (`x`, `y` for XY).
    pub fn letters(self) -> [char; 2] {
        let [a, b, _] = self.indices();
        [['x', 'y', 'z'][a], ['x', 'y', 'z'][b]]
    }

    /// `xy`, `yz` or `zx`.
    pub fn as_str(self) -> &'static str {
        match self {
            Plane::Xy => "xy",
            Plane::Yz => "yz",
            Plane::Zx => "zx",
        }
    }

    /// The key of a diagnostic in this plane: the `x` and `y` words of an
    /// XY key (`backlash_x_um`) become the plane's first and second axis
    /// (`backlash_y_um` and `backlash_z_um` in YZ).
    pub fn key(self, xy_key: &str) -> String {
        let [a, b] = self.letters();
        xy_key
            .split('_')
            .map(|w| match w {
                "x" => a.to_string(),
                "y" => b.to_string(),
                w => w.to_string(),
            })
            .collect::<Vec<_>>()
            .join("_")
    }
}

/// Settings of the diagnosis.
#[derive(Debug, Clone, PartialEq)]
pub struct CircularOptions {
    /// Nominal radius R, mm.
    pub radius_mm: f64,
    /// Pitch of the cyclic error (lead of the screw), mm.
    pub cyclic_pitch_mm: f64,
    /// Decay angle of a reversal spike, degrees.
    pub spike_width_deg: f64,
    /// Test plane: names the axes of the diagnostics.
    pub plane: Plane,
}

impl Default for CircularOptions {
    fn default() -> Self {
        Self {
            radius_mm: 100.0,
            cyclic_pitch_mm: 10.0,
            spike_width_deg: 3.0,
            plane: Plane::Xy,
        }
    }
}

/// The JSON keys of the diagnostics and set-up terms of a [`CircularDoc`] in
/// the XY plane (other planes: [`Plane::key`]).
pub const DIAGNOSTICS: [&str; 15] = [
    "backlash_x_um",
    "backlash_y_um",
    "lateral_play_x_um",
    "lateral_play_y_um",
    "reversal_spike_x_um",
    "reversal_spike_y_um",
    "cyclic_error_x_um",
    "cyclic_error_y_um",
    "servo_mismatch_um",
    "squareness_um_per_m",
    "straightness_x_um",
    "straightness_y_um",
    "scale_mismatch_um",
    "centre_x_um",
    "centre_y_um",
];

/// Columns of the design matrix: the 15 diagnostics with cyclic x, y split
/// into sin/cos parts, plus the radius offset.
const NCOL: usize = 18;

fn wrap180(a: f64) -> f64 {
    (a + 180.0).rem_euclid(360.0) - 180.0
}

/// The angle travelled since the last reversal at one of `at` (deg), moving in direction `s`.
fn since_reversal(theta: f64, s: f64, at: [f64; 2]) -> f64 {
    at.iter()
        .map(|&a| (s * wrap180(theta - a)).rem_euclid(360.0))
        .fold(f64::INFINITY, f64::min)
}

/// The regressors at angle θ (deg), direction s, radius R (mm), for a unit of each parameter.
fn row(theta_deg: f64, s: f64, o: &CircularOptions) -> [f64; NCOL] {
    let t = theta_deg.to_radians();
    let (sn, cs) = t.sin_cos();
    let r = o.radius_mm;
    let spike = |at: [f64; 2]| (-since_reversal(theta_deg, s, at) / o.spike_width_deg).exp();
    let px = 2.0 * PI * r * cs / o.cyclic_pitch_mm;
    let py = 2.0 * PI * r * sn / o.cyclic_pitch_mm;
    [
        0.5 * s * sn.signum() * cs,       // backlash x
        -0.5 * s * cs.signum() * sn,      // backlash y
        0.5 * s * sn.abs(),               // lateral play x
        -0.5 * s * cs.abs(),              // lateral play y
        spike([90.0, 270.0]),             // spike x
        spike([0.0, 180.0]),              // spike y
        px.sin() * cs,                    // cyclic x, sin part
        px.cos() * cs,                    // cyclic x, cos part
        py.sin() * sn,                    // cyclic y, sin part
        py.cos() * sn,                    // cyclic y, cos part
        0.5 * s * (2.0 * t).sin(),        // servo mismatch
        0.5 * r * 1e-3 * (2.0 * t).sin(), // squareness µm/m × R mm × 1e-3 → µm
        cs * cs * sn,                     // straightness x
        sn * sn * cs,                     // straightness y
        0.5 * (2.0 * t).cos(),            // scale mismatch
        cs,                               // centre x
        sn,                               // centre y
        1.0,                              // radius offset
    ]
}

/// Largest number of points per direction kept in [`CircularDoc::traces`]:
/// one every half degree on a full turn (the grid of H), so a document and a
/// report stay small (a 3600-sample test: about 47 kB of JSON) whatever the
/// sampling rate of the ballbar.
pub const TRACE_POINTS_MAX: usize = 720;

/// One direction's trace as kept in the document (the input of the polar
/// plot): every `stride`-th input sample in the recorded order, starting at
/// the first, `stride = ⌈n / TRACE_POINTS_MAX⌉` for `n` input samples (so at
/// most [`TRACE_POINTS_MAX`] points; all of them when `n` is not above it);
/// angles rounded to 0.001° and Δr to 0.001 µm.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DocTrace {
    /// `cw` or `ccw`.
    pub direction: String,
    /// Every how many input samples one is kept.
    pub stride: usize,
    /// θ, degrees counter-clockwise from the plane's first axis, as recorded.
    pub angle_deg: Vec<f64>,
    /// Δr as measured (about the nominal centre), µm.
    pub deviation_um: Vec<f64>,
}

impl DocTrace {
    /// Decimate `t` as documented on [`DocTrace`].
    pub fn decimate(direction: &str, t: &Trace) -> DocTrace {
        let n = t.angle_deg.len().min(t.deviation_um.len());
        let stride = n.div_ceil(TRACE_POINTS_MAX).max(1);
        let r3 = |v: f64| (v * 1e3).round() / 1e3;
        DocTrace {
            direction: direction.into(),
            stride,
            angle_deg: (0..n).step_by(stride).map(|i| r3(t.angle_deg[i])).collect(),
            deviation_um: (0..n)
                .step_by(stride)
                .map(|i| r3(t.deviation_um[i]))
                .collect(),
        }
    }
}

/// One diagnostic in the ranking.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Ranked {
    /// JSON key of the diagnostic.
    pub key: String,
    /// Fitted value (unit in the key).
    pub value: f64,
    /// Standard uncertainty (same unit).
    pub uncertainty: f64,
    /// Peak |Δr| of its fitted signature on the trace, µm: the ranking measure.
    pub peak_um: f64,
}

/// Result of `mtwin ballbar circular`: ISO 230-4 figures and the diagnosis (µm
/// unless the key says otherwise; `null` = not separable in this set-up).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CircularDoc {
    /// Nominal radius, mm.
    pub radius_mm: f64,
    /// Test plane (`xy`, `yz`, `zx`).
    pub plane: Plane,
    /// Directions measured: "cw", "ccw" or both.
    pub directions: Vec<String>,
    /// Circular deviation G (ISO 230-4).
    #[serde(rename = "G")]
    pub g_um: f64,
    /// Circular deviation of the clockwise trace.
    pub g_cw_um: Option<f64>,
    /// Circular deviation of the counter-clockwise trace.
    pub g_ccw_um: Option<f64>,
    /// Circular hysteresis H (ISO 230-4); `null` with one direction.
    #[serde(rename = "H")]
    pub h_um: Option<f64>,
    /// Radial deviation F = max |Δr| about the nominal centre.
    #[serde(rename = "F")]
    pub f_um: f64,
    /// Largest Δr.
    pub f_max_um: f64,
    /// Smallest Δr.
    pub f_min_um: f64,
    /// The diagnostics and the centre offset by their JSON keys in the test
    /// plane ([`DIAGNOSTICS`] renamed by [`Plane::key`]; units in the keys;
    /// `null` = not separable in this set-up). Read them with
    /// [`CircularDoc::get`].
    #[serde(flatten)]
    pub diagnostics: BTreeMap<String, Option<f64>>,
    /// Radius offset (bar length and common scale error), µm.
    pub radius_offset_um: Option<f64>,
    /// RMS of the fit residual, µm.
    pub residual_rms_um: f64,
    /// Diagnostics by decreasing peak signature (set-up terms left out).
    pub ranking: Vec<Ranked>,
    /// Groups of parameters that cannot be told apart in this set-up.
    pub inseparable: Vec<Vec<String>>,
    /// Pitch used for the cyclic error, mm.
    pub cyclic_pitch_mm: f64,
    /// Decay angle used for reversal spikes, degrees.
    pub spike_width_deg: f64,
    /// The traces, decimated ([`DocTrace`]; clockwise first): what the
    /// polar plot draws. Empty in documents written before they were kept.
    #[serde(default)]
    pub traces: Vec<DocTrace>,
}

impl CircularDoc {
    /// The value of a diagnostic named by its XY key (`backlash_x_um` is the
    /// first axis of the plane, `backlash_y_um` the second); `None` when it is
    /// not separable in this set-up or not a key of [`DIAGNOSTICS`].
    pub fn get(&self, xy_key: &str) -> Option<f64> {
        self.diagnostics
            .get(&self.plane.key(xy_key))
            .copied()
            .flatten()
    }
}

/// The diagnostic each design-matrix column belongs to (the order of
/// [`row`]): the cyclic errors have a sine and a cosine column each.
fn param_names() -> [&'static str; NCOL] {
    std::array::from_fn(|j| match j {
        0..=6 => DIAGNOSTICS[j],
        7 => DIAGNOSTICS[6],
        8 | 9 => DIAGNOSTICS[7],
        10..=16 => DIAGNOSTICS[j - 2],
        _ => "radius_offset_um",
    })
}

fn spread(x: &[f64]) -> f64 {
    x.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - x.iter().copied().fold(f64::INFINITY, f64::min)
}

/// Remove the least-squares centre of one trace: Δr − (cx cos θ + cy sin θ + c).
fn about_lsq_centre(t: &Trace) -> Vec<f64> {
    let n = t.angle_deg.len();
    let a = DMatrix::from_fn(n, 3, |i, j| {
        let th = t.angle_deg[i].to_radians();
        [th.cos(), th.sin(), 1.0][j]
    });
    let b = DVector::from_column_slice(&t.deviation_um);
    let p = a
        .clone()
        .svd(true, true)
        .solve(&b, 1e-12)
        .unwrap_or_else(|_| DVector::zeros(3));
    (0..n)
        .map(|i| {
            let th = t.angle_deg[i].to_radians();
            t.deviation_um[i] - p[0] * th.cos() - p[1] * th.sin()
        })
        .collect()
}

/// Linear interpolation of a trace sorted by angle at `theta` (deg), periodic in 360°.
fn interp(sorted: &[(f64, f64)], theta: f64) -> f64 {
    let n = sorted.len();
    let th = theta.rem_euclid(360.0);
    let k = sorted.partition_point(|p| p.0 < th);
    let a = if k == 0 {
        (sorted[n - 1].0 - 360.0, sorted[n - 1].1)
    } else {
        sorted[k - 1]
    };
    let b = if k == n {
        (sorted[0].0 + 360.0, sorted[0].1)
    } else {
        sorted[k]
    };
    if (b.0 - a.0).abs() < 1e-12 {
        return a.1;
    }
    a.1 + (b.1 - a.1) * (th - a.0) / (b.0 - a.0)
}

/// Evaluate the traces (either may be absent, not both). Errors (a sentence)
/// on a trace of fewer than 8 samples or a radius that is not positive.
pub fn circular(
    cw: Option<&Trace>,
    ccw: Option<&Trace>,
    o: &CircularOptions,
) -> Result<CircularDoc, String> {
    if !(o.radius_mm.is_finite() && o.radius_mm > 0.0) {
        return Err("the radius must be positive".into());
    }
    if !(o.cyclic_pitch_mm > 0.0 && o.spike_width_deg > 0.0) {
        return Err("the cyclic pitch and the spike width must be positive".into());
    }
    let runs: Vec<(f64, &Trace, &str)> = [(-1.0, cw, "cw"), (1.0, ccw, "ccw")]
        .into_iter()
        .filter_map(|(s, t, n)| t.map(|t| (s, t, n)))
        .collect();
    if runs.is_empty() {
        return Err("no trace: give the clockwise or the counter-clockwise run, or both".into());
    }
    for (_, t, n) in &runs {
        if t.angle_deg.len() < 8 || t.angle_deg.len() != t.deviation_um.len() {
            return Err(format!("the {n} trace needs at least 8 samples"));
        }
    }
    // ISO 230-4 figures
    let g_of = |t: &Trace| spread(&about_lsq_centre(t));
    let g_cw = cw.map(g_of);
    let g_ccw = ccw.map(g_of);
    let g = g_cw.unwrap_or(0.0).max(g_ccw.unwrap_or(0.0));
    let all: Vec<f64> = runs
        .iter()
        .flat_map(|r| r.1.deviation_um.iter().copied())
        .collect();
    let f_max = all.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let f_min = all.iter().copied().fold(f64::INFINITY, f64::min);
    // joint fit
    let n: usize = runs.iter().map(|r| r.1.angle_deg.len()).sum();
    let mut a = DMatrix::zeros(n, NCOL);
    let mut b = DVector::zeros(n);
    let mut i = 0;
    for (s, t, _) in &runs {
        for (th, d) in t.angle_deg.iter().zip(&t.deviation_um) {
            let r = row(*th, *s, o);
            for (j, v) in r.iter().enumerate() {
                a[(i, j)] = *v;
            }
            b[i] = *d;
            i += 1;
        }
    }
    // Scale columns to unit norm for conditioning.
    let norms: Vec<f64> = (0..NCOL).map(|j| a.column(j).norm().max(1e-300)).collect();
    for j in 0..NCOL {
        let nj = norms[j];
        a.column_mut(j).scale_mut(1.0 / nj);
    }
    let ata = a.transpose() * &a;
    let names = param_names();
    // Correlations from the covariance (pseudo-inverse when singular).
    let svd = ata.clone().svd(true, true);
    let cov = svd
        .clone()
        .pseudo_inverse(1e-12)
        .unwrap_or_else(|_| DMatrix::zeros(NCOL, NCOL));
    let mut bad = [false; NCOL];
    let mut groups: Vec<Vec<String>> = Vec::new();
    let smin = svd
        .singular_values
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min);
    let smax = svd.singular_values.iter().copied().fold(0.0, f64::max);
    let singular = smin <= 1e-10 * smax;
    for p in 0..NCOL {
        for q in p + 1..NCOL {
            if names[p] == names[q] {
                continue;
            }
            let rho = cov[(p, q)] / (cov[(p, p)] * cov[(q, q)]).sqrt();
            let dead = singular && (ata[(p, q)].abs() / (ata[(p, p)] * ata[(q, q)]).sqrt() > 0.995);
            if rho.abs() > 0.995 || dead || !rho.is_finite() {
                bad[p] = true;
                bad[q] = true;
                let pair = vec![o.plane.key(names[p]), o.plane.key(names[q])];
                if !groups.contains(&pair) {
                    groups.push(pair);
                }
            }
        }
    }
    // Fit the separable parameters only.
    let keep: Vec<usize> = (0..NCOL).filter(|&j| !bad[j]).collect();
    let ak = DMatrix::from_fn(n, keep.len(), |r, c| a[(r, keep[c])]);
    let sol = ak
        .clone()
        .svd(true, true)
        .solve(&b, 1e-12)
        .map_err(|e| format!("the fit failed: {e}"))?;
    let resid = &b - &ak * &sol;
    let dof = (n as f64 - keep.len() as f64).max(1.0);
    let sigma = (resid.norm_squared() / dof).sqrt();
    let covk = (ak.transpose() * &ak)
        .try_inverse()
        .unwrap_or_else(|| DMatrix::zeros(keep.len(), keep.len()));
    let mut p = [f64::NAN; NCOL];
    let mut u = [f64::NAN; NCOL];
    for (c, &j) in keep.iter().enumerate() {
        p[j] = sol[c] / norms[j];
        u[j] = sigma * covk[(c, c)].max(0.0).sqrt() / norms[j];
    }
    let get = |j: usize| (!bad[j]).then_some(p[j]);
    let amp = |j: usize| (!bad[j] && !bad[j + 1]).then(|| p[j].hypot(p[j + 1]));
    // Peak signature for the ranking.
    let peak = |cols: &[usize]| -> f64 {
        let mut m: f64 = 0.0;
        for (s, t, _) in &runs {
            for th in &t.angle_deg {
                let r = row(*th, *s, o);
                let v: f64 = cols.iter().map(|&j| r[j] * p[j]).sum();
                m = m.max(v.abs());
            }
        }
        m
    };
    let mut ranking = Vec::new();
    let groups_of: [(&str, &[usize]); 13] = [
        ("backlash_x_um", &[0]),
        ("backlash_y_um", &[1]),
        ("lateral_play_x_um", &[2]),
        ("lateral_play_y_um", &[3]),
        ("reversal_spike_x_um", &[4]),
        ("reversal_spike_y_um", &[5]),
        ("cyclic_error_x_um", &[6, 7]),
        ("cyclic_error_y_um", &[8, 9]),
        ("servo_mismatch_um", &[10]),
        ("squareness_um_per_m", &[11]),
        ("straightness_x_um", &[12]),
        ("straightness_y_um", &[13]),
        ("scale_mismatch_um", &[14]),
    ];
    for (key, cols) in groups_of {
        if cols.iter().any(|&j| bad[j]) {
            continue;
        }
        let (value, unc) = if cols.len() == 2 {
            let v = p[cols[0]].hypot(p[cols[1]]);
            (v, u[cols[0]].max(u[cols[1]]))
        } else {
            (p[cols[0]], u[cols[0]])
        };
        ranking.push(Ranked {
            key: o.plane.key(key),
            value,
            uncertainty: unc,
            peak_um: peak(cols),
        });
    }
    ranking.sort_by(|x, y| y.peak_um.total_cmp(&x.peak_um));
    // H: both traces about the common centre, on a 0.5° grid.
    let h = match (cw, ccw) {
        (Some(c1), Some(c2)) => {
            let (cx, cy) = (p[15], p[16]);
            let prep = |t: &Trace| {
                let mut v: Vec<(f64, f64)> = t
                    .angle_deg
                    .iter()
                    .zip(&t.deviation_um)
                    .map(|(th, d)| {
                        let r = th.to_radians();
                        let (cx, cy) = (
                            if cx.is_finite() { cx } else { 0.0 },
                            if cy.is_finite() { cy } else { 0.0 },
                        );
                        (th.rem_euclid(360.0), d - cx * r.cos() - cy * r.sin())
                    })
                    .collect();
                v.sort_by(|a, b| a.0.total_cmp(&b.0));
                v
            };
            let (s1, s2) = (prep(c1), prep(c2));
            Some(
                (0..720)
                    .map(|k| {
                        let th = k as f64 * 0.5;
                        (interp(&s1, th) - interp(&s2, th)).abs()
                    })
                    .fold(0.0, f64::max),
            )
        }
        _ => None,
    };
    Ok(CircularDoc {
        radius_mm: o.radius_mm,
        plane: o.plane,
        directions: runs.iter().map(|r| r.2.to_string()).collect(),
        g_um: g,
        g_cw_um: g_cw,
        g_ccw_um: g_ccw,
        h_um: h,
        f_um: f_max.abs().max(f_min.abs()),
        f_max_um: f_max,
        f_min_um: f_min,
        diagnostics: [
            ("backlash_x_um", get(0)),
            ("backlash_y_um", get(1)),
            ("lateral_play_x_um", get(2)),
            ("lateral_play_y_um", get(3)),
            ("reversal_spike_x_um", get(4)),
            ("reversal_spike_y_um", get(5)),
            ("cyclic_error_x_um", amp(6)),
            ("cyclic_error_y_um", amp(8)),
            ("servo_mismatch_um", get(10)),
            ("squareness_um_per_m", get(11)),
            ("straightness_x_um", get(12)),
            ("straightness_y_um", get(13)),
            ("scale_mismatch_um", get(14)),
            ("centre_x_um", get(15)),
            ("centre_y_um", get(16)),
        ]
        .into_iter()
        .map(|(k, v)| (o.plane.key(k), v))
        .collect(),
        radius_offset_um: get(17),
        residual_rms_um: resid.norm() / (n as f64).sqrt(),
        ranking,
        inseparable: groups,
        cyclic_pitch_mm: o.cyclic_pitch_mm,
        spike_width_deg: o.spike_width_deg,
        traces: runs
            .iter()
            .map(|(_, t, name)| DocTrace::decimate(name, t))
            .collect(),
    })
}

impl std::fmt::Display for CircularDoc {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let o = |v: Option<f64>| v.map_or("—".to_string(), |v| format!("{v:.2}"));
        writeln!(
            f,
            "ISO 230-4 circular test, plane {}, R = {} mm ({}):",
            self.plane.as_str().to_uppercase(),
            crate::io::fmt_f64(self.radius_mm),
            self.directions.join(" + ")
        )?;
        writeln!(
            f,
            "  G = {:.2} µm   H = {} µm   F = {:.2} µm (Δr from {:.2} to {:.2})",
            self.g_um,
            o(self.h_um),
            self.f_um,
            self.f_min_um,
            self.f_max_um
        )?;
        writeln!(f, "  diagnosis, largest signature first:")?;
        for r in &self.ranking {
            writeln!(
                f,
                "    {:<22} {:>10.2} ± {:<7.2} (peak {:.2} µm)",
                r.key, r.value, r.uncertainty, r.peak_um
            )?;
        }
        writeln!(
            f,
            "  set-up: centre ({}, {}) µm, radius offset {} µm; residual RMS {:.2} µm",
            o(self.get("centre_x_um")),
            o(self.get("centre_y_um")),
            o(self.radius_offset_um),
            self.residual_rms_um
        )?;
        for g in &self.inseparable {
            writeln!(f, "  not separable in this set-up: {}", g.join(" and "))?;
        }
        Ok(())
    }
}

/// Polar plot of the document's traces ([`CircularDoc::traces`]; the one
/// plot of `mtwin ballbar circular --plot` and of the report's circular
/// section): Δr of each direction about the fitted centre (the set-up offset
/// `centre_*_um` of `doc` taken out, as ballbar software shows it), at its
/// angle in the test plane, on µm rings ([`crate::report::svg::polar`]: the
/// middle ring is Δr = 0, radius `R·(0.5 + 0.45·Δr/v)`, `v` the largest |Δr|
/// rounded up to 1, 2 or 5 × 10ⁿ µm); points sorted by angle in [0°, 360°),
/// the first repeated at +360° to close the curve. The title gives the
/// plane, radius and G, H, F.
pub fn plot_svg(doc: &CircularDoc) -> String {
    use crate::report::svg::{Series, polar};
    let cx = doc.get("centre_x_um").unwrap_or(0.0);
    let cy = doc.get("centre_y_um").unwrap_or(0.0);
    let series: Vec<Series> = doc
        .traces
        .iter()
        .map(|t| {
            let (name, color) = if t.direction == "cw" {
                ("clockwise", "#1f77b4")
            } else {
                ("counter-clockwise", "#d62728")
            };
            Series {
                name: format!("{name} Δr about the fitted centre"),
                points: about_centre(t, cx, cy),
                color: color.into(),
                markers: false,
            }
        })
        .collect();
    let [a, b] = doc.plane.letters();
    polar(
        &format!(
            "Circular test, plane {}{} (θ from +{}), R = {} mm: G = {:.2} µm, H = {} µm, F = {:.2} µm",
            a.to_ascii_uppercase(),
            b.to_ascii_uppercase(),
            a.to_ascii_uppercase(),
            crate::io::fmt_f64(doc.radius_mm),
            doc.g_um,
            doc.h_um.map_or("—".into(), |h| format!("{h:.2}")),
            doc.f_um
        ),
        &series,
        "µm",
        1.0,
    )
}

/// The points `(θ in [0°, 360°), Δr − cx cos θ − cy sin θ)` of a trace
/// sorted by angle, the first repeated at θ + 360°.
fn about_centre(t: &DocTrace, cx: f64, cy: f64) -> Vec<(f64, f64)> {
    let mut pts: Vec<(f64, f64)> = t
        .angle_deg
        .iter()
        .zip(&t.deviation_um)
        .map(|(&th, &d)| {
            let r = th.to_radians();
            (th.rem_euclid(360.0), d - cx * r.cos() - cy * r.sin())
        })
        .collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    if let Some(&first) = pts.first() {
        pts.push((first.0 + 360.0, first.1));
    }
    pts
}
