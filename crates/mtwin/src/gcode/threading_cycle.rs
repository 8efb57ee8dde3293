//! The passes of LinuxCNC's G76 threading cycle: the moves a G76 block
//! expands to, in the X (depth) and Z (length) of the lathe, computed as
//! LinuxCNC 2.9's interpreter does (its `convert_threading_cycle` and
//! `threading_pass`; the cycle is described in LinuxCNC's G-code
//! documentation, "G76 Threading Cycle").
//!
//! The tool starts at the drive line (the current X and Z). Each pass goes
//! back to the retract X at the pass's start Z (a rapid), in to its depth
//! (a rapid, or a spindle-synchronised taper), along Z to the end of the
//! thread synchronised to the spindle at the pitch (ending with a taper
//! if asked), and out to the retract X (a rapid). The depths grow from
//! `|I| + |J|` by `|J|·n^(1/R)` for pass n until `|I| + |K|`, which is cut
//! H + 1 times (H spring passes; none at all for a negative H, as LinuxCNC
//! counts). With a compound angle Q each pass
//! starts and ends shifted along Z by its depth beyond `|I|` times tan Q.
//! A positive I is an internal thread (depth towards +X), a negative one
//! an external thread.
//!
//! Lengths are mm, the pitch mm per spindle revolution, the angle degrees.

use std::fmt;

/// The words of a G76 block, canonical (mm, degree).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Thread {
    /// P: advance per spindle revolution (the thread's pitch), mm.
    pub pitch: f64,
    /// I: the thread peak's offset from the drive line, mm (positive:
    /// internal thread).
    pub i: f64,
    /// J: depth of the first cut beyond I, mm (> 0).
    pub j: f64,
    /// K: full thread depth beyond I, mm (> J).
    pub k: f64,
    /// Q: compound slide angle, degrees (0 if absent or −1, as LinuxCNC).
    pub compound_deg: f64,
    /// Passes at the full depth: H + 1 (H the spring passes), 0 for H < 0.
    pub full_depth_passes: u32,
    /// R: depth degression (1 if absent or below 1).
    pub degression: f64,
    /// E: length of the entry and exit tapers along Z, mm (0 if absent or
    /// negative).
    pub taper: f64,
    /// L: 1 taper at the entry, 2 at the exit, 3 both (0 if absent or
    /// negative).
    pub taper_flags: u32,
}

/// A move of the cycle in the X Z of the lathe, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum ThreadMove {
    /// A rapid to X, Z.
    Rapid([f64; 2]),
    /// A move to X, Z synchronised to the spindle at `mm_per_rev` per
    /// revolution.
    Sync { to: [f64; 2], mm_per_rev: f64 },
}

/// Why the words cannot make a cycle (LinuxCNC's messages).
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ThreadError {
    /// I is zero.
    IZero,
    /// J ≤ 0.
    JNotPositive,
    /// K ≤ J.
    KNotBeyondJ,
    /// More passes than `max`.
    TooManyPasses { max: u64 },
}

impl fmt::Display for ThreadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ThreadError::IZero => write!(f, "In G76, I must not be 0"),
            ThreadError::JNotPositive => write!(f, "In G76, J must be greater than 0"),
            ThreadError::KNotBeyondJ => write!(f, "In G76, K must be greater than J"),
            ThreadError::TooManyPasses { max } => write!(
                f,
                "G76 of more than {max} passes (J small against K, or a large degression R): a \
                 bound of mtwin on the memory one block may take"
            ),
        }
    }
}

impl Thread {
    /// Checks the words as LinuxCNC does before any move.
    pub(crate) fn check(&self) -> Result<(), ThreadError> {
        if self.i == 0.0 {
            return Err(ThreadError::IZero);
        }
        if self.j <= 0.0 || self.j.is_nan() {
            return Err(ThreadError::JNotPositive);
        }
        if self.k <= self.j || self.k.is_nan() {
            return Err(ThreadError::KNotBeyondJ);
        }
        Ok(())
    }

    /// The number of passes (spring passes included) of the cycle, if at
    /// most `max`.
    pub(crate) fn passes(&self, max: u64) -> Result<u64, ThreadError> {
        let (full, end) = (self.i.abs(), self.i.abs() + self.k.abs());
        let mut depth = full + self.j.abs();
        let mut n: u64 = 0;
        while depth < end {
            n += 1;
            if n > max {
                return Err(ThreadError::TooManyPasses { max });
            }
            depth = full + self.j.abs() * ((n + 1) as f64).powf(1.0 / self.degression);
        }
        let total = n + u64::from(self.full_depth_passes);
        if total > max {
            return Err(ThreadError::TooManyPasses { max });
        }
        Ok(total)
    }

