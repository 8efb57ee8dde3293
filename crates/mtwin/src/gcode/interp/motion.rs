//! The motion step: G53, straight moves, arcs, probes, spindle-synchronised
//! moves and the G76 threading cycle, with the work offsets applied; and
//! the last step, the stops (M0, M1, M2, M30, M60).

use super::*;

impl Interpreter {
    /// G53 (non-modal): needs axis words and a straight motion mode.
    #[inline]
    pub(super) fn check_g53(
        &self,
        w: &BlockWords,
        codes: &Codes,
        s: &Step,
    ) -> Result<(), GcodeError> {
        let Some(col) = codes.g53() else {
            return Ok(());
        };
        if self.axis_words(w, codes).0.is_empty() {
            return Err(s.invalid(col, "G53 without axis words"));
        }
        let mode = self.motion_to_be(codes);
        if !matches!(mode, Some(MotionMode::Rapid | MotionMode::Linear)) {
            return Err(s.invalid(col, "G53 needs G0 or G1"));
        }
        Ok(())
    }

    /// Sets the total offset from the work, G92 and tool offsets in force,
    /// keeping the machine position.
    #[inline]
    pub(super) fn apply_offsets(&mut self) {
        let machine = self.to_machine(&self.state.position);
        let st = &mut self.state;
        st.rotation = st.work_rotations[usize::from(st.work_system - 1)];
        let mut g92 = st.axis_offset;
        rotate_xy(&mut g92, st.rotation);
        let offset = st.work_offsets[usize::from(st.work_system - 1)]
            .add(&g92)
            .add(&st.tool_offset);
        st.offset = offset;
        self.state.position = self.to_work(&machine);
    }

    /// Machine coordinates of a work position (identity kinematics).
    #[inline]
    pub(super) fn to_machine(&self, p: &Axes) -> Axes {
        let mut m = *p;
        rotate_xy(&mut m, self.state.rotation);
        m.add(&self.state.offset)
    }

    /// Work coordinates of a machine position (identity kinematics).
    #[inline]
    pub(super) fn to_work(&self, m: &Axes) -> Axes {
        let mut p = m.sub(&self.state.offset);
        rotate_xy(&mut p, -self.state.rotation);
        p
    }

    /// A work position as the events give it: X Y rotated by the rotation
    /// in force, so that machine = event position + offset.
    #[inline]
    pub(super) fn event_point(&self, p: &Axes) -> Axes {
        let mut q = *p;
        rotate_xy(&mut q, self.state.rotation);
        q
    }

    /// Refuses what this interpreter does not run in a rotated system.
    #[inline]
    pub(super) fn check_rotation(&self, s: &Step) -> Result<(), GcodeError> {
        if self.state.rotation != 0.0 && self.state.tcp {
            return Err(GcodeError::unsupported(
                s.line,
                0,
                "coordinate system rotation (G10 L2 R) with tool centre point control",
            ));
        }
        Ok(())
    }

    /// The axis words of a block in canonical units (mm, degree).
    #[inline]
    pub(super) fn axis_words(&self, w: &BlockWords, codes: &Codes) -> (AxisMask, [f64; 9]) {
        let dialect = self.opts.dialect;
        let dwell = codes.has(GCode::G4);
        let mut axes = AxisMask::EMPTY;
        let mut target = [0.0; 9];
        for axis in Axis::ALL {
            if let Some(a) = w.get(axis.letter()) {
                if dwell && dialect != Dialect::LinuxCnc && matches!(axis, Axis::X | Axis::U) {
                    continue; // Fanuc G4 X or U: the dwell time.
                }
                axes.insert(axis);
                let v = dialect.dimension(
                    a.value,
                    a.has_point,
                    self.state.units == Units::Inch,
                    axis.is_rotary(),
                );
                target[axis.index()] = if axis.is_rotary() {
                    v
                } else {
                    v * self.state.units.mm_per_unit()
                };
            }
        }
        (axes, target)
    }

