//! Reading and checking a block before anything runs: one code per modal
//! group, every word read by something, polar words (LinuxCNC's `read_g`,
//! `check_g_codes`, `check_other_codes`).

use super::*;

impl Interpreter {
    /// Reads the G- and M-codes of a block into `codes` (empty on entry), one per modal group,
    /// refusing unknown and unsupported codes and two codes of one group
    /// (LinuxCNC's `read_g`: G80 may share the line with another motion
    /// code, which wins).
    pub(super) fn read_codes(
        &self,
        w: &BlockWords,
        line: u64,
        codes: &mut Codes,
    ) -> Result<(), GcodeError> {
        let dialect = self.opts.dialect;
        for &(code, col) in &w.g {
            if let Some(why) = code.unsupported() {
                return Err(GcodeError::unsupported(line, col, format!("{why} {code}")));
            }
            if matches!(code, GCode::G33 | GCode::G33_1) && dialect != Dialect::LinuxCnc {
                // Fanuc's G33 takes the lead from F, not K.
                return Err(GcodeError::unsupported(
                    line,
                    col,
                    format!("spindle-synchronised motion {code} in this dialect"),
                ));
            }
            if matches!(code, GCode::G7 | GCode::G8) && dialect != Dialect::LinuxCnc {
                // Fanuc's G7 is not LinuxCNC's diameter mode.
                return Err(GcodeError::unsupported(
                    line,
                    col,
                    format!("lathe diameter/radius mode {code} in this dialect"),
                ));
            }
            let group = code.group(dialect);
            if group == ModalGroup::ArcDistance && !dialect.has_arc_distance_modes() {
                return Err(GcodeError::unsupported(
                    line,
                    col,
                    format!("{code} in this dialect"),
                ));
            }
            let slot = codes.slot(group);
            match *slot {
                None => *slot = Some((code, col)),
                Some((other, _)) => {
                    if group == ModalGroup::Motion && code == GCode::G80 {
                        // G80 beside another motion code is ignored.
                    } else if group == ModalGroup::Motion && other == GCode::G80 {
                        *slot = Some((code, col));
                    } else {
                        return Err(GcodeError::invalid(
                            line,
                            col,
                            format!("two G-codes of one modal group: {other} and {code}"),
                        ));
                    }
                }
            }
        }
        // M-codes: at most one per modal group.
        for &(code, col) in &w.m {
            let slot = match code {
                0 | 1 | 2 | 30 | 60 => &mut codes.m_stop,
                3..=5 => &mut codes.m_spindle,
                c if Some(c) == self.opts.tcp_on_m || Some(c) == self.opts.tcp_off_m => {
                    &mut codes.m_tcp
                }
                6 | 61 => &mut codes.m_tool_change,
                c if m_ignored(c) => continue,
                98 | 99 => {
                    return Err(GcodeError::unsupported(
                        line,
                        col,
                        format!("subprogram call M{code}"),
                    ));
                }
                _ => match self.opts.unknown_m {
                    UnknownMCode::Ignore => continue,
                    UnknownMCode::Reject => {
                        return Err(GcodeError::unsupported(
                            line,
                            col,
                            format!("M-code M{code}"),
                        ));
                    }
                },
            };
            if let Some((other, _)) = *slot {
                return Err(GcodeError::invalid(
                    line,
                    col,
                    format!("two M-codes of one modal group: M{other} and M{code}"),
                ));
            }
            *slot = Some((code, col));
        }
        if let Some((code, col)) = codes.non_modal
            && code.covets_axes()
        {
            if let Some((motion, _)) = codes.explicit_motion() {
                return Err(GcodeError::invalid(
                    line,
                    col,
                    format!(
                        "Cannot use two G codes that both use axis values: {code} and {motion}"
                    ),
                ));
            }
            let any_axis = Axis::ALL.iter().any(|a| w.get(a.letter()).is_some());
            if !any_axis && matches!(code, GCode::G52 | GCode::G92) {
                return Err(GcodeError::invalid(
                    line,
                    col,
                    format!("All axes missing with {code}"),
                ));
            }
        }
        if let Some((code, col)) = codes.motion
            && code.is_probe()
            && !Axis::ALL.iter().any(|a| w.get(a.letter()).is_some())
            && !w.polar()
        {
            let name = if code == GCode::G31 { "G31" } else { "G38.x" };
            return Err(GcodeError::invalid(
                line,
                col,
                format!("probing {name} without axis words"),
            ));
        }
        Ok(())
    }

