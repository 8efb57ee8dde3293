use nalgebra::Complex;

use super::{Arx, ArxStepper, SysidError};

/// A servo axis as a discrete transfer function from command `u` to encoder
/// position `y` (the `[axes.servo]` table of docs/machine-model.md):
///
/// ```text
/// y(k) = −Σ_{i=1..na} a_i·y(k−i) + Σ_{j=0..nb} b_j·u(k−j−nk),   a_0 = 1
/// ```
///
/// run on deviations from the first command sample, so an axis at rest stays
/// at rest. Positions in mm (linear axis) or degrees (rotary axis); `ts` in s.
#[derive(Debug, Clone, PartialEq)]
pub struct Servo {
    ts: f64,
    model: Arx,
}

impl Servo {
    /// A servo from its sample period (s), `b_0..b_nb`, `a_0..a_na` (`a_0 = 1`)
    /// and input delay `nk` (samples).
    pub fn new(ts: f64, b: Vec<f64>, a: Vec<f64>, nk: usize) -> Result<Servo, SysidError> {
        if !(ts.is_finite() && ts > 0.0) {
            return Err(SysidError::BadPeriod(ts));
        }
        Ok(Servo {
            ts,
            model: Arx::new(a, vec![(b, nk)])?,
        })
    }

    /// A servo from a single-input ARX model.
    pub fn from_arx(ts: f64, model: &Arx) -> Result<Servo, SysidError> {
        if model.n_inputs() != 1 {
            return Err(SysidError::InputCount {
                expected: 1,
                found: model.n_inputs(),
            });
        }
        Servo::new(ts, model.b(0).to_vec(), model.a().to_vec(), model.nk(0))
    }

    /// Sample period, s.
    pub fn ts(&self) -> f64 {
        self.ts
    }

    /// `b_0..b_nb`.
    pub fn b(&self) -> &[f64] {
        self.model.b(0)
    }

    /// `a_0..a_na` with `a_0 = 1`.
    pub fn a(&self) -> &[f64] {
        self.model.a()
    }

    /// Input delay, samples.
    pub fn nk(&self) -> usize {
        self.model.nk(0)
    }

    /// The underlying single-input ARX model (on deviations).
    pub fn arx(&self) -> &Arx {
        &self.model
    }

    /// Encoder positions for a command sequence sampled at `ts`: the model runs
    /// on `u(k) − u(0)` from rest and `u(0)` is added back.
    pub fn simulate(&self, commands: &[f64]) -> Vec<f64> {
        let mut s = self.stepper();
        commands.iter().map(|&u| s.push(u)).collect()
    }

    /// A streaming simulator: push one command, get one encoder position.
    pub fn stepper(&self) -> ServoStepper {
        ServoStepper {
            inner: self.model.stepper(),
            origin: None,
        }
    }

    /// Frequency response `H(e^{jωts})` at `f_hz` (Hz).
    pub fn frequency_response(&self, f_hz: f64) -> Complex<f64> {
        let w = 2.0 * std::f64::consts::PI * f_hz * self.ts;
        let q = Complex::from_polar(1.0, -w);
        let poly = |c: &[f64]| {
            c.iter()
                .rev()
                .fold(Complex::new(0.0, 0.0), |acc, &v| acc * q + v)
        };
        q.powu(self.nk() as u32) * poly(self.b()) / poly(self.a())
    }

    /// Static gain `B(1)/A(1)` (1 for an axis that reaches its command).
    pub fn dc_gain(&self) -> f64 {
        self.model.dc_gain(0)
    }

    /// The −3 dB bandwidth in Hz: the lowest frequency where `|H|` falls to
    /// `|H(0)|/√2`. `None` when the gain never drops that far below the
    /// Nyquist frequency, or the static gain is zero or infinite.
    pub fn bandwidth_hz(&self) -> Option<f64> {
        let g0 = self.dc_gain().abs();
        if !(g0.is_finite() && g0 > 0.0) {
            return None;
        }
        let level = g0 / std::f64::consts::SQRT_2;
        let below = |f: f64| self.frequency_response(f).norm() < level;
        let nyquist = 0.5 / self.ts;
        let steps = 4000;
        let lo_f = nyquist * 1e-6;
        let mut prev = lo_f;
        if below(prev) {
            return Some(prev);
        }
        for i in 1..=steps {
            let f = lo_f * (nyquist / lo_f).powf(i as f64 / steps as f64);
            if below(f) {
                let (mut lo, mut hi) = (prev, f);
                for _ in 0..80 {
                    let mid = 0.5 * (lo + hi);
                    if below(mid) { hi = mid } else { lo = mid }
                }
                return Some(0.5 * (lo + hi));
            }
            prev = f;
        }
        None
    }

