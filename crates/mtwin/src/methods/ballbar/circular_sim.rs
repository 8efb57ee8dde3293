//! Simulated circular-test traces with known errors (for planning and for
//! checking [`super::circular::circular`]): each error acts as a displacement
//! of the actual position (the error models of the table in
//! [`super::circular`]), the ballbar reads the exact distance from the centre,
//! and Gaussian noise is added.
//!
//! Servo dynamics: with [`CircularErrors::servos`] the commanded circle at
//! the given feed (starting at rest at θ = 0, one turn of run-in, then the
//! turn that is recorded) goes through each axis's servo model (the
//! transfer functions of `mtwin servo fit`, docs/servo.md), and the axes
//! stand where the models put them. Two first-order lags with velocity lags
//! τ₁ and τ₂ then show as a servo mismatch of about `v·(τ₁ − τ₂)` (v the
//! feed), the first axis lagging; equal servos show none. Different servos
//! also show as a scale mismatch ([`servo_signature`]), second order in ω·τ.

use crate::sysid::Servo;

use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

use super::circular::{CircularOptions, Trace};

/// Known errors of a simulated machine (units as the JSON keys of the diagnosis).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CircularErrors {
    /// µm.
    pub backlash_x_um: f64,
    /// µm.
    pub backlash_y_um: f64,
    /// µm.
    pub lateral_play_x_um: f64,
    /// µm.
    pub lateral_play_y_um: f64,
    /// µm.
    pub reversal_spike_x_um: f64,
    /// µm.
    pub reversal_spike_y_um: f64,
    /// Amplitude µm (phase `cyclic_phase_deg`).
    pub cyclic_error_x_um: f64,
    /// Amplitude µm.
    pub cyclic_error_y_um: f64,
    /// Phase of both cyclic errors, degrees.
    pub cyclic_phase_deg: f64,
    /// µm (X lags Y by this distance along the path).
    pub servo_mismatch_um: f64,
    /// µm/m.
    pub squareness_um_per_m: f64,
    /// µm.
    pub straightness_x_um: f64,
    /// µm.
    pub straightness_y_um: f64,
    /// µm over R.
    pub scale_mismatch_um: f64,
    /// Centre offset, µm.
    pub centre_x_um: f64,
    /// Centre offset, µm.
    pub centre_y_um: f64,
    /// Bar length error, µm.
    pub radius_offset_um: f64,
    /// Servo models of the two axes and the feed (in addition to
    /// `servo_mismatch_um`).
    pub servos: Option<ServoPair>,
}

/// The servo models of the plane's two axes (first, second) and the feed of
/// the circle: [`simulate_circular`] runs the commanded circle through them.
#[derive(Debug, Clone, PartialEq)]
pub struct ServoPair {
    /// Servo of the first axis (X in the XY plane): command to position, mm.
    pub first: Servo,
    /// Servo of the second axis.
    pub second: Servo,
    /// Feed along the circle, mm/min.
    pub feed_mm_min: f64,
}

/// What two servo models put into the diagnosis of a circle, in its keys'
/// units (µm): `scale_mismatch_um` and `servo_mismatch_um`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ServoSignature {
    /// The `(k/2)·cos 2θ` term, µm.
    pub scale_mismatch_um: f64,
    /// The `(m/2)·s·sin 2θ` term, µm.
    pub servo_mismatch_um: f64,
}

/// The scale and servo mismatch the servos of `p` put on a circle of
/// radius `R` (mm), in closed form.
///
/// In the steady state at ω = v/R each axis follows its sinusoidal command
/// through its frequency response `Gᵢ = Gᵢ(e^{jω·ts})`. Counter-clockwise,
/// θ = ωt: `x = R·Re(G₁e^{iθ})`, `y = R·Im(G₂e^{iθ})`, so
/// `|p|² = R²·(μ + Re(D·e^{2iθ})/2)` with `μ = (|G₁|² + |G₂|²)/2` and
/// `D = G₁² − G₂²`; to first order in `D`
/// `Δr = R·(√μ − 1) + R/(4√μ)·(Re D·cos 2θ − Im D·sin 2θ)`, and clockwise
/// (the conjugate responses) the `sin 2θ` term changes sign. Matched to the
/// signatures `(k/2)·cos 2θ` and `(m/2)·s·sin 2θ` of the diagnosis:
///
/// `k = R·Re D/(2√μ)`, `m = −R·Im D/(2√μ)`.
///
/// For first-order lags `G = 1/(1 + iu)`, `u = ωτ`: `Re G² = (1 − u²)/(1 + u²)²`,
/// so `k ≈ −(3/2)·R·(u₁² − u₂²)` for small `u`. The amplitude ratios
/// `|G| = 1/√(1 + u²)` alone (the radius difference of the two axes,
/// `R·(|G₁| − |G₂|) ≈ −R·(u₁² − u₂²)/2`) give a third of it; the rest is the
/// servo-mismatch ellipse turned by the common phase lag. With `m ≈ R·(φ₁ − φ₂)`
/// the scale term is `k ≈ −3·m·ū`, `ū` the mean `ωτ`: small against `m`.
pub fn servo_signature(p: &ServoPair, radius_mm: f64) -> ServoSignature {
    let omega = p.feed_mm_min / 60.0 / radius_mm;
    let f_hz = omega / (2.0 * std::f64::consts::PI);
    let (g1, g2) = (
        p.first.frequency_response(f_hz),
        p.second.frequency_response(f_hz),
    );
    let mu = 0.5 * (g1.norm_sqr() + g2.norm_sqr());
    let d = g1 * g1 - g2 * g2;
    let r_um = radius_mm * 1e3;
    ServoSignature {
        scale_mismatch_um: r_um * d.re / (2.0 * mu.sqrt()),
        servo_mismatch_um: -r_um * d.im / (2.0 * mu.sqrt()),
    }
}