    /// Group 1: sets the motion mode (G80 clears it) and moves to the axis
    /// words.
    pub(super) fn motion(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let previous = self.state.motion;
        match codes.motion {
            Some((GCode::G80, _)) => self.state.motion = None,
            Some((code, _)) => self.state.motion = Some(motion_mode(code)),
            None => {}
        }
        if codes.motion.is_some_and(|(c, _)| !c.is_cycle()) {
            // Any other motion code ends a series of cycles.
            self.cycle.initial_level = None;
        }
        let (axes, target) = self.axis_words(w, codes);
        let g53 = codes.g53();
        if codes.motion.is_none() && self.axes_consumed(codes) {
            return Ok(());
        }
        let polar = w.polar();
        if axes.is_empty() && !polar && codes.explicit_motion().is_none() {
            return Ok(());
        }
        if let Some((code, col)) = codes.motion
            && code.is_probe()
        {
            self.refuse_with_comp(s, col, "Cannot probe with cutter radius comp on")?;
        }
        match self.state.motion {
            None if !axes.is_empty() || polar => {
                Err(s.invalid(0, "axis words without a motion mode (G0, G1, G2 or G3)"))
            }
            None => Ok(()),
            Some(MotionMode::Cycle(code)) => {
                if self.comp.is_on() {
                    self.state.motion = previous;
                    return Err(
                        s.invalid(0, "Cannot use canned cycles with cutter compensation on")
                    );
                }
                let r = self.canned_cycle(code, previous, w, axes, target, s);
                if r.is_err() {
                    self.state.motion = previous;
                }
                r
            }
            Some(mode) => {
                self.cycle.initial_level = None;
                // LinuxCNC's straight probes (G38.2–G38.5), not the Fanuc G31.
                let probe = codes
                    .motion
                    .filter(|&(c, _)| c.is_probe() && c != GCode::G31);
                self.move_to(mode, w, axes, target, g53, probe, s)
            }
        }
    }

