//! The forward-kinematics kernel: `L` poses evaluated together in lanes (structure of
//! arrays, `[f64; L]` per quantity), written so that the compiler turns every lane loop into
//! SIMD instructions. `L = 1` is the single-pose path; [`LANES`] is the batch width. Every
//! lane computes exactly the same floating-point operations as the one-lane path, so a batch
//! gives bit-for-bit the poses of single calls.
//!
//! Nothing is linearised: rotary angles use [`sin_cos_deg`] (exact reduction in
//! degrees, then Taylor series to double precision), error angles the small-angle series of
//! [`super::transform::sin_cos`] (exact to double precision below 0.01 rad, `f64::sin_cos`
//! above).

use nalgebra::{Matrix3, Vector3};

use super::chain::{AxisKin, CompiledPdge, Kinematics, ToolPose};
use super::transform::{sin_cos, small_angle_sin_cos};
use crate::model::AxisKind;

/// Poses per batch step: eight `f64` lanes (two AVX registers, four SSE2 registers).
pub const LANES: usize = 8;

/// `1.5·2⁵²`: adding it rounds a double of magnitude < 2⁵¹ to the nearest integer, which
/// then sits in the low bits of the sum's mantissa (two's complement modulo 2⁵²).
const ROUND_MAGIC: f64 = 6_755_399_441_055_744.0;

/// Degrees at or beyond which [`sin_cos_deg`] hands over to `f64::sin_cos`.
const DEG_LIMIT: f64 = 1.0e12;

/// `(sin, cos)` of an angle in **degrees**, to double precision, without branches (so it
/// vectorises).
///
/// The angle is reduced to `r = d − 90·n ∈ [−45°, 45°]` exactly (the subtraction of an
/// integer multiple of 90 from a double of magnitude < 10¹² is exact), converted to radians
/// once, and sine and cosine are summed as Taylor series to the x¹⁷ and x¹⁶ terms, whose
/// remainders are below 1e-19; the quadrant `n mod 4` then swaps and signs them. Exact
/// quarter turns give exact 0 and ±1. For |d| ≥ 10¹² (or non-finite) it falls back to
/// `f64::sin_cos(d.to_radians())`.
#[inline(always)]
pub fn sin_cos_deg(d: f64) -> (f64, f64) {
    let (s, c) = sin_cos_deg_reduced(d);
    if d.abs() < DEG_LIMIT {
        (s, c)
    } else {
        sin_cos_deg_far(d)
    }
}

/// `f64::sin_cos` of `d` degrees: the rare fallback of [`sin_cos_deg`] for |d| ≥ 10¹² or
/// non-finite `d`. Kept out of line so that the compiler does not evaluate it
/// speculatively on every call (the standard sine and cosine are pure and may be hoisted).
#[cold]
#[inline(never)]
fn sin_cos_deg_far(d: f64) -> (f64, f64) {
    d.to_radians().sin_cos()
}

/// The branch-free body of [`sin_cos_deg`], valid for |d| < 10¹².
#[inline(always)]
fn sin_cos_deg_reduced(d: f64) -> (f64, f64) {
    let shifted = d * (1.0 / 90.0) + ROUND_MAGIC;
    let bits = shifted.to_bits();
    let n = shifted - ROUND_MAGIC;
    let r = d - 90.0 * n;
    let x = r * (std::f64::consts::PI / 180.0);
    let x2 = x * x;
    let s = x + x
        * x2
        * (-1.0 / 6.0
            + x2 * (1.0 / 120.0
                + x2 * (-1.0 / 5040.0
                    + x2 * (1.0 / 362_880.0
                        + x2 * (-1.0 / 39_916_800.0
                            + x2 * (1.0 / 6_227_020_800.0
                                + x2 * (-1.0 / 1_307_674_368_000.0
                                    + x2 * (1.0 / 355_687_428_096_000.0))))))));
    let c = 1.0
        + x2 * (-0.5
            + x2 * (1.0 / 24.0
                + x2 * (-1.0 / 720.0
                    + x2 * (1.0 / 40_320.0
                        + x2 * (-1.0 / 3_628_800.0
                            + x2 * (1.0 / 479_001_600.0
                                + x2 * (-1.0 / 87_178_291_200.0
                                    + x2 * (1.0 / 20_922_789_888_000.0))))))));
    // Quadrant n mod 4: odd swaps sine and cosine; sin < 0 in quadrants 2, 3; cos < 0 in 1, 2.
    let swap = 0u64.wrapping_sub(bits & 1);
    let (sb, cb) = (s.to_bits(), c.to_bits());
    let s_out = (cb & swap) | (sb & !swap);
    let c_out = (sb & swap) | (cb & !swap);
    let sign_s = (bits & 2) << 62;
    let sign_c = (bits.wrapping_add(1) & 2) << 62;
    (
        f64::from_bits(s_out ^ sign_s),
        f64::from_bits(c_out ^ sign_c),
    )
}