/// The following error `actual − command` (mm) of each axis at the `samples`
/// angles of the recorded turn (see the module documentation).
fn servo_errors(p: &ServoPair, r: f64, s: f64, samples: usize) -> [Vec<f64>; 2] {
    let v = p.feed_mm_min / 60.0;
    let omega = v / r;
    let turn = 2.0 * std::f64::consts::PI / omega;
    let one = |servo: &Servo, first: bool| -> Vec<f64> {
        let ts = servo.ts();
        let n = (2.0 * turn / ts).ceil() as usize + 2;
        let u: Vec<f64> = (0..n)
            .map(|j| {
                let th = s * omega * j as f64 * ts;
                if first { r * th.cos() } else { r * th.sin() }
            })
            .collect();
        let y = servo.simulate(&u);
        let e: Vec<f64> = y.iter().zip(&u).map(|(y, u)| y - u).collect();
        (0..samples)
            .map(|k| {
                let t = turn * (1.0 + k as f64 / samples as f64);
                let x = t / ts;
                let j = (x.floor() as usize).min(n - 2);
                let f = x - j as f64;
                e[j] + f * (e[j + 1] - e[j])
            })
            .collect()
    };
    [one(&p.first, true), one(&p.second, false)]
}

/// One direction (`ccw` true: counter-clockwise) of `samples` points over a
/// full turn, Gaussian noise of `noise_um` (standard deviation) from `seed`.
pub fn simulate_circular(
    e: &CircularErrors,
    o: &CircularOptions,
    ccw: bool,
    samples: usize,
    noise_um: f64,
    seed: u64,
) -> Trace {
    let s = if ccw { 1.0 } else { -1.0 };
    let r = o.radius_mm;
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed ^ u64::from(ccw));
    let noise = Normal::new(0.0, noise_um.max(0.0)).ok();
    let mut t = Trace::default();
    let um = 1e-3;
    let servo = e.servos.as_ref().map(|p| servo_errors(p, r, s, samples));
    for k in 0..samples {
        let th_deg = s * 360.0 * k as f64 / samples as f64;
        let th_deg = th_deg.rem_euclid(360.0);
        let th = th_deg.to_radians();
        let (sn, cs) = th.sin_cos();
        // commanded point and velocity directions
        let (x, y) = (r * cs, r * sn);
        let (vx, vy) = (-s * sn, s * cs);
        let sg = |v: f64| if v.abs() < 1e-12 { 0.0 } else { v.signum() };
        let mut dx = -0.5 * e.backlash_x_um * sg(vx) - 0.5 * e.lateral_play_y_um * sg(vy);
        let mut dy = -0.5 * e.backlash_y_um * sg(vy) - 0.5 * e.lateral_play_x_um * sg(vx);
        let ph = e.cyclic_phase_deg.to_radians();
        dx += e.cyclic_error_x_um * (2.0 * std::f64::consts::PI * x / o.cyclic_pitch_mm + ph).sin();
        dy += e.cyclic_error_y_um * (2.0 * std::f64::consts::PI * y / o.cyclic_pitch_mm + ph).sin();
        dx += e.squareness_um_per_m * 1e-6 * y / um;
        dx += e.straightness_y_um * (y / r).powi(2);
        dy += e.straightness_x_um * (x / r).powi(2);
        dx += e.scale_mismatch_um * x / r;
        dx += e.centre_x_um;
        dy += e.centre_y_um;
        // servo: X lags by the mismatch distance along the path
        let lag = e.servo_mismatch_um * um / r; // rad
        let xs = r * (th - s * lag).cos() - x;
        let (sx, sy) = servo.as_ref().map_or((0.0, 0.0), |[a, b]| (a[k], b[k]));
        let (ax, ay) = (x + xs + sx + dx * um, y + sy + dy * um);
        let mut d = (ax.hypot(ay) - r) / um + e.radius_offset_um;
        // reversal spikes: radial transients after each reversal
        for (h, at) in [
            (e.reversal_spike_x_um, [90.0, 270.0]),
            (e.reversal_spike_y_um, [0.0, 180.0]),
        ] {
            if h != 0.0 {
                let phi = at
                    .iter()
                    .map(|&a: &f64| {
                        (s * ((th_deg - a + 180.0).rem_euclid(360.0) - 180.0)).rem_euclid(360.0)
                    })
                    .fold(f64::INFINITY, f64::min);
                d += h * (-phi / o.spike_width_deg).exp();
            }
        }
        if let Some(nz) = &noise {
            d += nz.sample(&mut rng);
        }
        t.angle_deg.push(th_deg);
        t.deviation_um.push(d);
    }
    t
}
