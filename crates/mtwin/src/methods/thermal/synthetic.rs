//! A synthetic "truth" machine for tests and demonstrations: the drift mixes a
//! fast response (spindle housing, the same at every height) and a slow one
//! (lead screw and column, growing with height), each a continuous-time
//! first-order lag of the heat input, sampled exactly.

use rand::{SeedableRng, rngs::StdRng};
use rand_distr::{Distribution, Normal};

/// Continuous-time two-time-constant drift model (04's description of the
/// machine of the source paper \[R4\]):
///
/// ```text
/// τ_f·ẋ_f = h(n) − x_f,   τ_s·ẋ_s = h(n) − x_s,   h(n) = (n/1000)^p   (n in rev/min)
/// e(t, z) = g_f·x_f(t) + g_s·w(z)·x_s(t),  w(z) = 0.3 + 0.7·s²,  s = (z − z_lo)/(z_hi − z_lo)
/// ```
///
/// The speed is constant over each sample period, so the sampled response is
/// exact: `x(k+1) = φ·x(k) + (1 − φ)·h(n(k))`, `φ = exp(−T/τ)`.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthMachine {
    /// Sample period T, min.
    pub period_min: f64,
    /// Fast time constant, min.
    pub fast_tau_min: f64,
    /// Slow time constant, min.
    pub slow_tau_min: f64,
    /// Settled fast drift per unit heat input (`h = 1` at 1000 rev/min), mm.
    pub fast_gain_mm: f64,
    /// Settled slow drift per unit heat input at the top height, mm.
    pub slow_gain_mm: f64,
    /// Exponent `p` of the heat input `(n/1000)^p` (1: linear in speed).
    pub speed_exponent: f64,
    /// Lowest and highest height of the working range, mm.
    pub z_range: (f64, f64),
}

impl TruthMachine {
    /// A vertical machining centre like that of the source paper \[R4\]: 10 min sampling, fast
    /// 25 min and slow 150 min time constants, about −40 µm of drift at the
    /// top after hours at 8000 rev/min, heights −400…0 mm.
    pub fn demo() -> TruthMachine {
        TruthMachine {
            period_min: 10.0,
            fast_tau_min: 25.0,
            slow_tau_min: 150.0,
            fast_gain_mm: -0.0022,
            slow_gain_mm: -0.003,
            speed_exponent: 1.0,
            z_range: (-400.0, 0.0),
        }
    }

    /// Weight of the slow response at height `z_mm`.
    pub fn slow_weight(&self, z_mm: f64) -> f64 {
        let (lo, hi) = self.z_range;
        let s = (z_mm - lo) / (hi - lo);
        0.3 + 0.7 * s * s
    }

    /// Drift (mm) at `t = kT`, `k = 0..speeds.len()`, for a run from cold with
    /// `speeds[k]` (rev/min) held over `[kT, (k+1)T)`.
    pub fn drift(&self, speeds: &[f64], z_mm: f64) -> Vec<f64> {
        let pf = (-self.period_min / self.fast_tau_min).exp();
        let ps = (-self.period_min / self.slow_tau_min).exp();
        let w = self.slow_weight(z_mm);
        let (mut xf, mut xs) = (0.0, 0.0);
        speeds
            .iter()
            .map(|&n| {
                let e = self.fast_gain_mm * xf + self.slow_gain_mm * w * xs;
                let h = (n.abs() / 1000.0).powf(self.speed_exponent);
                xf = pf * xf + (1.0 - pf) * h;
                xs = ps * xs + (1.0 - ps) * h;
                e
            })
            .collect()
    }

    /// `TRAIN.csv` text for `runs` (label, speeds per sample) measured at
    /// `heights`, with white probing noise `noise_mm` drawn from `seed`.
    pub fn training_csv(
        &self,
        runs: &[(&str, Vec<f64>)],
        heights: &[f64],
        noise_mm: f64,
        seed: u64,
    ) -> String {
        let noise =
            Normal::new(0.0, noise_mm.max(0.0)).expect("a finite non-negative standard deviation");
        let mut rng = StdRng::seed_from_u64(seed);
        use crate::io::columns::{DRIFT_MM, SPEED_RPM, T_MIN, Z_MM};
        let mut s = format!("run,{T_MIN},{SPEED_RPM},{Z_MM},{DRIFT_MM}\n");
        for (label, speeds) in runs {
            let drifts: Vec<Vec<f64>> = heights.iter().map(|&z| self.drift(speeds, z)).collect();
            for (k, n) in speeds.iter().enumerate() {
                for (z, d) in heights.iter().zip(&drifts) {
                    let e = d[k] + noise.sample(&mut rng);
                    s.push_str(&format!(
                        "{label},{},{n},{z},{e}\n",
                        k as f64 * self.period_min
                    ));
                }
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_speed_follows_the_continuous_solution() {
        let m = TruthMachine::demo();
        let n = 4000.0;
        let e = m.drift(&[n; 40], -50.0);
        assert_eq!(e[0], 0.0);
        for (k, ek) in e.iter().enumerate() {
            let t = k as f64 * 10.0;
            let want = 4.0
                * (m.fast_gain_mm * (1.0 - (-t / 25.0).exp())
                    + m.slow_gain_mm * m.slow_weight(-50.0) * (1.0 - (-t / 150.0).exp()));
            assert!((ek - want).abs() < 1e-15, "{ek} vs {want}");
        }
        assert!(
            (m.slow_weight(0.0) - 1.0).abs() < 1e-15 && (m.slow_weight(-400.0) - 0.3).abs() < 1e-15
        );
    }
}