type V<const L: usize> = [f64; L];
type V3<const L: usize> = [V<L>; 3];
/// A 3×3 matrix per lane, row-major.
type M3<const L: usize> = [V<L>; 9];

#[inline(always)]
fn splat<const L: usize>(x: f64) -> V<L> {
    [x; L]
}

/// `x ← m·x`.
#[inline(always)]
fn mul<const L: usize>(m: &M3<L>, x: &mut V3<L>) {
    for l in 0..L {
        let (a, b, c) = (x[0][l], x[1][l], x[2][l]);
        x[0][l] = m[0][l] * a + m[1][l] * b + m[2][l] * c;
        x[1][l] = m[3][l] * a + m[4][l] * b + m[5][l] * c;
        x[2][l] = m[6][l] * a + m[7][l] * b + m[8][l] * c;
    }
}

/// `x ← mᵀ·x`.
#[inline(always)]
fn tr_mul<const L: usize>(m: &M3<L>, x: &mut V3<L>) {
    for l in 0..L {
        let (a, b, c) = (x[0][l], x[1][l], x[2][l]);
        x[0][l] = m[0][l] * a + m[3][l] * b + m[6][l] * c;
        x[1][l] = m[1][l] * a + m[4][l] * b + m[7][l] * c;
        x[2][l] = m[2][l] * a + m[5][l] * b + m[8][l] * c;
    }
}

/// `x ← m·x` for a matrix common to all lanes.
#[inline(always)]
fn mul_const<const L: usize>(m: &Matrix3<f64>, x: &mut V3<L>) {
    for l in 0..L {
        let (a, b, c) = (x[0][l], x[1][l], x[2][l]);
        for r in 0..3 {
            x[r][l] = m[(r, 0)] * a + m[(r, 1)] * b + m[(r, 2)] * c;
        }
    }
}

/// `x ← mᵀ·x` for a matrix common to all lanes.
#[inline(always)]
fn tr_mul_const<const L: usize>(m: &Matrix3<f64>, x: &mut V3<L>) {
    for l in 0..L {
        let (a, b, c) = (x[0][l], x[1][l], x[2][l]);
        for r in 0..3 {
            x[r][l] = m[(0, r)] * a + m[(1, r)] * b + m[(2, r)] * c;
        }
    }
}

/// [`sin_cos`] in every lane: the Taylor branch vectorised when every lane takes it.
#[inline(always)]
fn small_sin_cos<const L: usize>(x: &V<L>) -> (V<L>, V<L>) {
    let mut s = [0.0; L];
    let mut c = [0.0; L];
    if x.iter().all(|v| v.abs() < 1e-2) {
        for l in 0..L {
            (s[l], c[l]) = small_angle_sin_cos(x[l]);
        }
    } else {
        for l in 0..L {
            (s[l], c[l]) = sin_cos(x[l]);
        }
    }
    (s, c)
}

/// `Rx(a)·Ry(b)·Rz(c)` per lane, the same products as [`super::transform::rxyz`].
#[inline(always)]
fn rxyz_lanes<const L: usize>(a: &V<L>, b: &V<L>, c: &V<L>) -> M3<L> {
    let (sa, ca) = small_sin_cos(a);
    let (sb, cb) = small_sin_cos(b);
    let (sc, cc) = small_sin_cos(c);
    let mut m = [[0.0; L]; 9];
    for l in 0..L {
        m[0][l] = cb[l] * cc[l];
        m[1][l] = -cb[l] * sc[l];
        m[2][l] = sb[l];
        m[3][l] = sa[l] * sb[l] * cc[l] + ca[l] * sc[l];
        m[4][l] = -sa[l] * sb[l] * sc[l] + ca[l] * cc[l];
        m[5][l] = -sa[l] * cb[l];
        m[6][l] = -ca[l] * sb[l] * cc[l] + sa[l] * sc[l];
        m[7][l] = ca[l] * sb[l] * sc[l] + sa[l] * cc[l];
        m[8][l] = ca[l] * cb[l];
    }
    m
}