    /// Whether a non-motion code of the block reads its axis words (G10,
    /// G28, G30, G52, G92, G43.1).
    #[inline]
    pub(super) fn axes_consumed(&self, codes: &Codes) -> bool {
        codes.non_modal.is_some_and(|(c, _)| c.covets_axes()) || codes.has(GCode::G43_1)
    }

    /// The motion mode the block's axis words will use: its own motion
    /// code, else the modal one.
    #[inline]
    pub(super) fn motion_to_be(&self, codes: &Codes) -> Option<MotionMode> {
        if codes.motion.is_none() && self.axes_consumed(codes) {
            return None;
        }
        match codes.motion {
            Some((GCode::G80, _)) => None,
            Some((code, _)) => Some(motion_mode(code)),
            None => self.state.motion,
        }
    }

    /// Refuses words that no code of the block reads, as LinuxCNC's
    /// `check_other_codes` does: I J K without an arc, R outside arcs, G64
    /// and M19, and D, E, H, L, P, Q ("E word with no G76, M66, M67 or M68
    /// to use it", ...): a word nothing reads is a typing error, never
    /// silently dropped. Only the codes this interpreter accepts are listed.
    pub(super) fn check_words(
        &self,
        block: &Block,
        w: &BlockWords,
        codes: &Codes,
        line: u64,
    ) -> Result<(), GcodeError> {
        let any_axis = Axis::ALL.iter().any(|a| w.get(a.letter()).is_some()) || w.polar();
        let moving = any_axis || codes.explicit_motion().is_some();
        let to_be = self.motion_to_be(codes);
        let arc_now = moving
            && matches!(
                to_be,
                Some(MotionMode::ArcClockwise | MotionMode::ArcCounterClockwise)
            );
        let cycle_now = match to_be {
            Some(MotionMode::Cycle(c)) if moving => Some(c),
            _ => None,
        };
        let cycle_in = |cs: &[GCode]| cycle_now.is_some_and(|c| cs.contains(&c));
        // G33 and G33.1 read K (and G33.1 I, the retract speed factor).
        let sync_now =
            moving && matches!(to_be, Some(MotionMode::SpindleSync | MotionMode::RigidTap));
        let tap_now = sync_now && to_be == Some(MotionMode::RigidTap);
        // G76 reads I J K, E, H, L, P, Q and R.
        let thread_now = moving && to_be == Some(MotionMode::Threading);
        if let Some((GCode::G33 | GCode::G33_1 | GCode::G76, col)) = codes.motion
            && !any_axis
        {
            return Err(GcodeError::invalid(
                line,
                col,
                "All axes missing with motion code",
            ));
        }
        let g10 = codes.has(GCode::G10);
        if let Some(r) = w.get(b'R') {
            // R is read by G2/G3, G64 (blend tolerance) and M19 (orientation).
            let g64 = codes.has(GCode::G64);
            let m19 = w.has_m(&[19]);
            if g64 && m19 {
                return Err(GcodeError::invalid(
                    line,
                    r.column,
                    "R word is ambiguous on a line with both G64 and M19 - use separate lines",
                ));
            }
            if !(arc_now || g64 || m19 || g10 || cycle_now.is_some() || thread_now) {
                return Err(GcodeError::invalid(
                    line,
                    r.column,
                    "R word with no g code that uses it",
                ));
            }
        }
        if !arc_now && !cycle_in(&[GCode::G87]) && !thread_now {
            for l in [b'I', b'J', b'K'] {
                if (l != b'K' && g10) || (l == b'K' && sync_now) || (l == b'I' && tap_now) {
                    continue;
                }
                if let Some(x) = w.get(l) {
                    return Err(GcodeError::invalid(
                        line,
                        x.column,
                        format!("{} word with no G2 or G3 to use it", l as char),
                    ));
                }
            }
        }
        let comp_on = codes.cutter_comp.is_some_and(|(c, _)| c != GCode::G40);
        // Whether a code of the block reads the letter: worked out only for
        // a letter the block has (most blocks have none of these).
        let checks: [(u8, &dyn Fn() -> bool, &str); 6] = [
            (
                b'D',
                &|| comp_on,
                "D word with no G41, G41.1, G42, G42.1 or G96 to use it",
            ),
            (
                b'E',
                &|| w.has_m(&[66, 67, 68]) || sync_now || thread_now,
                "E word with no G76, M66, M67 or M68 to use it",
            ),
            (
                b'H',
                &|| {
                    codes.has(GCode::G43)
                        || codes.has(GCode::G43_2)
                        || codes.has(GCode::G43_4)
                        || thread_now
                },
                "H word with no G43 or G76 to use it",
            ),
            (
                b'L',
                &|| w.has_m(&[66]) || g10 || cycle_now.is_some() || comp_on || thread_now,
                "L word with no G10, cutter compensation, canned cycle or M66 to use it",
            ),
            (
                b'P',
                &|| {
                    codes.has(GCode::G4)
                        || codes.has(GCode::G64)
                        || arc_now
                        || g10
                        || thread_now
                        || cycle_in(&[
                            GCode::G74,
                            GCode::G82,
                            GCode::G84,
                            GCode::G86,
                            GCode::G88,
                            GCode::G89,
                        ])
                        || w.has_m(&[19, 50, 51, 52, 53, 62, 63, 64, 65, 66])
                },
                "P word with no G2, G3, G4, G64, M19, M50-M53 or M62-M66 to use it",
            ),
            (
                b'Q',
                &|| {
                    codes.has(GCode::G64)
                        || w.has_m(&[19, 61, 66, 67, 68])
                        || g10
                        || thread_now
                        || cycle_in(&[GCode::G73, GCode::G83])
                },
                "Q word with no G64, M19, M61, M66, M67, M68 or canned cycle to use it",
            ),
        ];
        if sync_now {
            if w.get(b'K').is_none() {
                return Err(GcodeError::invalid(
                    line,
                    0,
                    "K word missing with g33/g33.1",
                ));
            }
            if let Some(f) = w.get(b'F') {
                return Err(GcodeError::invalid(
                    line,
                    f.column,
                    "F word used with a g33/g33.1",
                ));
            }
        }
        if thread_now {
            // LinuxCNC's P "missing" is its unset value, -1.
            if w.get(b'P').is_none_or(|p| p.value == -1.0) {
                return Err(GcodeError::invalid(line, 0, "P word missing with G76"));
            }
            if [b'I', b'J', b'K'].iter().any(|&l| w.get(l).is_none()) {
                return Err(GcodeError::invalid(
                    line,
                    0,
                    "I, J, or K words missing with G76",
                ));
            }
        }
        for (l, used, message) in checks {
            let Some(x) = w.get(l) else { continue };
            if used() {
                continue;
            }
            let mut message = message.to_string();
            // `X1e3`: the E (or D) was meant as an exponent.
            let at = x.column - 1;
            let text = block.text();
            if matches!(l, b'E' | b'D')
                && at > 0
                && text.get(at - 1).is_some_and(u8::is_ascii_digit)
            {
                message.push_str(
                    " (G-code numbers have no exponent: `1e3` reads as 1 followed by an E word)",
                );
            }
            return Err(GcodeError::invalid(line, x.column, message));
        }
        Ok(())
    }

