//! Arc geometry: centre from IJK offsets or R (with LinuxCNC's radius
//! tolerances), swept angle, length and extreme points.

use std::f64::consts::{FRAC_PI_2, TAU};

use super::axes::Axes;
use super::event::{ArcMove, Units};

/// Why an arc cannot be built (sentences as LinuxCNC words them).
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ArcError {
    ZeroRadius,
    SamePointR,
    RadiusTooSmall,
    RadiusMismatch { r1: f64, r2: f64 },
}

impl std::fmt::Display for ArcError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ArcError::ZeroRadius => write!(f, "Zero-radius arc"),
            ArcError::SamePointR => write!(f, "Current point same as end point of arc"),
            ArcError::RadiusTooSmall => write!(f, "Arc radius too small to reach end point"),
            ArcError::RadiusMismatch { r1, r2 } => write!(
                f,
                "Radius to end of arc differs from radius to start: r1={r1:.4} mm r2={r2:.4} mm"
            ),
        }
    }
}

/// Absolute radius tolerance of centre-format arcs, mm: 2·√2·0.001 in for
/// inch programs, 2·√2·0.01 mm for metric ones (LinuxCNC).
fn center_abs_tolerance(units: Units) -> f64 {
    match units {
        Units::Inch => 2.0 * 0.001 * Units::Inch.mm_per_unit() * std::f64::consts::SQRT_2,
        Units::Millimetre => 2.0 * 0.01 * std::f64::consts::SQRT_2,
    }
}

/// Relative radius tolerance of centre-format arcs (0.1 %).
const CENTER_REL_TOLERANCE: f64 = 0.001;

/// Tolerance of R-format arcs and zero radius, mm (LinuxCNC's TOLERANCE_INCH
/// 0.0005 in and TOLERANCE_MM 0.005 mm).
fn tolerance(units: Units) -> f64 {
    match units {
        Units::Inch => 0.0005 * Units::Inch.mm_per_unit(),
        Units::Millimetre => 0.005,
    }
}

/// Centre of a centre-format arc from start `s`, end `e` and centre `c`
/// (plane coordinates, mm): checks LinuxCNC's radius tolerances.
pub(crate) fn check_center(
    s: [f64; 2],
    e: [f64; 2],
    c: [f64; 2],
    units: Units,
) -> Result<(), ArcError> {
    let r1 = (s[0] - c[0]).hypot(s[1] - c[1]);
    let r2 = (e[0] - c[0]).hypot(e[1] - c[1]);
    if r1 < tolerance(units) {
        return Err(ArcError::ZeroRadius);
    }
    let abs_err = (r1 - r2).abs();
    let rel_err = abs_err / r1.max(r2);
    let t = center_abs_tolerance(units);
    if abs_err > 100.0 * t || (abs_err > t && rel_err > CENTER_REL_TOLERANCE) {
        return Err(ArcError::RadiusMismatch { r1, r2 });
    }
    Ok(())
}

/// Centre of an R-format arc (LinuxCNC's `arc_data_r`): `ccw` for G3,
/// negative `r` for the longer of the two arcs.
pub(crate) fn center_from_radius(
    s: [f64; 2],
    e: [f64; 2],
    r: f64,
    ccw: bool,
    units: Units,
) -> Result<[f64; 2], ArcError> {
    if s == e {
        return Err(ArcError::SamePointR);
    }
    let abs_r = r.abs();
    let mid = [(s[0] + e[0]) / 2.0, (s[1] + e[1]) / 2.0];
    let mut half = (mid[0] - e[0]).hypot(mid[1] - e[1]);
    if half - abs_r > tolerance(units) {
        return Err(ArcError::RadiusTooSmall);
    }
    if half / abs_r > 1.0 - 1e-12 {
        half = abs_r;
    }
    let chord = (e[1] - s[1]).atan2(e[0] - s[0]);
    let theta = if (!ccw && r > 0.0) || (ccw && r < 0.0) {
        chord - FRAC_PI_2
    } else {
        chord + FRAC_PI_2
    };
    let offset = abs_r * (half / abs_r).asin().cos();
    Ok([mid[0] + offset * theta.cos(), mid[1] + offset * theta.sin()])
}