    /// The moves of the cycle from the drive line `start` (X, Z) to the
    /// thread's end `end_z`, without the final rapid to the block's end
    /// point; at most `max_passes` passes.
    pub(crate) fn moves(
        &self,
        start: [f64; 2],
        end_z: f64,
        max_passes: u64,
    ) -> Result<Vec<ThreadMove>, ThreadError> {
        self.check()?;
        let passes = self.passes(max_passes)?;
        let [safe_x, start_z] = start;
        let internal = self.i > 0.0;
        // X at `d` beyond the drive line, towards the thread.
        let x_at = |d: f64| if internal { safe_x + d } else { safe_x - d };
        let full = self.i.abs();
        let first = full + self.j.abs();
        let height = self.k.abs();
        let end_depth = height + full;
        let towards_plus_z = end_z > start_z;
        let mut angle = self.compound_deg.to_radians();
        if towards_plus_z {
            angle = -angle;
        }
        let tan = angle.tan();
        let mut taper = self.taper.max(0.0);
        let taper_pitch = if taper > 0.0 {
            self.pitch * taper.hypot(height) / taper
        } else {
            self.pitch
        };
        if towards_plus_z {
            taper = -taper;
        }
        let entry = taper != 0.0 && self.taper_flags & 1 != 0;
        let exit = taper != 0.0 && self.taper_flags & 2 != 0;
        let target_z = end_z + height * tan;
        let mut out = Vec::with_capacity(6 * passes as usize);
        let pass = |depth: f64, out: &mut Vec<ThreadMove>| {
            let zoff = (depth - full) * tan;
            let retract = x_at(depth - end_depth);
            let sync = |to: [f64; 2], mm_per_rev: f64| ThreadMove::Sync { to, mm_per_rev };
            out.push(ThreadMove::Rapid([retract, start_z - zoff]));
            if entry {
                out.push(sync([x_at(depth - height), start_z - zoff], taper_pitch));
                out.push(sync([x_at(depth), start_z - zoff - taper], taper_pitch));
            } else {
                out.push(ThreadMove::Rapid([x_at(depth), start_z - zoff]));
            }
            if exit {
                out.push(sync([x_at(depth), target_z - zoff + taper], self.pitch));
                out.push(sync([x_at(depth - height), target_z - zoff], taper_pitch));
            } else {
                out.push(sync([x_at(depth), target_z - zoff], self.pitch));
            }
            out.push(ThreadMove::Rapid([retract, target_z - zoff]));
        };
        let mut depth = first;
        let mut n = 1u64;
        while depth < end_depth {
            pass(depth, &mut out);
            n += 1;
            depth = full + self.j.abs() * (n as f64).powf(1.0 / self.degression);
        }
        for _ in 0..self.full_depth_passes {
            pass(end_depth, &mut out);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn thread() -> Thread {
        Thread {
            pitch: 1.5,
            i: -1.0,
            j: 0.4,
            k: 1.0,
            compound_deg: 0.0,
            full_depth_passes: 1,
            degression: 1.0,
            taper: 0.0,
            taper_flags: 0,
        }
    }

    fn close(a: [f64; 2], b: [f64; 2]) -> bool {
        (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12
    }

    fn end(m: &ThreadMove) -> [f64; 2] {
        match *m {
            ThreadMove::Rapid(p) | ThreadMove::Sync { to: p, .. } => p,
        }
    }

    #[test]
    fn external_thread_cuts_at_growing_depths_to_the_full_depth() {
        // Drive line X10 Z5 to Z-20, I-1 (external: cuts towards -X), first
        // cut J0.4 beyond I, full depth K1: depths 1.4, 1.8, then 2
        // (= |I| + K), each pass: back to X 10 + (2 − depth), in, along Z at
        // the pitch, out.
        let m = thread().moves([10.0, 5.0], -20.0, 100).unwrap();
        assert_eq!(m.len(), 3 * 4);
        for (k, depth) in [1.4, 1.8, 2.0].into_iter().enumerate() {
            let p = &m[4 * k..4 * k + 4];
            let back = 10.0 - depth + 2.0;
            assert!(close(end(&p[0]), [back, 5.0]), "{p:?}");
            assert!(matches!(p[1], ThreadMove::Rapid(q) if close(q, [10.0 - depth, 5.0])));
            assert!(matches!(p[2], ThreadMove::Sync { to, mm_per_rev }
                if close(to, [10.0 - depth, -20.0]) && mm_per_rev == 1.5));
            assert!(matches!(p[3], ThreadMove::Rapid(q) if close(q, [back, -20.0])));
        }
    }

    #[test]
    fn internal_thread_goes_towards_plus_x_with_spring_passes() {
        let t = Thread {
            i: 0.5,
            full_depth_passes: 3,
            ..thread()
        };
        let m = t.moves([4.0, 0.0], -10.0, 100).unwrap();
        // Depths 0.9, 1.3 (< 1.5), then 1.5 three times.
        let depths: Vec<f64> = m.chunks(4).map(|p| end(&p[2])[0] - 4.0).collect();
        let want = [0.9, 1.3, 1.5, 1.5, 1.5];
        assert_eq!(depths.len(), want.len());
        for (d, w) in depths.iter().zip(want) {
            assert!((d - w).abs() < 1e-12, "{depths:?}");
        }
        assert_eq!(t.passes(100), Ok(5));
    }

    #[test]
    fn degression_compound_angle_and_tapers() {
        // R2: pass n cuts at |I| + J·√n. Q30 shifts each pass along Z by (depth − |I|)·tan 30°
        // (towards the start, as the thread runs to −Z). E2 L3 tapers
        // both ends: the taper moves at P·√(E² + K²)/E per revolution.
        let t = Thread {
            degression: 2.0,
            compound_deg: 30.0,
            taper: 2.0,
            taper_flags: 3,
            ..thread()
        };
        let m = t.moves([10.0, 5.0], -20.0, 100).unwrap();
        let tan = 30f64.to_radians().tan();
        let taper_pitch = 1.5 * (4.0f64 + 1.0).sqrt() / 2.0;
        // Depths: 1.4, 1 + 0.4·√2, 1 + 0.4·√3, 1 + 0.4·√4 = 1.8, √5 → 1.894,
        // √6 → 1.98, √7 → 2.058 ≥ 2: stop; then 2.
        let mut depths: Vec<f64> = (1..=6).map(|n| 1.0 + 0.4 * f64::from(n).sqrt()).collect();
        depths.push(2.0);
        assert_eq!(m.len(), depths.len() * 6);
        for (p, d) in m.chunks(6).zip(&depths) {
            let zoff = (d - 1.0) * tan;
            let target = -20.0 + tan;
            assert!(close(end(&p[0]), [10.0 - d + 2.0, 5.0 - zoff]));
            assert!(matches!(p[1], ThreadMove::Sync { to, mm_per_rev }
                if close(to, [10.0 - d + 1.0, 5.0 - zoff]) && (mm_per_rev - taper_pitch).abs() < 1e-12));
            assert!(matches!(p[2], ThreadMove::Sync { to, .. }
                if close(to, [10.0 - d, 5.0 - zoff - 2.0])));
            assert!(matches!(p[3], ThreadMove::Sync { to, mm_per_rev }
                if close(to, [10.0 - d, target - zoff + 2.0]) && mm_per_rev == 1.5));
            assert!(matches!(p[4], ThreadMove::Sync { to, .. }
                if close(to, [10.0 - d + 1.0, target - zoff])));
            assert!(close(end(&p[5]), [10.0 - d + 2.0, target - zoff]));
        }
        // Towards +Z the angle and the tapers turn round.
        let m = t.moves([10.0, -20.0], 5.0, 100).unwrap();
        let d = 1.4;
        let zoff = -(d - 1.0) * tan;
        assert!(close(end(&m[0]), [10.6, -20.0 - zoff]));
        assert!(close(end(&m[2]), [10.0 - d, -20.0 - zoff + 2.0]));
    }

    #[test]
    fn bad_words_and_too_many_passes_are_refused() {
        let bad = |t: Thread| t.moves([0.0, 0.0], -1.0, 100).unwrap_err();
        assert_eq!(bad(Thread { i: 0.0, ..thread() }), ThreadError::IZero);
        assert_eq!(
            bad(Thread { j: 0.0, ..thread() }),
            ThreadError::JNotPositive
        );
        assert_eq!(bad(Thread { k: 0.4, ..thread() }), ThreadError::KNotBeyondJ);
        // J 0.001 to K 1: 999 passes before the full depth.
        let fine = Thread {
            j: 0.001,
            ..thread()
        };
        assert_eq!(fine.passes(10_000), Ok(1000));
        assert_eq!(
            bad(fine),
            ThreadError::TooManyPasses { max: 100 },
            "beyond the bound"
        );
        assert!(ThreadError::IZero.to_string().starts_with("In G76"));
    }
}