impl AxisKin {
    /// The six PDGE values per lane.
    #[inline(always)]
    fn pdge_lanes<const L: usize>(&self, q: &V<L>) -> [V<L>; 6] {
        let mut e = [[0.0; L]; 6];
        match &self.compiled {
            CompiledPdge::None => {}
            CompiledPdge::Fast {
                degree,
                scale,
                offset,
                coeff,
            } => {
                let mut u = [[0.0; L]; 6];
                for c in 0..6 {
                    for l in 0..L {
                        u[c][l] = scale[c] * q[l] + offset[c];
                    }
                    e[c] = splat(coeff[*degree][c]);
                }
                for k in (0..*degree).rev() {
                    for c in 0..6 {
                        for l in 0..L {
                            e[c][l] = e[c][l] * u[c][l] + coeff[k][c];
                        }
                    }
                }
            }
            CompiledPdge::General => {
                for l in 0..L {
                    let v = self.pdge_values(q[l]);
                    for c in 0..6 {
                        e[c][l] = v[c];
                    }
                }
            }
        }
        e
    }

    /// `L_i·J_i(q)` rotation of a rotary axis per lane: `cos·M₀ + sin·M₁ + M₂`.
    #[inline(always)]
    fn rotary_lanes<const L: usize>(&self, q: &V<L>) -> M3<L> {
        let mut s = [0.0; L];
        let mut c = [0.0; L];
        for l in 0..L {
            (s[l], c[l]) = sin_cos_deg_reduced(q[l]);
        }
        for l in 0..L {
            if q[l].abs() >= DEG_LIMIT || q[l].is_nan() {
                (s[l], c[l]) = sin_cos_deg_far(q[l]);
            }
        }
        let [m0, m1, m2] = &self.rot_terms;
        let mut m = [[0.0; L]; 9];
        for r in 0..3 {
            for k in 0..3 {
                let (a, b, d) = (m0[(r, k)], m1[(r, k)], m2[(r, k)]);
                for l in 0..L {
                    m[3 * r + k][l] = c[l] * a + s[l] * b + d;
                }
            }
        }
        m
    }

    /// Apply `A_i(q)` to the point `p` and vector `v` in every lane.
    #[inline(always)]
    fn apply_lanes<const L: usize>(&self, q: &V<L>, p: &mut V3<L>, v: &mut V3<L>) {
        if self.has_pdge {
            let e = self.pdge_lanes(q);
            if self.pdge_rotates {
                let r = rxyz_lanes(&e[3], &e[4], &e[5]);
                mul(&r, p);
                mul(&r, v);
            }
            for k in 0..3 {
                for l in 0..L {
                    p[k][l] += e[k][l];
                }
            }
        }
        match self.kind {
            AxisKind::Linear => {
                for k in 0..3 {
                    for l in 0..L {
                        p[k][l] += self.dir[k] * q[l];
                    }
                }
                if self.has_loc_rotation {
                    mul_const(&self.pl.r, p);
                    mul_const(&self.pl.r, v);
                }
            }
            AxisKind::Rotary => {
                let r = self.rotary_lanes(q);
                mul(&r, p);
                mul(&r, v);
            }
        }
        for k in 0..3 {
            for l in 0..L {
                p[k][l] += self.pl.t[k];
            }
        }
    }