    /// LinuxCNC's polar coordinates, `@` (distance from the origin of the
    /// program frame, program units) and `^` (angle from +X, degrees,
    /// counter-clockwise seen from +Z), which stand for the X and Y words
    /// of a motion: the checks of LinuxCNC 2.9's `enhance_block` and
    /// `find_ends` that need no position. The plane checked is the one in
    /// force before the block (as LinuxCNC checks it).
    pub(super) fn check_polar(
        &self,
        w: &BlockWords,
        codes: &Codes,
        line: u64,
    ) -> Result<(), GcodeError> {
        let Some(first) = [b'@', b'^']
            .iter()
            .filter_map(|&l| w.get(l))
            .map(|l| l.column)
            .min()
        else {
            return Ok(());
        };
        let invalid = |m: &str| Err(GcodeError::invalid(line, first, m));
        if self.opts.dialect != Dialect::LinuxCnc {
            return Err(GcodeError::unsupported(
                line,
                first,
                "polar coordinates (@, ^) in this dialect",
            ));
        }
        if !(self.opts.machine_axes.contains(Axis::X) && self.opts.machine_axes.contains(Axis::Y)) {
            return invalid("Cannot use polar coordinate on a machine lacking X or Y axes");
        }
        if self.state.plane != Plane::Xy {
            return invalid("Cannot use polar coordinate except in G17 plane");
        }
        for l in [b'X', b'Y'] {
            if let Some(x) = w.get(l) {
                return Err(GcodeError::invalid(
                    line,
                    x.column,
                    format!(
                        "Cannot specify both polar coordinate and {} word",
                        l as char
                    ),
                ));
            }
        }
        if let Some((GCode::G80, col)) = codes.motion
            && !self.axes_consumed(codes)
        {
            return Err(GcodeError::invalid(
                line,
                col,
                "Cannot use axis values with G80",
            ));
        }
        if self.motion_to_be(codes).is_none() || self.axes_consumed(codes) {
            return invalid("Polar coordinates can only be used for motion");
        }
        if let Some(col) = codes.g53() {
            return Err(GcodeError::invalid(
                line,
                col,
                "Cannot use polar coordinates with G53",
            ));
        }
        Ok(())
    }

