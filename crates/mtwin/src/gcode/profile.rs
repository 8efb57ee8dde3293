//! Rest-to-rest trapezoidal motion profile along a normalised path parameter
//! `s ∈ [0, 1]`.

/// A trapezoidal (or triangular) velocity profile taking `s` from 0 to 1,
/// starting and ending at rest. Units: `s` is dimensionless, time in s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trapezoid {
    /// Peak path speed reached, 1/s.
    v: f64,
    /// Path acceleration and deceleration, 1/s² (`f64::INFINITY` for none).
    a: f64,
    /// Duration of the acceleration phase, s.
    t_acc: f64,
    /// Duration of the constant-speed phase, s.
    t_flat: f64,
}

impl Trapezoid {
    /// The fastest rest-to-rest profile over `s ∈ [0, 1]` with path speed at
    /// most `v_max` (1/s, finite and positive) and path acceleration at most
    /// `a_max` (1/s², positive, may be infinite: then the speed steps).
    pub fn new(v_max: f64, a_max: f64) -> Self {
        if a_max.is_infinite() {
            return Trapezoid {
                v: v_max,
                a: a_max,
                t_acc: 0.0,
                t_flat: 1.0 / v_max,
            };
        }
        // Distance covered accelerating to v_max and back: v²/a.
        if v_max * v_max / a_max <= 1.0 {
            Trapezoid {
                v: v_max,
                a: a_max,
                t_acc: v_max / a_max,
                t_flat: 1.0 / v_max - v_max / a_max,
            }
        } else {
            let v = a_max.sqrt();
            Trapezoid {
                v,
                a: a_max,
                t_acc: v / a_max,
                t_flat: 0.0,
            }
        }
    }

    /// Total duration, s.
    pub fn duration(&self) -> f64 {
        2.0 * self.t_acc + self.t_flat
    }

    /// Peak path speed, 1/s.
    pub fn peak_speed(&self) -> f64 {
        self.v
    }

    /// Path parameter at time `t` (s) after the start, clamped to [0, 1].
    pub fn s_at(&self, t: f64) -> f64 {
        let t1 = self.t_acc;
        let t2 = t1 + self.t_flat;
        let total = self.duration();
        let s_acc = if t1 > 0.0 {
            0.5 * self.a * t1 * t1
        } else {
            0.0
        };
        let s = if t <= 0.0 {
            0.0
        } else if t < t1 {
            0.5 * self.a * t * t
        } else if t < t2 {
            s_acc + self.v * (t - t1)
        } else if t < total {
            let r = total - t;
            1.0 - 0.5 * self.a * r * r
        } else {
            1.0
        };
        s.clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_speed_without_acceleration_limit() {
        let p = Trapezoid::new(0.5, f64::INFINITY);
        assert_eq!(p.duration(), 2.0);
        assert!((p.s_at(1.0) - 0.5).abs() < 1e-15);
    }

    #[test]
    fn trapezoid_duration_closed_form() {
        // v = 1, a = 4: T = 1/v + v/a = 1.25 s.
        let p = Trapezoid::new(1.0, 4.0);
        assert!((p.duration() - 1.25).abs() < 1e-15);
        assert!((p.s_at(0.25) - 0.125).abs() < 1e-15); // a t²/2
        assert!((p.s_at(0.625) - 0.5).abs() < 1e-15); // symmetric midpoint
        assert_eq!(p.s_at(2.0), 1.0);
    }

    #[test]
    fn triangle_when_speed_is_not_reached() {
        // v = 10, a = 4: peak √4 = 2, T = 2·√(1/a)·... = 2·v/a = 1 s.
        let p = Trapezoid::new(10.0, 4.0);
        assert!((p.peak_speed() - 2.0).abs() < 1e-15);
        assert!((p.duration() - 1.0).abs() < 1e-15);
        assert!((p.s_at(0.5) - 0.5).abs() < 1e-15);
    }
}