    /// Apply `A_i(q)⁻¹` to the point `p` and vector `v` in every lane.
    #[inline(always)]
    pub(super) fn apply_inv_lanes<const L: usize>(&self, q: &V<L>, p: &mut V3<L>, v: &mut V3<L>) {
        for k in 0..3 {
            for l in 0..L {
                p[k][l] -= self.pl.t[k];
            }
        }
        match self.kind {
            AxisKind::Linear => {
                if self.has_loc_rotation {
                    tr_mul_const(&self.pl.r, p);
                    tr_mul_const(&self.pl.r, v);
                }
                for k in 0..3 {
                    for l in 0..L {
                        p[k][l] -= self.dir[k] * q[l];
                    }
                }
            }
            AxisKind::Rotary => {
                let r = self.rotary_lanes(q);
                tr_mul(&r, p);
                tr_mul(&r, v);
            }
        }
        if self.has_pdge {
            let e = self.pdge_lanes(q);
            for k in 0..3 {
                for l in 0..L {
                    p[k][l] -= e[k][l];
                }
            }
            if self.pdge_rotates {
                let r = rxyz_lanes(&e[3], &e[4], &e[5]);
                tr_mul(&r, p);
                tr_mul(&r, v);
            }
        }
    }
}

impl Kinematics {
    /// `L` poses; `q(i)` gives axis `i`'s position in every lane.
    #[inline(always)]
    pub(crate) fn pose_lanes<const L: usize>(&self, q: impl Fn(usize) -> V<L>) -> (V3<L>, V3<L>) {
        let mut p: V3<L> = [
            splat(self.tool_point.x),
            splat(self.tool_point.y),
            splat(self.tool_point.z),
        ];
        let mut v: V3<L> = [
            splat(self.tool_dir.x),
            splat(self.tool_dir.y),
            splat(self.tool_dir.z),
        ];
        for &i in self.tool_chain.iter().rev() {
            self.axes[i].apply_lanes(&q(i), &mut p, &mut v);
        }
        for &i in &self.work_chain {
            self.axes[i].apply_inv_lanes(&q(i), &mut p, &mut v);
        }
        for k in 0..3 {
            for l in 0..L {
                p[k][l] -= self.work_point[k];
            }
        }
        (p, v)
    }

    /// The poses of `qs` (`n_axes` values per pose, row after row) into `out`, on the
    /// calling thread, [`LANES`] poses at a time. Each result is bit-for-bit
    /// [`Kinematics::pose`] of its row.
    ///
    /// # Panics
    /// If `out.len() · n_axes ≠ qs.len()`.
    pub fn poses_into(&self, qs: &[f64], out: &mut [ToolPose]) {
        let n = self.axes.len();
        if n == 0 {
            out.fill(self.pose(&[]));
            return;
        }
        assert_eq!(
            qs.len(),
            out.len() * n,
            "poses_into: {} positions for {} poses of {n} axes",
            qs.len(),
            out.len()
        );
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above. (A safe `#[target_feature]`
            // function is still `unsafe` to call from code compiled without the feature.)
            unsafe { self.poses_into_avx2(qs, out) };
            return;
        }
        self.poses_into_lanes(qs, out);
    }