    /// The X Y end (mm, program frame) of a single move with polar words,
    /// from `[x, y]`, the point the move starts from (the programmed one
    /// under cutter radius compensation), as LinuxCNC 2.9's `find_ends`:
    /// in G90 `@` and `^` are the end's distance and angle, the missing one
    /// kept from the start (a distance alone at the origin is an error); in
    /// G91 `@` is added to the start's distance and `^` to its angle (an
    /// error at the origin).
    pub(super) fn polar_end(
        &self,
        w: &BlockWords,
        [x, y]: [f64; 2],
        s: &Step,
    ) -> Result<(f64, f64), GcodeError> {
        let scale = self.state.units.mm_per_unit();
        let distance = w.get(b'@').map(|l| l.value * scale);
        let angle = w.get(b'^').map(|l| l.value.to_radians());
        let at_origin = x == 0.0 && y == 0.0;
        let polar = |r: f64, t: f64| (r * t.cos(), r * t.sin());
        match self.state.distance {
            DistanceMode::Absolute => match (distance, angle) {
                (Some(r), Some(t)) => Ok(polar(r, t)),
                (Some(_), None) if at_origin => {
                    Err(s.invalid(0, "Must specify angle in polar coordinate if at the origin"))
                }
                (Some(r), None) => Ok(polar(r, y.atan2(x))),
                (None, Some(t)) => Ok(polar(x.hypot(y), t)),
                (None, None) => Ok((x, y)), // not a polar block
            },
            DistanceMode::Incremental => {
                let (mut x, mut y) = (x, y);
                if let Some(d) = distance {
                    if x == 0.0 && y == 0.0 {
                        return Err(s.invalid(
                            0,
                            "Incremental motion with polar coordinates is indeterminate when at the origin",
                        ));
                    }
                    (x, y) = polar(x.hypot(y) + d, y.atan2(x));
                }
                if let Some(t) = angle {
                    if x == 0.0 && y == 0.0 {
                        return Err(s.invalid(
                            0,
                            "G91 motion with polar coordinates is indeterminate when at the origin",
                        ));
                    }
                    (x, y) = polar(x.hypot(y), y.atan2(x) + t);
                }
                Ok((x, y))
            }
        }
    }
}
