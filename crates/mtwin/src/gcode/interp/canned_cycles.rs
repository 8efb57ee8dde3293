//! Canned cycles (G73, G74, G81 … G89) expanded into the moves,
//! dwells and spindle commands LinuxCNC's `convert_cycle_*` produce.

use super::*;

impl Interpreter {
    /// A canned cycle (G73, G74, G81 ... G89) in the active plane, as the
    /// straight moves, dwells and spindle commands LinuxCNC's
    /// `convert_cycle_*` produce, repeated L times (in G91 each repeat
    /// moves by the in-plane words). `previous` is the motion mode before
    /// the block: words a cycle remembers may be left out only when it is
    /// the same cycle.
    pub(super) fn canned_cycle(
        &mut self,
        code: GCode,
        previous: Option<MotionMode>,
        w: &BlockWords,
        axes: AxisMask,
        target: [f64; 9],
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let st = &self.state;
        let same = previous == Some(MotionMode::Cycle(code));
        if st.feed <= 0.0 {
            return Err(s.invalid(0, "Cannot feed with zero feed rate"));
        }
        if st.feed_mode == FeedMode::InverseTime {
            return Err(s.invalid(0, "Cannot use inverse time feed with canned cycles"));
        }
        let (p, q, n) = st.plane.axes();
        let plane = match st.plane {
            Plane::Xy => "XY",
            Plane::Zx => "XZ",
            Plane::Yz => "YZ",
        };
        for a in axes.iter() {
            if a.is_rotary() || matches!(a, Axis::U | Axis::V | Axis::W) {
                let col = w.get(a.letter()).map_or(0, |l| l.column);
                return Err(s.invalid(
                    col,
                    format!("Cannot put {a:?} in a canned cycle in the {plane} plane"),
                ));
            }
        }
        let scale = st.units.mm_per_unit();
        let r_word = match w.get(b'R') {
            Some(r) => r.value * scale,
            None if same => self.cycle.r,
            None => {
                return Err(s.invalid(0, "R clearance plane unspecified in canned cycle"));
            }
        };
        let repeats = match w.get(b'L') {
            None => 1,
            Some(l) => {
                let n = nonneg_int(*l, s.line, "L")?;
                if n == 0 {
                    return Err(s.invalid(l.column, "Cannot do zero repeats of canned cycle"));
                }
                if u64::from(n) > crate::limits::MAX_CYCLE_REPEATS {
                    return Err(s.invalid(
                        l.column,
                        format!(
                            "L{n}: at most {} repeats of a canned cycle in one block (a bound of mtwin on the memory one block may take)",
                            crate::limits::MAX_CYCLE_REPEATS
                        ),
                    ));
                }
                n
            }
        };
        if !same && !axes.contains(n) {
            return Err(s.invalid(
                0,
                format!("{n:?} value unspecified in {plane} plane canned cycle"),
            ));
        }
        let bottom_word = if axes.contains(n) {
            target[n.index()]
        } else {
            self.cycle.bottom
        };
        let mut current_cc = st.position[n];
        let mut old_cc = *self.cycle.initial_level.get_or_insert(current_cc);
        let (mut aa, mut bb) = (st.position[p], st.position[q]);
        let (mut da, mut db) = (0.0, 0.0);
        let st_distance = st.distance;
        // Polar words (XY plane only): in G90 the hole's distance and angle
        // from the origin, the missing one from the current point (no
        // error at the origin, unlike a single move); in G91 added to the
        // distance and angle of each repeat's hole.
        let distance_word = w.get(b'@').map(|l| l.value * scale);
        let angle_word = w.get(b'^').map(|l| l.value);
        let (r, cc) = match st.distance {
            DistanceMode::Absolute => {
                if axes.contains(p) {
                    aa = target[p.index()];
                }
                if axes.contains(q) {
                    bb = target[q.index()];
                }
                if distance_word.is_some() || angle_word.is_some() {
                    let radius = distance_word.unwrap_or(aa.hypot(bb));
                    let theta = angle_word.map_or(bb.atan2(aa), f64::to_radians);
                    (aa, bb) = (radius * theta.cos(), radius * theta.sin());
                }
                (r_word, bottom_word)
            }
            DistanceMode::Incremental => {
                if axes.contains(p) {
                    da = target[p.index()];
                }
                if axes.contains(q) {
                    db = target[q.index()];
                }
                let r = r_word + old_cc;
                (r, r + bottom_word)
            }
        };
        if r < cc {
            return Err(s.invalid(0, format!("R less than {n:?} in cycle in {plane} plane")));
        }
        // Cycle words, checked before any move.
        let dwell = |this: &Self| -> Result<f64, GcodeError> {
            match w.get(b'P') {
                Some(pw) => Ok(pw.value),
                None if same || matches!(code, GCode::G74 | GCode::G84) => Ok(this.cycle.p),
                None => Err(s.invalid(0, format!("Dwell time P word missing with {code}"))),
            }
        };
        let mut params = self.cycle;
        match code {
            GCode::G82 | GCode::G86 | GCode::G88 | GCode::G89 | GCode::G74 | GCode::G84 => {
                params.p = dwell(self)?;
            }
            GCode::G73 | GCode::G83 => {
                params.q = match w.get(b'Q') {
                    Some(qw) => qw.value * scale,
                    None if same => self.cycle.q,
                    None => return Err(s.invalid(0, format!("Q word missing with {code}"))),
                };
                if params.q <= 0.0 {
                    return Err(s.invalid(0, "Negative or zero Q value used"));
                }
            }
            GCode::G87 => {
                for (k, l) in [b'I', b'J', b'K'].into_iter().enumerate() {
                    match w.get(l) {
                        Some(x) => params.ijk[k] = x.value * scale,
                        None if same => {}
                        None => {
                            return Err(
                                s.invalid(0, format!("{} word missing with G87", l as char))
                            );
                        }
                    }
                }
            }
            _ => {}
        }
        let spindle = self.state.spindle;
        match (code, spindle) {
            (
                GCode::G84 | GCode::G74 | GCode::G86 | GCode::G87 | GCode::G88,
                SpindleState::Stopped,
            ) => {
                return Err(s.invalid(0, format!("Spindle not turning in {code}")));
            }
            (GCode::G84, SpindleState::CounterClockwise) => {
                return Err(s.invalid(0, "Spindle turning counterclockwise in G84"));
            }
            (GCode::G74, SpindleState::Clockwise) => {
                return Err(s.invalid(0, "Spindle turning clockwise in G74"));
            }
            _ => {}
        }
        let words = self.programmed(axes, true);
        let at = |this: &Self, a: f64, b: f64, c: f64| {
            let mut to = this.state.position;
            to[p] = a;
            to[q] = b;
            to[n] = c;
            to
        };
        // Below the R level: straight up to it first.
        if old_cc < r {
            let to = at(self, self.state.position[p], self.state.position[q], r);
            self.push_straight(true, to, words, s)?;
            old_cc = r;
            current_cc = old_cc;
        }
        let clear = match self.state.retract {
            RetractMode::RLevel => r,
            RetractMode::InitialLevel => old_cc,
        };
        if matches!(code, GCode::G73 | GCode::G83) {
            // Pecks of one hole times the repeats: bounded before any move
            // is made, as the repeats are (huge R or tiny Q would otherwise
            // expand one block without end).
            let pecks = ((r - cc) / params.q).ceil() * f64::from(repeats);
            if pecks.is_nan() || pecks > crate::limits::MAX_CYCLE_PECKS as f64 {
                let column = w.get(b'Q').map_or(0, |q| q.column);
                return Err(s.invalid(
                    column,
                    format!(
                        "{code} from R {r} to {cc} by Q {} ({repeats} repeats): more than {} pecks in one block (a bound of mtwin on the memory one block may take)",
                        params.q,
                        crate::limits::MAX_CYCLE_PECKS
                    ),
                ));
            }
        }
        for repeat in (1..=repeats).rev() {
            aa += da;
            bb += db;
            if st_distance == DistanceMode::Incremental {
                for (d, turn) in [(distance_word, 0.0), (None, angle_word.unwrap_or(0.0))] {
                    let d = d.unwrap_or(0.0);
                    if d == 0.0 && turn == 0.0 {
                        continue;
                    }
                    if aa == 0.0 && bb == 0.0 {
                        return Err(s.invalid(
                            0,
                            "Incremental motion with polar coordinates is indeterminate when at the origin",
                        ));
                    }
                    let radius = aa.hypot(bb) + d;
                    let theta = bb.atan2(aa) + turn.to_radians();
                    (aa, bb) = (radius * theta.cos(), radius * theta.sin());
                }
            }
            if repeat == repeats && current_cc > r {
                self.push_straight(true, at(self, aa, bb, current_cc), words, s)?;
                self.push_straight(true, at(self, aa, bb, r), words, s)?;
            } else {
                self.push_straight(true, at(self, aa, bb, clear), words, s)?;
                if clear > r {
                    self.push_straight(true, at(self, aa, bb, r), words, s)?;
                }
            }
            self.cycle_body(code, &params, [aa, bb], r, clear, cc, words, s)?;
        }
        let mut end = self.state.position;
        end[p] = aa;
        end[q] = bb;
        end[n] = clear;
        self.state.position = end;
        self.cycle = CycleMemory {
            r: r_word,
            bottom: bottom_word,
            initial_level: self.cycle.initial_level,
            ..params
        };
        Ok(())
    }

