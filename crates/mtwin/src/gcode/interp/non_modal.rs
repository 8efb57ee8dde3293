//! The non-modal codes that change state or move: G10 (offset and tool
//! tables), G28/G30 (through a waypoint home), G52 and the G92 family.

use super::*;

impl Interpreter {
    /// The non-modal codes of group 0 that change state or move: G10, G28,
    /// G28.1, G30, G30.1, G52, G92 (G4 and G53 have their own steps).
    pub(super) fn non_modal(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.non_modal else {
            return Ok(());
        };
        const AXIS_OFFSETS: &str = "Cannot change axis offsets with cutter radius comp";
        match code {
            GCode::G28 | GCode::G30 => {
                self.refuse_with_comp(s, col, "Cannot use g28 or g30 with cutter radius comp")?
            }
            GCode::G28_1 | GCode::G30_1 => self.refuse_with_comp(
                s,
                col,
                "Cannot set reference point with cutter compensation in effect",
            )?,
            GCode::G52 | GCode::G92 => self.refuse_with_comp(s, col, AXIS_OFFSETS)?,
            _ => {}
        }
        match code {
            GCode::G10 => self.g10(w, codes, col, s),
            GCode::G28 | GCode::G30 => self.go_home(code, w, codes, s),
            GCode::G28_1 => {
                self.state.g28_home = self.home_to_store();
                Ok(())
            }
            GCode::G30_1 => {
                self.state.g30_home = self.home_to_store();
                Ok(())
            }
            GCode::G52 | GCode::G92 => {
                let (axes, values) = self.axis_words(w, codes);
                self.check_wrapped(w, axes, &values, s)?;
                for a in axes.iter() {
                    let v = values[a.index()];
                    self.state.axis_offset[a] = if code == GCode::G92 {
                        self.state.position[a] + self.state.axis_offset[a] - v
                    } else {
                        v
                    };
                }
                self.apply_offsets();
                self.state.g92_saved = self.state.axis_offset;
                self.state.g92_applied = true;
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// Refuses absolute values of wrapped rotary axes outside (−360, 360).
    #[inline]
    fn check_wrapped(
        &self,
        w: &BlockWords,
        axes: AxisMask,
        values: &[f64; 9],
        s: &Step,
    ) -> Result<(), GcodeError> {
        for a in axes.iter() {
            let v = values[a.index()];
            if self.opts.wrapped_rotary.contains(a) && (v <= -360.0 || v >= 360.0) {
                let col = w.get(a.letter()).map_or(0, |l| l.column);
                return Err(s.invalid(
                    col,
                    format!("Invalid absolute position {v} for wrapped rotary axis {a:?}"),
                ));
            }
        }
        Ok(())
    }

    /// The machine position G28.1/G30.1 store (wrapped rotary axes in
    /// [0, 360)).
    #[inline]
    fn home_to_store(&self) -> Axes {
        let mut m = self.to_machine(&self.state.position);
        for a in self.opts.wrapped_rotary.iter() {
            m[a] = m[a].rem_euclid(360.0);
        }
        m
    }

    /// G28, G30: a rapid to the axis words (the waypoint, in the current
    /// frame and distance mode), then a rapid to the stored home position
    /// on the axes named (all axes if none is named). Both moves are made
    /// even when they have no length, as LinuxCNC's canonical calls are.
    fn go_home(
        &mut self,
        code: GCode,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let (axes, values) = self.axis_words(w, codes);
        let from = self.state.position;
        let mut waypoint = from;
        for a in axes.iter() {
            let v = values[a.index()];
            waypoint[a] = match self.state.distance {
                DistanceMode::Incremental => from[a] + v,
                DistanceMode::Absolute if self.opts.wrapped_rotary.contains(a) => {
                    unwrap_rotary(v, from[a])
                        .map_err(|m| s.invalid(w.get(a.letter()).map_or(0, |l| l.column), m))?
                }
                DistanceMode::Absolute => v,
            };
        }
        let mut words = self.programmed(axes, false);
        words.expanded = true;
        self.push_straight(true, waypoint, words, s)?;
        let home = if code == GCode::G28 {
            self.state.g28_home
        } else {
            self.state.g30_home
        };
        let mut end = waypoint;
        if self.state.rotation == 0.0 {
            let home_work = home.sub(&self.state.offset);
            for a in Axis::ALL {
                if axes.is_empty() || axes.contains(a) {
                    end[a] = home_work[a];
                }
            }
        } else {
            // The axes named go to their machine home, the others keep
            // their machine position; back to the rotated frame.
            let mut m = self.to_machine(&waypoint);
            for a in Axis::ALL {
                if axes.is_empty() || axes.contains(a) {
                    m[a] = home[a];
                }
            }
            end = self.to_work(&m);
        }
        self.push_straight(true, end, self.programmed(AxisMask::EMPTY, true), s)
    }

    /// What the block wrote for a move, in the current modes.
    #[inline]
    pub(super) fn programmed(&self, axes: AxisMask, expanded: bool) -> Programmed {
        Programmed {
            axes,
            g53: false,
            distance: self.state.distance,
            units: self.state.units,
            expanded,
            x_diameter: self.state.lathe_diameter,
        }
    }

    /// A straight move from the current position to `to` (work
    /// coordinates): a rapid, or a feed at the current feed (units per
    /// minute or per revolution, as canned cycles feed).
    pub(super) fn push_straight(
        &mut self,
        rapid: bool,
        to: Axes,
        words: Programmed,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let st = &self.state;
        let feed = if rapid {
            Feed::Rapid
        } else {
            match st.feed_mode {
                FeedMode::UnitsPerRevolution => Feed::PerRevolution {
                    mm_per_rev: st.feed,
                    rpm: st.spindle_rpm,
                },
                _ => Feed::PerMinute(st.feed),
            }
        };
        self.check_rotation(s)?;
        let start = self.comp.physical_start(&st.position);
        let lin = Linear {
            from: self.event_point(&start),
            to: self.event_point(&to),
            offset: st.offset,
            feed,
            tcp: st.tcp,
            words,
        };
        self.state.position = to;
        s.emit(if rapid {
            EventKind::Traverse(lin)
        } else {
            EventKind::Feed(lin)
        });
        Ok(())
    }

    /// G10: L2 and L20 set the offset of a coordinate system (P1 ... P9,
    /// P0 the active one), L1, L10 and L11 a tool table entry (P the tool).
    pub(super) fn g10(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        col: usize,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let l = w
            .get(b'L')
            .filter(|l| matches!(l.value, 1.0 | 2.0 | 10.0 | 11.0 | 20.0))
            .ok_or_else(|| s.invalid(col, "Line with G10 does not have L1, L10, L11, L2, or L20"))?
            .value as u32;
        let p = w.get(b'P').map_or(0.0, |p| p.value);
        let p_int = p.round();
        if (p - p_int).abs() > 0.0002 {
            return Err(s.invalid(col, "P value not an integer with G10"));
        }
        let (axes, values) = self.axis_words(w, codes);
        let st = &self.state;
        // The current position as it would read in `system` (LinuxCNC's
        // find_current_in_system), without rotation.
        let in_system = |system: usize| -> Axes {
            let mut c = st
                .position
                .add(&st.axis_offset)
                .add(&st.work_offsets[usize::from(st.work_system - 1)])
                .sub(&st.work_offsets[system - 1]);
            if st.g92_applied {
                c = c.sub(&st.g92_saved);
            }
            c
        };
        match l {
            2 | 20 => {
                if !(0.0..=9.0).contains(&p_int) {
                    return Err(s.invalid(col, format!("P value out of range (0-9) with G10 L{l}")));
                }
                if w.get(b'I').is_some() || w.get(b'J').is_some() {
                    return Err(s.invalid(col, "I J words not allowed with G10 L2"));
                }
                let rotation = match w.get(b'R') {
                    Some(r) if l == 20 => {
                        return Err(s.invalid(r.column, "R not allowed in G10 L20"));
                    }
                    // Degrees, whatever the length units.
                    Some(r) => Some(r.value),
                    None => None,
                };
                if l == 20 {
                    self.check_wrapped(w, axes, &values, s)?;
                }
                let system = if p_int == 0.0 {
                    usize::from(st.work_system)
                } else {
                    p_int as usize
                };
                let active = system == usize::from(st.work_system);
                if active {
                    self.refuse_with_comp(
                        s,
                        col,
                        "Cannot change the active coordinate system with cutter radius compensation on",
                    )?;
                }
                let rotated = st.rotation != 0.0 || st.work_rotations[system - 1] != 0.0;
                // LinuxCNC's interpreter re-reads the current point
                // without the G92 offset when the rotation of the active
                // system changes (or G10 L20 sets a rotated one), while its
                // motion keeps the machine point: the two disagree, so
                // mtwin refuses rather than pick one.
                let g92 = st.axis_offset[Axis::X] != 0.0 || st.axis_offset[Axis::Y] != 0.0;
                let new_rotation = rotation.is_some_and(|r| r != st.rotation);
                if active && g92 && (new_rotation || (l == 20 && rotated)) {
                    return Err(GcodeError::unsupported(
                        s.line,
                        col,
                        format!(
                            "G10 L{l} {} of the active coordinate system while a G92 offset is in force",
                            if l == 20 {
                                "in a rotated system"
                            } else {
                                "changing the rotation"
                            }
                        ),
                    ));
                }
                if l == 20 && rotated && !active {
                    return Err(GcodeError::unsupported(
                        s.line,
                        col,
                        "G10 L20 of a coordinate system other than the active one with a rotation (G10 L2 R) in force",
                    ));
                }
                let current = in_system(system);
                let mut offset = st.work_offsets[system - 1];
                if l == 20 && rotated {
                    // The active system: the origin moves by the rotated
                    // difference between the current point and the values
                    // (LinuxCNC: the machine point stays, reading them).
                    let mut delta = Axes::ZERO;
                    for a in axes.iter() {
                        delta[a] = current[a] - values[a.index()];
                    }
                    rotate_xy(&mut delta, st.rotation);
                    offset = offset.add(&delta);
                } else {
                    for a in axes.iter() {
                        let v = values[a.index()];
                        offset[a] = if l == 20 {
                            current[a] + offset[a] - v
                        } else {
                            v
                        };
                    }
                }
                self.state.work_offsets[system - 1] = offset;
                if let Some(r) = rotation {
                    self.state.work_rotations[system - 1] = r;
                }
                if active {
                    self.apply_offsets();
                    s.emit(EventKind::WorkOffset {
                        system: system as u8,
                        offset,
                        rotation: self.state.rotation,
                    });
                }
                Ok(())
            }
            _ => {
                if p_int < 1.0 {
                    return Err(s.invalid(col, format!("P value out of range with G10 L{l}")));
                }
                let tool = p_int as u32;
                if axes.is_empty() && [b'R', b'Q', b'I', b'J'].iter().all(|&c| w.get(c).is_none()) {
                    return Err(s.invalid(col, "G10 L1 without offsets has no effect"));
                }
                if self.tools.get(tool).is_none() {
                    return Err(s.invalid(col, format!("tool {tool} is not in the tool table")));
                }
                let offset = if l == 1 {
                    let mut o = self.tools.get(tool).map_or(Axes::ZERO, |t| t.offset);
                    for a in axes.iter() {
                        o[a] = values[a.index()];
                    }
                    o
                } else {
                    self.tool_offset_reading(l, tool, axes, &values)
                };
                let scale = self.state.units.mm_per_unit();
                let r = w.get(b'R').map(|r| r.value * scale);
                let q = w.get(b'Q').map(|q| q.value);
                let (i, j) = (w.get(b'I').map(|x| x.value), w.get(b'J').map(|x| x.value));
                let entry = self.tools.entry(tool);
                entry.offset = offset;
                if let Some(r) = r {
                    entry.diameter = (2.0 * r).abs();
                }
                if let Some(q) = q {
                    if !(0.0..=9.0).contains(&q) || q.fract() != 0.0 {
                        return Err(s.invalid(col, "Q (orientation) must be 0 to 9 with G10 L1"));
                    }
                    entry.orientation = q as u8;
                }
                if let Some(i) = i {
                    entry.front_angle = i;
                }
                if let Some(j) = j {
                    entry.back_angle = j;
                }
                Ok(())
            }
        }
    }

    /// The current point as it reads in coordinate system `system` (1 ... 9)
    /// with no tool offset (LinuxCNC's `find_current_in_system_without_tlo`):
    /// the machine point without the tool offset in force, taken into
    /// `system`'s origin and rotation, less the G92 offsets if applied.
    #[inline]
    fn current_in_system_without_tool(&self, system: usize) -> Axes {
        let st = &self.state;
        let mut c = st.position.add(&st.axis_offset);
        rotate_xy(&mut c, st.rotation);
        c = c
            .add(&st.work_offsets[usize::from(st.work_system - 1)])
            .add(&st.tool_offset)
            .sub(&st.work_offsets[system - 1]);
        rotate_xy(&mut c, -st.work_rotations[system - 1]);
        if st.g92_applied {
            c = c.sub(&st.g92_saved);
        }
        c
    }

    /// The tool offsets G10 L10 (L11) sets for `tool`: those with which the
    /// current point reads the axis words in the active system (in G59.3,
    /// without its G92 offsets), as LinuxCNC's `convert_setup_tool` computes
    /// them. X and Y are the difference turned by the system's rotation
    /// (G10 L2 R); with only one of them written, the entry keeps the part
    /// of its old X Y offset along the other (rotated) axis. Axes not
    /// written keep the entry's offsets.
    fn tool_offset_reading(&self, l: u32, tool: u32, axes: AxisMask, values: &[f64; 9]) -> Axes {
        let st = &self.state;
        let system = if l == 11 {
            9
        } else {
            usize::from(st.work_system)
        };
        let mut current = self.current_in_system_without_tool(system);
        if l == 11 && st.g92_applied {
            current = current.add(&st.g92_saved);
        }
        let rotation = st.work_rotations[system - 1];
        let old = self.tools.get(tool).map_or(Axes::ZERO, |t| t.offset);
        let mut offset = old;
        for a in axes.iter() {
            offset[a] = current[a] - values[a.index()];
        }
        let (x, y) = (axes.contains(Axis::X), axes.contains(Axis::Y));
        if x || y {
            // The new part along the written axes, turned into the machine
            // frame, plus the old part along the other one.
            let mut new = Axes::ZERO;
            let mut kept = Axes::ZERO;
            kept[Axis::X] = old[Axis::X];
            kept[Axis::Y] = old[Axis::Y];
            rotate_xy(&mut kept, -rotation);
            if x {
                new[Axis::X] = current[Axis::X] - values[Axis::X.index()];
                kept[Axis::X] = 0.0;
            }
            if y {
                new[Axis::Y] = current[Axis::Y] - values[Axis::Y.index()];
                kept[Axis::Y] = 0.0;
            }
            rotate_xy(&mut new, rotation);
            rotate_xy(&mut kept, rotation);
            offset[Axis::X] = new[Axis::X] + kept[Axis::X];
            offset[Axis::Y] = new[Axis::Y] + kept[Axis::Y];
        }
        offset
    }

    /// G92.1 and G92.2 (axis offsets to zero; G92.1 also clears the kept
    /// values), G92.3 (restore the kept values).
    #[inline]
    pub(super) fn set_g92_applied(&mut self, codes: &Codes, s: &Step) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.g92_applied else {
            return Ok(());
        };
        self.refuse_with_comp(s, col, "Cannot change axis offsets with cutter radius comp")?;
        if code == GCode::G92_3 {
            self.state.axis_offset = self.state.g92_saved;
            self.state.g92_applied = true;
        } else {
            self.state.axis_offset = Axes::ZERO;
            self.state.g92_applied = false;
            if code == GCode::G92_1 {
                self.state.g92_saved = Axes::ZERO;
            }
        }
        self.apply_offsets();
        Ok(())
    }
}