    /// One move of `mode` to the axis words. With cutter radius
    /// compensation on, the words are read from the programmed position
    /// and the move is made by [`CutterComp`]. `probe`: the block's
    /// G38.2–G38.5 and the column of its word. As LinuxCNC 2.9's
    /// `convert_probe`, a probe is refused under G95 and a G38.2 or G38.4
    /// (the kinds that fail without contact) whose end is its start on
    /// every axis ("Start point too close to probe point"); after it
    /// #5061–#5070 read [`Self::set_probe_result`].
    #[allow(clippy::too_many_arguments)]
    fn move_to(
        &mut self,
        mode: MotionMode,
        w: &BlockWords,
        axes: AxisMask,
        target: [f64; 9],
        g53: Option<usize>,
        probe: Option<(GCode, usize)>,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let line = s.line;
        let st = &self.state;
        let from = st.position;
        let base = self.comp.base(&from);
        let mut to = base;
        if let Some(col) = g53 {
            if !matches!(mode, MotionMode::Rapid | MotionMode::Linear) {
                return Err(s.invalid(col, "G53 needs G0 or G1"));
            }
            if st.distance == DistanceMode::Incremental {
                return Err(s.invalid(col, "G53 is not allowed with G91"));
            }
        }
        if g53.is_some() && st.rotation != 0.0 {
            // G53 in a rotated system: the named axes go to the machine
            // position, the others keep theirs; X Y back to the rotated frame.
            let mut m = self.to_machine(&from);
            for axis in axes.iter() {
                m[axis] = target[axis.index()];
            }
            to = self.to_work(&m);
        }
        for axis in axes.iter() {
            let v = target[axis.index()];
            to[axis] = if g53.is_some() && st.rotation != 0.0 {
                to[axis]
            } else if g53.is_some() {
                v - st.offset[axis]
            } else if st.distance == DistanceMode::Incremental {
                base[axis] + v
            } else if self.opts.wrapped_rotary.contains(axis) {
                unwrap_rotary(v, from[axis]).map_err(|m| {
                    GcodeError::invalid(line, w.get(axis.letter()).map_or(0, |l| l.column), m)
                })?
            } else {
                v
            };
        }
        let polar = w.polar();
        if polar {
            let (x, y) = self.polar_end(w, [base[Axis::X], base[Axis::Y]], s)?;
            to[Axis::X] = x;
            to[Axis::Y] = y;
        }
        if let Some((code, col)) = probe {
            if st.feed_mode == FeedMode::UnitsPerRevolution {
                return Err(s.invalid(col, "Cannot probe with feed per rev mode"));
            }
            if matches!(code, GCode::G38_2 | GCode::G38_4) && to.0 == from.0 {
                return Err(s.invalid(col, "Start point too close to probe point"));
            }
        }
        let words = Programmed {
            axes,
            g53: g53.is_some(),
            distance: st.distance,
            units: st.units,
            // No X or Y word ends a polar move: none can be rewritten.
            expanded: polar,
            x_diameter: st.lathe_diameter,
        };
        // The column an error of a compensated move names: its first axis
        // word (or polar word).
        let column = axes
            .iter()
            .next()
            .and_then(|a| w.get(a.letter()))
            .or_else(|| w.get(b'@'))
            .or_else(|| w.get(b'^'))
            .map_or(0, |l| l.column);
        let kind = match mode {
            MotionMode::Rapid | MotionMode::Linear => {
                self.comp.straight_move_started();
                let rapid = mode == MotionMode::Rapid;
                let comp = self.comp.engaged();
                if !comp && axes.is_empty() && !polar {
                    return Ok(());
                }
                let feed = if rapid {
                    Feed::Rapid
                } else {
                    // A move of rotary axes only: F is deg/min (or deg/rev)
                    // whatever the length units.
                    let d = to.sub(&base);
                    let rotary_only =
                        d.xyz_norm() == 0.0 && d.uvw_norm() == 0.0 && d.abc_norm() > 0.0;
                    match self.feed(w, line)? {
                        Feed::PerMinute(_) if rotary_only => Feed::PerMinute(self.feed_as_written),
                        Feed::PerRevolution { rpm, .. } if rotary_only => Feed::PerRevolution {
                            mm_per_rev: self.feed_as_written,
                            rpm,
                        },
                        f => f,
                    }
                };
                self.check_rotation(s)?;
                if comp {
                    if let Some(col) = g53 {
                        return Err(s.invalid(col, "Cannot use g53 with cutter radius comp"));
                    }
                    let units = self.state.units;
                    let feed = match feed {
                        Feed::InverseTime(f) => {
                            let (length, rotary) = cutter_comp::straight_length(&base, &to, units);
                            cutter_comp::inverse_time_feed(f, length, rotary, units)
                        }
                        f => f,
                    };
                    let info = self.move_info(s.at, column, words, feed);
                    return self
                        .comp
                        .straight(rapid, to, &info, &mut self.state.position, s.out);
                }
                let start = self.comp.physical_start(&from);
                let st = &self.state;
                let lin = Linear {
                    from: self.event_point(&start),
                    to: self.event_point(&to),
                    offset: st.offset,
                    feed,
                    tcp: self.state.tcp,
                    words,
                };
                if rapid {
                    EventKind::Traverse(lin)
                } else {
                    EventKind::Feed(lin)
                }
            }
            MotionMode::Cycle(code) => {
                return Err(s.invalid(0, format!("{code} is not a single move")));
            }
            MotionMode::SpindleSync | MotionMode::RigidTap => {
                return self.spindle_sync(mode, w, axes, to, words, s);
            }
            MotionMode::Threading => return self.threading_cycle(w, axes, to, words, s),
            MotionMode::ArcClockwise | MotionMode::ArcCounterClockwise => {
                if self.comp.arc_not_allowed() {
                    return Err(s.invalid(
                        0,
                        "The move just after exiting cutter compensation mode must be straight, not an arc",
                    ));
                }
                // No axis words: with I, J or K a full circle about the
                // current point (as LinuxCNC 2.9 runs it), else an error.
                let ijk = [b'I', b'J', b'K'].iter().any(|&l| w.get(l).is_some());
                if axes.is_empty() && !polar && (w.get(b'R').is_some() || !ijk) {
                    return Err(s.invalid(0, "All axes missing with motion code"));
                }
                let feed = self.feed(w, line)?;
                let ccw = mode == MotionMode::ArcCounterClockwise;
                let comp = self.comp.engaged();
                let plane = self.state.plane;
                let (p, q, n) = plane.axes();
                if comp && self.comp.first_move() {
                    let scale = self.state.units.mm_per_unit();
                    let r_word = w.get(b'R').map(|r| r.value * scale);
                    let info = self.move_info(s.at, column, words, feed);
                    self.comp.check_arc_entry(
                        [base[p], base[q]],
                        [to[p], to[q]],
                        ccw,
                        r_word,
                        &info,
                    )?;
                }
                let (mut center, turns) = self.arc_center(w, &base, &to, ccw, line)?;
                if comp {
                    let center = [center[p.index()], center[q.index()]];
                    let units = self.state.units;
                    let feed = match feed {
                        Feed::InverseTime(f) => {
                            let length = cutter_comp::arc_length(
                                [base[p], base[q]],
                                center,
                                turns,
                                [to[p], to[q]],
                                to[n] - base[n],
                            );
                            cutter_comp::inverse_time_feed(f, length, false, units)
                        }
                        f => f,
                    };
                    let info = self.move_info(s.at, column, words, feed);
                    return self.comp.arc(
                        turns,
                        center,
                        to,
                        &info,
                        &mut self.state.position,
                        s.out,
                    );
                }
                self.check_rotation(s)?;
                let start = self.comp.physical_start(&from);
                let st = &self.state;
                if st.rotation != 0.0 {
                    if st.plane != Plane::Xy {
                        return Err(GcodeError::unsupported(
                            line,
                            0,
                            "coordinate system rotation (G10 L2 R) with an arc outside the XY plane",
                        ));
                    }
                    let (sn, cs) = st.rotation.to_radians().sin_cos();
                    let [x, y, _] = center;
                    center[0] = x * cs - y * sn;
                    center[1] = x * sn + y * cs;
                }
                EventKind::Arc(ArcMove {
                    from: self.event_point(&start),
                    to: self.event_point(&to),
                    center,
                    plane: st.plane,
                    turns,
                    offset: st.offset,
                    feed,
                    tcp: st.tcp,
                    words,
                })
            }
        };
        self.state.position = to;
        s.emit(kind);
        if probe.is_some() {
            self.set_probe_result(&to);
        }
        Ok(())
    }