/// Derived geometry of an arc move.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Geometry {
    /// In-plane centre.
    pub center: [f64; 2],
    /// Start angle, rad.
    pub start_angle: f64,
    /// Signed sweep, rad (positive counter-clockwise about the normal).
    pub sweep: f64,
    /// In-plane radius at the start, mm.
    pub radius: f64,
    /// In-plane radius at the end, mm.
    pub end_radius: f64,
    /// Travel along the normal, mm.
    pub rise: f64,
}

impl Geometry {
    /// Length of the XYZ path: the in-plane spiral length (mean radius ×
    /// |sweep|) combined with the rise.
    pub fn xyz_length(&self) -> f64 {
        let r = 0.5 * (self.radius + self.end_radius);
        (r * self.sweep).hypot(self.rise)
    }
}

/// Signed sweep from angle `a0` to `a1` for `turns` (LinuxCNC: an end equal
/// to the start is a full circle).
pub(crate) fn sweep(a0: f64, a1: f64, turns: i32) -> f64 {
    let extra = f64::from(turns.unsigned_abs().saturating_sub(1)) * TAU;
    let mut d = a1 - a0;
    if turns > 0 {
        while d <= 1e-12 {
            d += TAU;
        }
        while d > TAU + 1e-12 {
            d -= TAU;
        }
        d + extra
    } else {
        while d >= -1e-12 {
            d -= TAU;
        }
        while d < -TAU - 1e-12 {
            d += TAU;
        }
        d - extra
    }
}

pub(crate) fn geometry(arc: &ArcMove) -> Geometry {
    let (p, q, n) = arc.plane.axes();
    let c = [arc.center[p.index()], arc.center[q.index()]];
    let (s, e) = (plane_point(&arc.from, p, q), plane_point(&arc.to, p, q));
    let a0 = (s[1] - c[1]).atan2(s[0] - c[0]);
    let a1 = (e[1] - c[1]).atan2(e[0] - c[0]);
    Geometry {
        center: c,
        start_angle: a0,
        sweep: sweep(a0, a1, arc.turns),
        radius: (s[0] - c[0]).hypot(s[1] - c[1]),
        end_radius: (e[0] - c[0]).hypot(e[1] - c[1]),
        rise: arc.to[n] - arc.from[n],
    }
}

/// The point of `arc` at `s ∈ [0, 1]` of its sweep ([`geometry`] `g`): in
/// the plane on the spiral from the start radius to the end radius, the
/// other axes linear in `s`; exactly `arc.to` at `s ≥ 1`. The one place the
/// interpolator and the travel check of statistics take arc points from.
pub(crate) fn point_at(arc: &ArcMove, g: &Geometry, s: f64) -> Axes {
    if s >= 1.0 {
        return arc.to;
    }
    let (p, q, _) = arc.plane.axes();
    let mut x = super::timing::lerp(&arc.from, &arc.to, s);
    let ang = g.start_angle + g.sweep * s;
    let r = g.radius + (g.end_radius - g.radius) * s;
    x[p] = g.center[0] + r * ang.cos();
    x[q] = g.center[1] + r * ang.sin();
    x
}

fn plane_point(a: &Axes, p: super::axes::Axis, q: super::axes::Axis) -> [f64; 2] {
    [a[p], a[q]]
}