    /// [`Kinematics::poses_into_lanes`] compiled for AVX2: the same operations (no fused
    /// multiply–add, so the same roundings) on 256-bit registers. Callers without AVX2
    /// enabled at compile time must check the CPU first (`is_x86_feature_detected!`).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn poses_into_avx2(&self, qs: &[f64], out: &mut [ToolPose]) {
        self.poses_into_lanes(qs, out);
    }

    /// The body of [`Kinematics::poses_into`]: [`LANES`] poses at a time, the rest one by
    /// one. `n_axes ≥ 1` and the lengths are checked by the caller.
    #[inline(always)]
    fn poses_into_lanes(&self, qs: &[f64], out: &mut [ToolPose]) {
        let n = self.axes.len();
        let mut rows = qs.chunks_exact(n * LANES);
        let mut outs = out.chunks_exact_mut(LANES);
        for (rows, out) in (&mut rows).zip(&mut outs) {
            let (p, v) = self.pose_lanes::<LANES>(|i| std::array::from_fn(|l| rows[l * n + i]));
            for (l, o) in out.iter_mut().enumerate() {
                *o = ToolPose {
                    tip: Vector3::new(p[0][l], p[1][l], p[2][l]),
                    axis: Vector3::new(v[0][l], v[1][l], v[2][l]),
                };
            }
        }
        for (q, o) in rows.remainder().chunks_exact(n).zip(outs.into_remainder()) {
            *o = self.pose_lanes_one(q);
        }
    }

    /// One pose through the lane kernel (inlined into the caller's target features).
    #[inline(always)]
    fn pose_lanes_one(&self, q: &[f64]) -> ToolPose {
        let (p, v) = self.pose_lanes::<1>(|i| [q[i]]);
        ToolPose {
            tip: Vector3::new(p[0][0], p[1][0], p[2][0]),
            axis: Vector3::new(v[0][0], v[1][0], v[2][0]),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// sin and cos of `d` degrees by reducing to the nearest quarter turn and calling the
    /// standard library on the remainder in radians (an independent route).
    fn reference(d: f64) -> (f64, f64) {
        let n = (d / 90.0).round();
        let (s, c) = ((d - 90.0 * n) * std::f64::consts::PI / 180.0).sin_cos();
        match (n as i64).rem_euclid(4) {
            0 => (s, c),
            1 => (c, -s),
            2 => (-s, -c),
            _ => (-c, s),
        }
    }

    #[test]
    fn sin_cos_in_degrees_is_exact_to_double_precision() {
        let mut worst: f64 = 0.0;
        for i in -200_000..=200_000 {
            let d = i as f64 * 0.0183 + 1e-7;
            let (s, c) = sin_cos_deg(d);
            let (rs, rc) = reference(d);
            worst = worst.max((s - rs).abs()).max((c - rc).abs());
            // And against f64::sin_cos of to_radians (whose own rounding of d·π/180 is
            // ≈ 1e-16·|d| rad).
            let (fs, fc) = d.to_radians().sin_cos();
            let tol = 4.0 * f64::EPSILON * (1.0 + d.abs() / 90.0);
            assert!((s - fs).abs() < tol && (c - fc).abs() < tol, "d = {d}");
            assert!((s * s + c * c - 1.0).abs() < 4.0 * f64::EPSILON);
        }
        assert!(worst <= 2.0 * f64::EPSILON, "worst {worst}");
        // Exact quarter turns.
        for (d, s, c) in [
            (0.0f64, 0.0f64, 1.0f64),
            (90.0, 1.0, 0.0),
            (180.0, 0.0, -1.0),
            (-90.0, -1.0, 0.0),
            (270.0, -1.0, 0.0),
            (36000.0, 0.0, 1.0),
        ] {
            let (a, b) = sin_cos_deg(d);
            assert_eq!((a, b), (s, c), "{d}");
        }
        // Far outside the reduction range and non-finite inputs.
        let (s, c) = sin_cos_deg(3e14);
        assert_eq!((s, c), 3e14f64.to_radians().sin_cos());
        assert!(sin_cos_deg(f64::NAN).0.is_nan());
    }

    /// The portable kernel (the one a CPU without AVX2 runs), called explicitly: every pose
    /// of a batch is bit-for-bit the single-pose [`Kinematics::pose`] and agrees with the
    /// independent full-transform route `T_MW⁻¹·T_MT` to 1e-12 mm per metre of reach, for
    /// batch lengths below, at and beyond the lane count and not a multiple of it.
    #[test]
    fn portable_lane_kernel_equals_the_single_pose() {
        use crate::kinematics::tests::{fast_path_machines, poses};
        let zero = ToolPose {
            tip: Vector3::zeros(),
            axis: Vector3::zeros(),
        };
        for (name, m) in fast_path_machines() {
            let k = Kinematics::new(&m);
            for count in [0, 1, LANES - 1, LANES, 3 * LANES + 5] {
                let ps = poses(&m, count, 31 + count as u64);
                let flat: Vec<f64> = ps.iter().flatten().copied().collect();
                let mut out = vec![zero; count];
                k.poses_into_lanes(&flat, &mut out);
                for (q, got) in ps.iter().zip(&out) {
                    assert_eq!(*got, k.pose(q), "{name}, {count} poses, q = {q:?}");
                    let t = k.tool_in_workpiece(q);
                    let tol = 1e-12 * (1.0 + t.t.norm() / 1000.0);
                    assert!((t.t - got.tip).norm() < tol, "{name} {q:?}");
                    assert!((t.r * m.tool_direction - got.axis).norm() < 1e-14, "{name}");
                }
                // The AVX2 build of the same kernel gives the same bits.
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx2") {
                    let mut wide = vec![zero; count];
                    // SAFETY: the CPU has AVX2, checked just above.
                    unsafe { k.poses_into_avx2(&flat, &mut wide) };
                    assert_eq!(wide, out, "{name}, {count} poses");
                }
            }
        }
    }
}
