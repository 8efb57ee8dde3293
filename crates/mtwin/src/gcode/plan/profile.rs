//! Trapezoidal speed profile along a path of length `L` between given entry
//! and exit speeds: accelerate at `a`, cruise at `v_max`, decelerate at `a`.

/// A speed profile over `s ∈ [0, L]`: speed `v0` at the start, `v1` at the
/// end, at most `v_max` in between, acceleration and deceleration `a`.
/// Units: those of `L` (mm, deg, or 1 for a normalised path) and s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Profile {
    len: f64,
    v0: f64,
    v1: f64,
    /// Cruise (or peak) speed.
    vp: f64,
    a: f64,
    t_acc: f64,
    t_flat: f64,
    t_dec: f64,
}

impl Profile {
    /// The fastest profile over `len` (> 0) from `v0` to `v1` within `v_max`
    /// (> 0) and `a` (> 0, may be infinite: constant speed `v_max`, and the
    /// end speeds are taken as `v_max`). The end speeds are clamped to what
    /// `v_max` and `a` allow (`v1 ≤ √(v0² + 2 a L)`, `v0 ≤ √(v1² + 2 a L)`).
    pub fn new(len: f64, v0: f64, v1: f64, v_max: f64, a: f64) -> Self {
        if a.is_infinite() {
            return Profile {
                len,
                v0: v_max,
                v1: v_max,
                vp: v_max,
                a,
                t_acc: 0.0,
                t_flat: len / v_max,
                t_dec: 0.0,
            };
        }
        let v0 = v0.clamp(0.0, v_max);
        let v1 = v1.clamp(0.0, v_max).min((v0 * v0 + 2.0 * a * len).sqrt());
        let v0 = v0.min((v1 * v1 + 2.0 * a * len).sqrt());
        // Peak of the triangle: vp² − v0² + vp² − v1² = 2 a L.
        let peak = ((2.0 * a * len + v0 * v0 + v1 * v1) / 2.0).sqrt();
        let vp = peak.min(v_max).max(v0).max(v1);
        let t_acc = (vp - v0) / a;
        let t_dec = (vp - v1) / a;
        let d_acc = (vp * vp - v0 * v0) / (2.0 * a);
        let d_dec = (vp * vp - v1 * v1) / (2.0 * a);
        let flat = (len - d_acc - d_dec).max(0.0);
        Profile {
            len,
            v0,
            v1,
            vp,
            a,
            t_acc,
            t_flat: if vp > 0.0 { flat / vp } else { 0.0 },
            t_dec,
        }
    }

    /// Duration, s.
    pub fn duration(&self) -> f64 {
        self.t_acc + self.t_flat + self.t_dec
    }

    /// Path length.
    pub fn len(&self) -> f64 {
        self.len
    }

    /// Speed at the start and at the end.
    pub fn end_speeds(&self) -> (f64, f64) {
        (self.v0, self.v1)
    }

    /// Speed at which the final deceleration starts (the cruise or peak speed).
    pub fn peak(&self) -> f64 {
        self.vp
    }

    /// Acceleration (infinite for a constant-speed profile).
    pub fn accel(&self) -> f64 {
        self.a
    }

    /// Distance along the path at `t` s after the start, in `[0, L]`.
    pub fn s_at(&self, t: f64) -> f64 {
        let (t1, t2, total) = (self.t_acc, self.t_acc + self.t_flat, self.duration());
        let s = if t <= 0.0 {
            0.0
        } else if t >= total {
            self.len
        } else if self.a.is_infinite() {
            self.vp * t
        } else if t < t1 {
            self.v0 * t + 0.5 * self.a * t * t
        } else if t < t2 {
            let d_acc = self.v0 * t1 + 0.5 * self.a * t1 * t1;
            d_acc + self.vp * (t - t1)
        } else {
            let r = total - t;
            self.len - (self.v1 * r + 0.5 * self.a * r * r)
        };
        s.clamp(0.0, self.len)
    }

    /// Speed at `t` s after the start.
    pub fn v_at(&self, t: f64) -> f64 {
        let total = self.duration();
        if self.a.is_infinite() {
            return if (0.0..total).contains(&t) {
                self.vp
            } else {
                0.0
            };
        }
        if t <= 0.0 {
            self.v0
        } else if t < self.t_acc {
            self.v0 + self.a * t
        } else if t < self.t_acc + self.t_flat {
            self.vp
        } else if t < total {
            self.v1 + self.a * (total - t)
        } else {
            self.v1
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rest_to_rest_matches_the_closed_form() {
        // L = 100, v = 50, a = 200: T = L/v + v/a = 2.25 s.
        let p = Profile::new(100.0, 0.0, 0.0, 50.0, 200.0);
        assert!((p.duration() - 2.25).abs() < 1e-12);
        assert!((p.s_at(0.125) - 0.5 * 200.0 * 0.125 * 0.125).abs() < 1e-12);
        assert_eq!(p.s_at(3.0), 100.0);
        // Triangle: L = 1, a = 4, v large: peak 2, T = 1.
        let p = Profile::new(1.0, 0.0, 0.0, 10.0, 4.0);
        assert!((p.duration() - 1.0).abs() < 1e-12);
        assert!((p.peak() - 2.0).abs() < 1e-12);
    }

    #[test]
    fn end_speeds_are_kept_and_clamped() {
        // Cruise through at v: T = L / v.
        let p = Profile::new(10.0, 5.0, 5.0, 5.0, 1.0);
        assert!((p.duration() - 2.0).abs() < 1e-12);
        // From 0, exit speed not reachable: clamped to √(2aL) = √20.
        let p = Profile::new(10.0, 0.0, 100.0, 100.0, 1.0);
        assert!((p.end_speeds().1 - 20f64.sqrt()).abs() < 1e-12);
        assert!((p.duration() - 20f64.sqrt()).abs() < 1e-12);
        // Speed is continuous at the phase changes.
        let p = Profile::new(10.0, 1.0, 2.0, 3.0, 1.5);
        let h = 1e-7;
        for t in [p.t_acc, p.t_acc + p.t_flat] {
            let v = (p.s_at(t + h) - p.s_at(t - h)) / (2.0 * h);
            assert!((v - p.v_at(t)).abs() < 1e-5, "{v} {}", p.v_at(t));
        }
    }
}