/// In-plane points of the arc: start, every quadrant crossing (where a
/// plane coordinate has an extreme; radius interpolated along the sweep),
/// end. Each plane coordinate is monotone between consecutive points.
pub(crate) fn plane_points(arc: &ArcMove) -> Vec<[f64; 2]> {
    let g = geometry(arc);
    let (p, q, _) = arc.plane.axes();
    let mut pts = vec![[arc.from[p], arc.from[q]]];
    let dir = g.sweep.signum();
    // First multiple of pi/2 strictly beyond the start in the sweep direction.
    let mut k = if dir > 0.0 {
        (g.start_angle / FRAC_PI_2).floor() + 1.0
    } else {
        (g.start_angle / FRAC_PI_2).ceil() - 1.0
    };
    loop {
        let ang = k * FRAC_PI_2;
        let t = (ang - g.start_angle) / g.sweep;
        if !(t > 0.0 && t < 1.0) {
            break;
        }
        let r = g.radius + t * (g.end_radius - g.radius);
        pts.push([g.center[0] + r * ang.cos(), g.center[1] + r * ang.sin()]);
        k += dir;
    }
    pts.push([arc.to[p], arc.to[q]]);
    pts
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn r_format_centre_is_equidistant_and_on_the_requested_side() {
        // Quarter circle of radius 10 from (10,0) to (0,10): centre (0,0) for
        // G3 R10, centre (10,10) for G2 R10.
        let c =
            center_from_radius([10.0, 0.0], [0.0, 10.0], 10.0, true, Units::Millimetre).unwrap();
        assert!((c[0]).abs() < 1e-12 && c[1].abs() < 1e-12, "{c:?}");
        let c =
            center_from_radius([10.0, 0.0], [0.0, 10.0], 10.0, false, Units::Millimetre).unwrap();
        assert!(
            (c[0] - 10.0).abs() < 1e-12 && (c[1] - 10.0).abs() < 1e-12,
            "{c:?}"
        );
        // Negative R: the long way, so the centre flips side.
        let c =
            center_from_radius([10.0, 0.0], [0.0, 10.0], -10.0, true, Units::Millimetre).unwrap();
        assert!(
            (c[0] - 10.0).abs() < 1e-12 && (c[1] - 10.0).abs() < 1e-12,
            "{c:?}"
        );
        assert_eq!(
            center_from_radius([0.0, 0.0], [30.0, 0.0], 10.0, true, Units::Millimetre),
            Err(ArcError::RadiusTooSmall)
        );
    }

    #[test]
    fn sweep_directions_and_full_circles() {
        assert!((sweep(0.0, FRAC_PI_2, 1) - FRAC_PI_2).abs() < 1e-15);
        assert!((sweep(0.0, FRAC_PI_2, -1) + 3.0 * FRAC_PI_2).abs() < 1e-15);
        assert!((sweep(1.0, 1.0, 1) - TAU).abs() < 1e-15);
        assert!((sweep(1.0, 1.0, -2) + 2.0 * TAU).abs() < 1e-15);
        assert!((sweep(PI - 0.1, -PI + 0.1, 1) - 0.2).abs() < 1e-12);
    }

    #[test]
    fn radius_tolerance_regions_of_the_linuxcnc_readme() {
        // Metric: t_abs = 0.028284 mm. Small arc: 0.02 mm off passes, 0.04 fails.
        let u = Units::Millimetre;
        assert!(check_center([0.0, 0.0], [2.0 * 5.0 + 0.02, 0.0], [5.0, 0.0], u).is_ok());
        assert!(check_center([0.0, 0.0], [2.0 * 5.0 + 0.04, 0.0], [5.0, 0.0], u).is_err());
        // Medium (r = 1000 mm): relative 0.1 % rules: 0.9 mm passes, 1.1 fails.
        assert!(check_center([0.0, 0.0], [2000.9, 0.0], [1000.0, 0.0], u).is_ok());
        assert!(check_center([0.0, 0.0], [2001.1, 0.0], [1000.0, 0.0], u).is_err());
        // Big (r = 5000 mm): 100·t_abs = 2.83 mm rules although 0.1 % is 5 mm.
        assert!(check_center([0.0, 0.0], [10002.5, 0.0], [5000.0, 0.0], u).is_ok());
        assert!(check_center([0.0, 0.0], [10003.0, 0.0], [5000.0, 0.0], u).is_err());
    }
}