    /// The velocity lag `τ` (s): at a constant commanded velocity `v` the axis
    /// settles to a following error `u − y = v·τ`.
    ///
    /// For a ramp `u(k) = v·ts·k`, the final-value theorem gives
    /// `e_ss = v·ts·(Σ (j+nk)·b_j − Σ i·a_i)/A(1)` when `B(1) = A(1)`. An
    /// identified model has a static gain `g = B(1)/A(1)` only close to 1;
    /// `τ` is then the low-frequency group delay
    /// `ts·(Σ (j+nk)·b_j/B(1) − Σ i·a_i/A(1))`, which equals the formula
    /// above at `g = 1` (with `g ≠ 1` the error also grows as `(1−g)·v·t`).
    pub fn velocity_lag_s(&self) -> Result<f64, SysidError> {
        let a1: f64 = self.a().iter().sum();
        let b1: f64 = self.b().iter().sum();
        if a1.abs() < 1e-300 || b1.abs() < 1e-300 {
            return Err(SysidError::Degenerate(
                "the servo has no finite nonzero static gain, so it has no steady following error"
                    .into(),
            ));
        }
        let nk = self.nk() as f64;
        let mb: f64 = self
            .b()
            .iter()
            .enumerate()
            .map(|(j, b)| (j as f64 + nk) * b)
            .sum();
        let ma: f64 = self.a().iter().enumerate().map(|(i, a)| i as f64 * a).sum();
        Ok(self.ts * (mb / b1 - ma / a1))
    }

    /// Steady following error `u − y` (mm or deg) at the constant velocity
    /// `velocity` (mm/s or deg/s).
    pub fn following_error(&self, velocity: f64) -> Result<f64, SysidError> {
        Ok(velocity * self.velocity_lag_s()?)
    }
}

/// Streaming servo simulation: the first command pushed is the reference
/// `u(0)`; memory stays bounded for trajectories of any length.
#[derive(Debug, Clone)]
pub struct ServoStepper {
    inner: ArxStepper,
    origin: Option<f64>,
}

impl ServoStepper {
    /// Push the next command, get the encoder position at that sample.
    pub fn push(&mut self, command: f64) -> f64 {
        let u0 = *self.origin.get_or_insert(command);
        u0 + self.inner.push(&[command - u0])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The example servo of docs/machine-model.md.
    fn example() -> Servo {
        Servo::new(
            0.001,
            vec![0.0, 0.0183, 0.0171],
            vec![1.0, -1.8106, 0.8460],
            0,
        )
        .unwrap()
    }

    #[test]
    fn at_rest_stays_at_rest_and_stepper_matches() {
        let s = example();
        let y = s.simulate(&[123.4; 50]);
        assert!(y.iter().all(|&v| v == 123.4));
        let u: Vec<f64> = (0..300).map(|k| 5.0 + (k as f64 * 0.02).sin()).collect();
        let y = s.simulate(&u);
        let mut st = s.stepper();
        for (uk, yk) in u.iter().zip(&y) {
            assert_eq!(st.push(*uk), *yk);
        }
        assert!(Servo::new(0.0, vec![1.0], vec![1.0], 0).is_err());
        assert!(Servo::new(0.001, vec![1.0], vec![2.0], 0).is_err());
    }

    #[test]
    fn ramp_following_error_matches_final_value_formula() {
        // A unit-gain servo: b scaled so that B(1) = A(1).
        let a = vec![1.0, -1.6, 0.68];
        let a1: f64 = a.iter().sum();
        let b = vec![0.3 * a1, 0.7 * a1];
        let s = Servo::new(0.001, b, a, 1).unwrap();
        assert!((s.dc_gain() - 1.0).abs() < 1e-12);
        let v = 250.0; // mm/s
        let u: Vec<f64> = (0..3000).map(|k| 10.0 + v * 0.001 * k as f64).collect();
        let y = s.simulate(&u);
        let e_sim = u[2999] - y[2999];
        let e = s.following_error(v).unwrap();
        assert!((e_sim - e).abs() < 1e-9, "{e_sim} vs {e}");
    }

    #[test]
    fn bandwidth_of_a_first_order_lag() {
        // y(k) = p·y(k−1) + (1−p)·u(k): |H| = (1−p)/|1 − p e^{−jw}|; the −3 dB
        // point solves |1 − p e^{−jw}|² = 2(1−p)², i.e.
        // cos w = (1 + p² − 2(1−p)²)/(2p).
        let p: f64 = 0.95;
        let ts = 0.001;
        let s = Servo::new(ts, vec![1.0 - p], vec![1.0, -p], 0).unwrap();
        let w = ((1.0 + p * p - 2.0 * (1.0 - p).powi(2)) / (2.0 * p)).acos();
        let f = w / (2.0 * std::f64::consts::PI * ts);
        let bw = s.bandwidth_hz().unwrap();
        assert!((bw - f).abs() < 1e-9 * f, "{bw} vs {f}");
        // A pure gain never drops 3 dB.
        assert!(
            Servo::new(ts, vec![1.0], vec![1.0], 3)
                .unwrap()
                .bandwidth_hz()
                .is_none()
        );
    }

    #[test]
    fn frequency_response_is_the_sinusoidal_steady_state() {
        let s = example();
        let f = 37.0;
        let w = 2.0 * std::f64::consts::PI * f * s.ts();
        let n = 6000;
        let u: Vec<f64> = (0..n).map(|k| (w * k as f64).sin()).collect();
        let y = s.simulate(&u);
        let h = s.frequency_response(f);
        for (k, yk) in y.iter().enumerate().skip(n - 50) {
            let want = h.norm() * (w * k as f64 + h.arg()).sin();
            assert!((yk - want).abs() < 1e-9, "{yk} vs {want}");
        }
    }
}