    /// The result of a straight probe G38.2–G38.5, as mtwin assumes it: the
    /// part is not modelled, so the probe runs to its end point without
    /// contact (as LinuxCNC's standalone interpreter `rs274` reports it).
    /// #5061–#5069 read that end (X Y Z U V W in program units, A B C in
    /// degrees, within [0, 360) on a wrapped rotary axis; the point in the
    /// coordinate system the probe ran in) and #5070 reads 0 (not tripped).
    #[inline]
    fn set_probe_result(&mut self, end: &Axes) {
        let per_unit = 1.0 / self.state.units.mm_per_unit();
        for (j, a) in Axis::ALL.into_iter().enumerate() {
            let v = if a.is_rotary() && self.opts.wrapped_rotary.contains(a) {
                end[a].rem_euclid(360.0)
            } else if a.is_rotary() {
                end[a]
            } else {
                end[a] * per_unit
            };
            self.params.set_state(5061 + j as u32, v);
        }
        self.params.set_state(5070, 0.0);
    }

    /// G33 (a straight move at K per spindle revolution) and G33.1 (rigid
    /// tapping: to the end at K per revolution, the spindle reversed, and
    /// back to the start at I times the speed, I ≥ 1, default 1), as
    /// LinuxCNC 2.9 runs them: the spindle must turn (M3 or M4); after
    /// G33.1 the position is the start again. Refused as unsupported: a
    /// zero spindle speed or K ≤ 0 (no time for the move), cutter radius
    /// compensation on (LinuxCNC feeds such a move unsynchronised or
    /// fails), and rotary or UVW words on G33.1 (LinuxCNC taps along X Y Z
    /// and sets the other axes without moving them). Both kinds of move
    /// are marked `expanded`: a rewriter must not split or re-code them.
    fn spindle_sync(
        &mut self,
        mode: MotionMode,
        w: &BlockWords,
        axes: AxisMask,
        to: Axes,
        mut words: Programmed,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let tap = mode == MotionMode::RigidTap;
        let name = if tap { "G33.1" } else { "G33" };
        self.comp.straight_move_started();
        if self.comp.engaged() {
            return Err(GcodeError::unsupported(
                s.line,
                0,
                format!("{name} with cutter radius compensation on"),
            ));
        }
        let st = &self.state;
        if st.spindle == SpindleState::Stopped {
            return Err(s.invalid(0, format!("Spindle not turning in {name}")));
        }
        let k = w.get(b'K').map_or(0.0, |k| k.value) * st.units.mm_per_unit();
        if !(k > 0.0 && k.is_finite()) {
            return Err(GcodeError::unsupported(
                s.line,
                w.get(b'K').map_or(0, |k| k.column),
                format!("{name} with K ≤ 0 (no advance per spindle revolution to time the move)"),
            ));
        }
        let rpm = st.spindle_rpm;
        if !(rpm > 0.0 && rpm.is_finite()) {
            return Err(GcodeError::unsupported(
                s.line,
                0,
                format!("{name} with the spindle speed at 0 (no S): the move cannot be timed"),
            ));
        }
        if tap
            && let Some(a) = axes
                .iter()
                .find(|a| !matches!(a, Axis::X | Axis::Y | Axis::Z))
        {
            return Err(GcodeError::unsupported(
                s.line,
                w.get(a.letter()).map_or(0, |l| l.column),
                "G33.1 with an A, B, C, U, V or W word (LinuxCNC taps along X Y Z only)",
            ));
        }
        self.check_rotation(s)?;
        words.expanded = true;
        let start = self.comp.physical_start(&st.position);
        let feed = Feed::PerRevolution { mm_per_rev: k, rpm };
        let lin = Linear {
            from: self.event_point(&start),
            to: self.event_point(&to),
            offset: st.offset,
            feed,
            tcp: st.tcp,
            words,
        };
        s.emit(EventKind::Feed(lin));
        if tap {
            // The retract: the spindle reversed at I times the speed.
            let factor = w.get(b'I').map_or(1.0, |i| i.value).max(1.0);
            s.emit(EventKind::Feed(Linear {
                from: lin.to,
                to: lin.from,
                feed: Feed::PerRevolution {
                    mm_per_rev: k,
                    rpm: rpm * factor,
                },
                ..lin
            }));
        } else {
            self.state.position = to;
        }
        Ok(())
    }

