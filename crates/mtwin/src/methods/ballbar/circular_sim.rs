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
//! feed), the first axis lagging; equal servos show none.

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