    /// The moves of one repeat of a canned cycle at (`a`, `b`) in the plane,
    /// from the R level `r` to the bottom `bottom` and back to `clear`.
    #[allow(clippy::too_many_arguments)]
    fn cycle_body(
        &mut self,
        code: GCode,
        params: &CycleMemory,
        [a, b]: [f64; 2],
        r: f64,
        clear: f64,
        bottom: f64,
        words: Programmed,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let (p, q, n) = self.state.plane.axes();
        let at = |this: &Self, x: f64, y: f64, z: f64| {
            let mut to = this.state.position;
            to[p] = x;
            to[q] = y;
            to[n] = z;
            to
        };
        let feed = |this: &mut Self, z: f64, s: &mut Step| {
            let to = at(this, a, b, z);
            this.push_straight(false, to, words, s)
        };
        let rapid = |this: &mut Self, z: f64, s: &mut Step| {
            let to = at(this, a, b, z);
            this.push_straight(true, to, words, s)
        };
        let spindle = |this: &mut Self, dir: SpindleState, s: &mut Step| {
            this.state.spindle = dir;
            s.emit(EventKind::Spindle(dir));
        };
        let dir = self.state.spindle;
        // G73/G83 back off 0.010 inch (0.254 mm) above the last depth.
        const RAPID_DELTA: f64 = 0.254;
        match code {
            GCode::G81 => {
                feed(self, bottom, s)?;
                rapid(self, clear, s)?;
            }
            GCode::G82 => {
                feed(self, bottom, s)?;
                s.emit(EventKind::Dwell { seconds: params.p });
                rapid(self, clear, s)?;
            }
            GCode::G73 | GCode::G83 => {
                let mut depth = r - params.q;
                while depth > bottom {
                    feed(self, depth, s)?;
                    if code == GCode::G83 {
                        rapid(self, r, s)?;
                    }
                    rapid(self, depth + RAPID_DELTA, s)?;
                    let next = depth - params.q;
                    if next >= depth {
                        // Q below the resolution of the depth's number.
                        return Err(s.invalid(
                            0,
                            format!("Q {} too small to move from depth {depth}", params.q),
                        ));
                    }
                    depth = next;
                }
                feed(self, bottom, s)?;
                rapid(self, clear, s)?;
            }
            GCode::G74 | GCode::G84 => {
                let (reverse, forward) = if code == GCode::G84 {
                    (SpindleState::CounterClockwise, SpindleState::Clockwise)
                } else {
                    (SpindleState::Clockwise, SpindleState::CounterClockwise)
                };
                // LinuxCNC 2.9 (and later) passes the tapping feeds' end
                // points to its plane mapping in another order than the
                // other cycles: in G18 and G19 the two feeds go along
                // another axis than the cycle's. Reproduced as it runs.
                let tap = |this: &mut Self, z: f64, s: &mut Step| {
                    let mut to = this.state.position;
                    match this.state.plane {
                        Plane::Xy => (to[p], to[q], to[n]) = (a, b, z),
                        Plane::Yz => (to[n], to[p], to[q]) = (b, z, a),
                        Plane::Zx => (to[q], to[n], to[p]) = (z, a, b),
                    }
                    this.push_straight(false, to, words, s)
                };
                tap(self, bottom, s)?;
                spindle(self, SpindleState::Stopped, s);
                spindle(self, reverse, s);
                s.emit(EventKind::Dwell { seconds: params.p });
                tap(self, clear, s)?;
                spindle(self, SpindleState::Stopped, s);
                spindle(self, forward, s);
            }
            GCode::G85 => {
                feed(self, bottom, s)?;
                feed(self, r, s)?;
                rapid(self, clear, s)?;
            }
            GCode::G86 => {
                feed(self, bottom, s)?;
                s.emit(EventKind::Dwell { seconds: params.p });
                spindle(self, SpindleState::Stopped, s);
                rapid(self, clear, s)?;
                spindle(self, dir, s);
            }
            GCode::G87 => {
                let [i, j, k] = params.ijk;
                let middle = match self.state.distance {
                    DistanceMode::Incremental => bottom + k,
                    DistanceMode::Absolute => k,
                };
                let (oa, ob) = (a + i, b + j);
                let to = at(self, oa, ob, r);
                self.push_straight(true, to, words, s)?;
                spindle(self, SpindleState::Stopped, s);
                let to = at(self, oa, ob, bottom);
                self.push_straight(true, to, words, s)?;
                rapid(self, bottom, s)?;
                spindle(self, dir, s);
                feed(self, middle, s)?;
                feed(self, bottom, s)?;
                spindle(self, SpindleState::Stopped, s);
                let to = at(self, oa, ob, bottom);
                self.push_straight(true, to, words, s)?;
                let to = at(self, oa, ob, clear);
                self.push_straight(true, to, words, s)?;
                rapid(self, clear, s)?;
                spindle(self, dir, s);
            }
            GCode::G88 => {
                // The operator retracts by hand after the program stop.
                feed(self, bottom, s)?;
                s.emit(EventKind::Dwell { seconds: params.p });
                spindle(self, SpindleState::Stopped, s);
                spindle(self, dir, s);
            }
            GCode::G89 => {
                feed(self, bottom, s)?;
                s.emit(EventKind::Dwell { seconds: params.p });
                feed(self, clear, s)?;
            }
            _ => return Err(s.invalid(0, format!("{code} is not a canned cycle"))),
        }
        Ok(())
    }
}