    /// G76, LinuxCNC's threading cycle ([`threading_cycle`]): from the
    /// drive line (the current X and Z) the passes along Z to the block's Z,
    /// synchronised to the spindle at P per revolution (the tapers at their
    /// longer advance), then a rapid to the block's end point. X is the
    /// depth and Z the length whatever the plane, as in LinuxCNC. Its errors
    /// are LinuxCNC's (cutter compensation on, spindle stopped, rotary or
    /// UVW axis words that move, I = 0, J ≤ 0, K ≤ J, L negative, H or L
    /// not an integer); refused as unsupported: P ≤ 0 or no spindle speed
    /// (no time for the passes). More than
    /// [`MAX_THREADING_PASSES`](crate::limits::MAX_THREADING_PASSES) passes
    /// in one block are refused (a bound of mtwin). The moves are marked
    /// `expanded`, as a canned cycle's.
    pub(super) fn threading_cycle(
        &mut self,
        w: &BlockWords,
        axes: AxisMask,
        to: Axes,
        mut words: Programmed,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        self.comp.straight_move_started();
        if self.comp.is_on() {
            return Err(s.invalid(
                0,
                "Cannot use G76 threading cycle with cutter radius compensation on",
            ));
        }
        let st = &self.state;
        if st.spindle == SpindleState::Stopped {
            return Err(s.invalid(0, "Spindle not turning in G76"));
        }
        if let Some(a) = axes
            .iter()
            .find(|&a| !matches!(a, Axis::X | Axis::Y | Axis::Z) && to[a] != st.position[a])
        {
            let col = w.get(a.letter()).map_or(0, |l| l.column);
            return Err(s.invalid(col, "Cannot move rotary axes with G76"));
        }
        let scale = st.units.mm_per_unit();
        let value = |l: u8| w.get(l).map(|x| x.value);
        let integer = |l: u8| -> Result<Option<i64>, GcodeError> {
            match w.get(l) {
                Some(x) if x.value.fract() != 0.0 || x.value.abs() > 1e9 => Err(s.invalid(
                    x.column,
                    format!("{} word must be an integer with G76", l as char),
                )),
                Some(x) => Ok(Some(x.value as i64)),
                None => Ok(None),
            }
        };
        let h = integer(b'H')?.unwrap_or(0);
        let flags = match integer(b'L')? {
            Some(l) if l < 0 => {
                return Err(s.invalid(w.get(b'L').map_or(0, |x| x.column), "Negative L word used"));
            }
            l => l.unwrap_or(0),
        };
        let pitch = value(b'P').unwrap_or(0.0) * scale;
        if !(pitch > 0.0 && pitch.is_finite()) {
            return Err(GcodeError::unsupported(
                s.line,
                w.get(b'P').map_or(0, |p| p.column),
                "G76 with P ≤ 0 (no advance per spindle revolution to time the passes)",
            ));
        }
        let rpm = st.spindle_rpm;
        if !(rpm > 0.0 && rpm.is_finite()) {
            return Err(GcodeError::unsupported(
                s.line,
                0,
                "G76 with the spindle speed at 0 (no S): the passes cannot be timed",
            ));
        }
        let thread = threading_cycle::Thread {
            pitch,
            i: value(b'I').unwrap_or(0.0) * scale,
            j: value(b'J').unwrap_or(0.0) * scale,
            k: value(b'K').unwrap_or(0.0) * scale,
            compound_deg: value(b'Q').filter(|&q| q != -1.0).unwrap_or(0.0),
            full_depth_passes: u32::try_from((h + 1).max(0)).unwrap_or(u32::MAX),
            degression: value(b'R').filter(|&r| r >= 1.0).unwrap_or(1.0),
            taper: value(b'E').map_or(0.0, |e| (e * scale).max(0.0)),
            taper_flags: u32::try_from(flags & 3).unwrap_or(0),
        };
        let start = st.position;
        let moves = thread
            .moves(
                [start[Axis::X], start[Axis::Z]],
                to[Axis::Z],
                crate::limits::MAX_THREADING_PASSES,
            )
            .map_err(|e| s.invalid(0, e.to_string()))?;
        self.check_rotation(s)?;
        words.expanded = true;
        let mut from = self.comp.physical_start(&start);
        let mut emit = |this: &Self, end: Axes, feed: Feed, s: &mut Step| {
            let lin = Linear {
                from: this.event_point(&from),
                to: this.event_point(&end),
                offset: this.state.offset,
                feed,
                tcp: this.state.tcp,
                words,
            };
            s.emit(if feed == Feed::Rapid {
                EventKind::Traverse(lin)
            } else {
                EventKind::Feed(lin)
            });
            from = end;
        };
        for m in moves {
            let (xz, feed) = match m {
                threading_cycle::ThreadMove::Rapid(p) => (p, Feed::Rapid),
                threading_cycle::ThreadMove::Sync { to, mm_per_rev } => {
                    (to, Feed::PerRevolution { mm_per_rev, rpm })
                }
            };
            let mut end = start;
            end[Axis::X] = xz[0];
            end[Axis::Z] = xz[1];
            emit(self, end, feed, s);
        }
        emit(self, to, Feed::Rapid, s);
        self.state.position = to;
        Ok(())
    }

    /// What a move of cutter radius compensation carries besides its
    /// geometry.
    #[inline]
    fn move_info(&self, at: SourcePos, column: usize, words: Programmed, feed: Feed) -> MoveInfo {
        let st = &self.state;
        MoveInfo {
            at,
            column,
            plane: st.plane,
            units: st.units,
            offset: st.offset,
            tcp: st.tcp,
            words,
            feed,
        }
    }

    /// The feed of a G1, G2 or G3 move in the current feed mode.
    pub(super) fn feed(&self, w: &BlockWords, line: u64) -> Result<Feed, GcodeError> {
        let st = &self.state;
        match st.feed_mode {
            FeedMode::UnitsPerMinute => {
                if st.feed <= 0.0 {
                    return Err(GcodeError::invalid(
                        line,
                        0,
                        "Cannot do G1, G2 or G3 with zero feed rate",
                    ));
                }
                Ok(Feed::PerMinute(st.feed))
            }
            FeedMode::InverseTime => {
                if w.get(b'F').is_none() {
                    return Err(GcodeError::invalid(
                        line,
                        0,
                        "F word missing with inverse time G1, G2 or G3 move",
                    ));
                }
                if st.feed <= 0.0 {
                    return Err(GcodeError::invalid(line, 0, "zero inverse-time feed rate"));
                }
                Ok(Feed::InverseTime(st.feed))
            }
            FeedMode::UnitsPerRevolution => {
                if st.feed <= 0.0 {
                    return Err(GcodeError::invalid(
                        line,
                        0,
                        "Cannot do G1, G2 or G3 with zero feed per revolution",
                    ));
                }
                if st.spindle_rpm <= 0.0 {
                    return Err(GcodeError::invalid(
                        line,
                        0,
                        "Cannot feed with zero spindle speed in feed per rev mode",
                    ));
                }
                Ok(Feed::PerRevolution {
                    mm_per_rev: st.feed,
                    rpm: st.spindle_rpm,
                })
            }
        }
    }

    /// M2, M30: end of program (M0, M1, M60 do not change the motion).
    /// Every stop releases the moves cutter compensation holds back, as they
    /// are; M2 and M30 also turn it off.
    #[inline]
    pub(super) fn stop(&mut self, codes: &Codes, s: &mut Step) -> Result<(), GcodeError> {
        let Some((code, _)) = codes.m_stop else {
            return Ok(());
        };
        let end = matches!(code, 2 | 30);
        let plane = self.state.plane;
        self.comp
            .stop(&self.state.position, plane, end, s.out, s.line)?;
        if end {
            self.ended = true;
            s.emit(EventKind::ProgramEnd);
        } else {
            s.emit(EventKind::Wait(TaskWait::Pause));
        }
        Ok(())
    }

    /// Centre (work X Y Z) and signed turns of a G2/G3 block.
    fn arc_center(
        &self,
        w: &BlockWords,
        from: &Axes,
        to: &Axes,
        ccw: bool,
        line: u64,
    ) -> Result<([f64; 3], i32), GcodeError> {
        let st = &self.state;
        let (p, q, n) = st.plane.axes();
        let offset_letter = |a: Axis| match a {
            Axis::X => b'I',
            Axis::Y => b'J',
            _ => b'K',
        };
        let (lp, lq, ln) = (offset_letter(p), offset_letter(q), offset_letter(n));
        if let Some(x) = w.get(ln) {
            let plane = match st.plane {
                Plane::Xy => "XY",
                Plane::Zx => "XZ",
                Plane::Yz => "YZ",
            };
            return Err(GcodeError::invalid(
                line,
                x.column,
                format!("{} word given for arc in {plane} plane", ln as char),
            ));
        }
        let turns = match w.get(b'P') {
            None => 1,
            Some(pw) => {
                if pw.value.fract() != 0.0 {
                    return Err(GcodeError::invalid(
                        line,
                        pw.column,
                        "P value not an integer with G2 or G3",
                    ));
                }
                if pw.value < 1.0 || pw.value > f64::from(i32::MAX) {
                    return Err(GcodeError::invalid(
                        line,
                        pw.column,
                        "P value not positive with G2 or G3",
                    ));
                }
                pw.value as i32
            }
        };
        let s = [from[p], from[q]];
        let e = [to[p], to[q]];
        let scale = st.units.mm_per_unit();
        let dim = |l: &Letter| {
            self.opts
                .dialect
                .dimension(l.value, l.has_point, st.units == Units::Inch, false)
                * scale
        };
        let arc_err = |e: ArcError| GcodeError::invalid(line, 0, e.to_string());
        let (ip, iq, r) = (w.get(lp), w.get(lq), w.get(b'R'));
        let c = match (ip.is_some() || iq.is_some(), r) {
            (true, Some(rw)) => {
                return Err(GcodeError::invalid(
                    line,
                    rw.column,
                    "Mixed radius-ijk format for arc",
                ));
            }
            (false, None) => {
                return Err(GcodeError::invalid(
                    line,
                    0,
                    "R, I, J and K words all missing for arc",
                ));
            }
            (false, Some(rw)) => {
                arc::center_from_radius(s, e, dim(rw), ccw, st.units).map_err(arc_err)?
            }
            (true, None) => {
                if st.arc_distance == DistanceMode::Absolute {
                    // G90.1: both centre words, as LinuxCNC requires.
                    for (l, x) in [(lp, ip), (lq, iq)] {
                        if x.is_none() {
                            return Err(GcodeError::invalid(
                                line,
                                0,
                                format!("{} word missing in absolute center arc", l as char),
                            ));
                        }
                    }
                }
                let (op, oq) = (ip.map_or(0.0, dim), iq.map_or(0.0, dim));
                let c = match st.arc_distance {
                    DistanceMode::Incremental => [s[0] + op, s[1] + oq],
                    DistanceMode::Absolute => [op, oq],
                };
                arc::check_center(s, e, c, st.units).map_err(arc_err)?;
                c
            }
        };
        let mut center = from.xyz();
        center[p.index()] = c[0];
        center[q.index()] = c[1];
        Ok((center, if ccw { turns } else { -turns }))
    }
}
