//! The steps that set modal state, in LinuxCNC's order of execution: feed
//! mode and rate, spindle speed, tool select and change, spindle direction,
//! TCP M-codes, dwell, plane, units, lathe diameter mode, tool length
//! offset, coordinate system, distance modes, retract mode.

use super::*;

impl Interpreter {
    /// G93, G94, G95. Each clears the feed rate.
    #[inline]
    pub(super) fn set_feed_mode(&mut self, codes: &Codes, s: &mut Step) {
        let Some((code, _)) = codes.feed_mode else {
            return;
        };
        let mode = match code {
            GCode::G93 => FeedMode::InverseTime,
            GCode::G94 => FeedMode::UnitsPerMinute,
            _ => FeedMode::UnitsPerRevolution,
        };
        // LinuxCNC sets the feed rate to zero at every G93, G94 or G95, even
        // of the mode already in force: F must follow.
        self.state.feed = 0.0;
        self.feed_as_written = 0.0;
        self.state.feed_mode = mode;
        s.emit(EventKind::FeedMode(mode));
    }

    /// F, in canonical units (mm/min, 1/min, mm/rev).
    #[inline]
    pub(super) fn set_feed_rate(&mut self, w: &BlockWords, s: &mut Step) -> Result<(), GcodeError> {
        let Some(f) = w.get(b'F') else {
            return Ok(());
        };
        if f.value < 0.0 {
            return Err(s.invalid(f.column, "negative F word"));
        }
        let scale = match self.state.feed_mode {
            FeedMode::InverseTime => 1.0,
            _ => self.state.units.mm_per_unit(),
        };
        self.state.feed = f.value * scale;
        self.feed_as_written = f.value;
        s.emit(EventKind::FeedRate(self.state.feed));
        Ok(())
    }

    /// S, rev/min.
    #[inline]
    pub(super) fn set_spindle_speed(
        &mut self,
        w: &BlockWords,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let Some(sw) = w.get(b'S') else {
            return Ok(());
        };
        if sw.value < 0.0 {
            return Err(s.invalid(sw.column, "negative spindle speed"));
        }
        self.state.spindle_rpm = sw.value;
        s.emit(EventKind::SpindleSpeed { rpm: sw.value });
        Ok(())
    }

    /// T: the tool the next M6 loads. With a tool table, a tool other than
    /// 0 must be in it (LinuxCNC refuses T of a tool its table does not
    /// hold); without one, any tool is taken (its offsets are then unknown:
    /// G43 of it is refused).
    #[inline]
    pub(super) fn select_tool(&mut self, w: &BlockWords, s: &Step) -> Result<(), GcodeError> {
        if let Some(t) = w.get(b'T') {
            let n = nonneg_int(*t, s.line, "T")?;
            if n != 0 && !self.tools.is_empty() && self.tools.get(n).is_none() {
                return Err(s.invalid(
                    t.column,
                    format!("Requested tool {n} not found in the tool table"),
                ));
            }
            self.state.selected_tool = n;
        }
        Ok(())
    }

    /// M6: the selected tool goes into the spindle. M61 Qn: tool `n` is
    /// declared in the spindle without a change (LinuxCNC's
    /// CHANGE_TOOL_NUMBER: its entry becomes the spindle's, so a later G43
    /// without H or with H0 applies it, and `#5400`–`#5413` read it from
    /// the next line); Q0 empties the spindle. Q is rounded to the nearest
    /// integer, as LinuxCNC's `round_to_int`; M61 changes neither the tool
    /// T selected nor the tool offset in force.
    pub(super) fn change_tool(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        match codes.m_tool_change {
            Some((6, _)) => {
                self.refuse_with_comp(
                    s,
                    0,
                    "Cannot change tools with cutter radius compensation on",
                )?;
                self.tool_before_change = self.state.tool;
                self.state.tool = self.state.selected_tool;
                s.emit(EventKind::Wait(TaskWait::ToolChange));
            }
            Some((_, col)) => {
                let q = w.get(b'Q');
                let need = "Need non-negative Q-word to specify tool number with M61";
                let Some(q) = q else {
                    return Err(s.invalid(col, need));
                };
                let n = (q.value + 0.5).floor();
                if !(0.0..=f64::from(u32::MAX)).contains(&n) {
                    return Err(s.invalid(q.column, need));
                }
                let n = n as u32;
                if n != 0 && self.tools.get(n).is_none() {
                    return Err(s.invalid(
                        q.column,
                        format!("Requested tool {n} not found in the tool table"),
                    ));
                }
                self.tool_before_change = self.state.tool;
                self.state.tool = n;
                s.emit(EventKind::Wait(TaskWait::ToolNumber));
            }
            None => {}
        }
        Ok(())
    }

    /// The tool whose entry LinuxCNC's interpreter holds as the spindle's
    /// (its tool index 0, read by G43 H0, G43.2 H0, and G41/G42 without D
    /// or with D0) while this block runs: the tool in the spindle, except
    /// on the line of an M6 or M61, where LinuxCNC re-reads the entry only
    /// at the next line, so it is still the tool loaded before (checked
    /// with `rs274` 2.9: `T2 M6`, then `T4 M6 G43 H0` applies tool 2).
    #[inline]
    pub(super) fn spindle_entry_tool(&self, codes: &Codes) -> u32 {
        if codes.m_tool_change.is_some() {
            self.tool_before_change
        } else {
            self.state.tool
        }
    }

    /// The tool G43 and G43.4 without H apply: the spindle's entry, but on
    /// the line of an M6 or M61 the new tool's own entry (LinuxCNC reads
    /// the pocket changed to), unless that is tool 0 (its pocket is the
    /// spindle's entry, still the tool loaded before).
    #[inline]
    fn g43_default_tool(&self, codes: &Codes) -> u32 {
        if codes.m_tool_change.is_some() && self.state.tool != 0 {
            self.state.tool
        } else {
            self.spindle_entry_tool(codes)
        }
    }

    /// The block's M-codes among `codes` that LinuxCNC's task waits for
    /// motion to end at ([`TaskWait`]), in the order of `codes` (M9 is mist
    /// off, then flood off).
    #[inline]
    pub(super) fn task_waits(&mut self, w: &BlockWords, s: &mut Step, codes: &[u32]) {
        if w.m.is_empty() {
            return;
        }
        for &c in codes {
            if !w.m.iter().any(|&(m, _)| m == c) {
                continue;
            }
            let waits: &[TaskWait] = match c {
                7 => &[TaskWait::MistOn],
                8 => &[TaskWait::FloodOn],
                9 => &[TaskWait::MistOff, TaskWait::FloodOff],
                19 => &[TaskWait::SpindleOrient],
                66 => &[TaskWait::InputWait],
                _ => &[TaskWait::Output],
            };
            for &k in waits {
                s.emit(EventKind::Wait(k));
            }
        }
    }

    /// An error `message` at `column` while cutter radius compensation is
    /// on (LinuxCNC refuses these codes then).
    #[inline]
    pub(super) fn refuse_with_comp(
        &self,
        s: &Step,
        column: usize,
        message: &str,
    ) -> Result<(), GcodeError> {
        if self.comp.is_on() {
            return Err(s.invalid(column, message));
        }
        Ok(())
    }

    /// M-codes accepted without a motion meaning that LinuxCNC refuses
    /// while cutter radius compensation is on (overrides, outputs, inputs).
    #[inline]
    pub(super) fn m_codes_with_comp(&self, w: &BlockWords, s: &Step) -> Result<(), GcodeError> {
        if !self.comp.is_on() {
            return Ok(());
        }
        let enable = w.get(b'P').is_none_or(|p| p.value != 0.0);
        for &(code, col) in &w.m {
            let message = match code {
                48 => "Cannot enable overrides with cutter radius compensation on",
                49 => "Cannot disable overrides with cutter radius compensation on",
                50..=53 if enable => "Cannot enable overrides with cutter radius compensation on",
                50..=53 => "Cannot disable overrides with cutter radius compensation on",
                62 => "Cannot set motion output with cutter radius compensation on",
                63 => "Cannot set motion digital output with cutter radius compensation on",
                64 | 65 => "Cannot set auxiliary digital output with cutter radius compensation on",
                66 if w.get(b'P').is_some() => {
                    "Cannot wait for digital input with cutter radius compensation on"
                }
                66 => "Cannot wait for analog input with cutter radius compensation on",
                67 => "Cannot set motion analog output with cutter radius compensation on",
                68 => "Cannot set auxiliary analog output with cutter radius compensation on",
                _ => continue,
            };
            return Err(s.invalid(col, message));
        }
        Ok(())
    }

    /// M3, M4, M5.
    #[inline]
    pub(super) fn set_spindle_direction(&mut self, codes: &Codes, s: &mut Step) {
        let Some((code, _)) = codes.m_spindle else {
            return;
        };
        let dir = match code {
            3 => SpindleState::Clockwise,
            4 => SpindleState::CounterClockwise,
            _ => SpindleState::Stopped,
        };
        self.state.spindle = dir;
        s.emit(EventKind::Spindle(dir));
    }

    /// The configured TCP M-codes (kinematics switch remaps).
    #[inline]
    pub(super) fn switch_tcp_by_m_code(&mut self, codes: &Codes, s: &mut Step) {
        let Some((code, _)) = codes.m_tcp else {
            return;
        };
        let on = Some(code) == self.opts.tcp_on_m;
        self.state.tcp = on;
        self.tcp_from_g43_4 = false;
        s.emit(EventKind::Tcp(on));
    }

    /// G4.
    pub(super) fn dwell(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        if !codes.has(GCode::G4) {
            return Ok(());
        }
        let (word, value) = match self.opts.dialect {
            Dialect::LinuxCnc => (DwellWord::PSeconds, w.get(b'P')),
            Dialect::Fanuc { .. } => match (w.get(b'X').or(w.get(b'U')), w.get(b'P')) {
                (Some(x), _) => (DwellWord::XSeconds, Some(x)),
                (None, p) => (DwellWord::PMilliseconds, p),
            },
        };
        let v = value.ok_or_else(|| s.invalid(0, "dwell time missing with G4"))?;
        if v.value < 0.0 {
            return Err(s.invalid(v.column, "negative dwell time"));
        }
        // Fanuc `G4 X` without a decimal point (and without decimal point
        // programming) is in least increments of 0.001 s, as a dimension
        // word of a metric program: `G4 X2500` is 2.5 s.
        let value = match word {
            DwellWord::XSeconds => self
                .opts
                .dialect
                .dimension(v.value, v.has_point, false, false),
            _ => v.value,
        };
        s.emit(EventKind::Dwell {
            seconds: word.seconds(value),
        });
        Ok(())
    }

    /// G17, G18, G19.
    #[inline]
    pub(super) fn set_plane(&mut self, codes: &Codes, s: &Step) -> Result<(), GcodeError> {
        if let Some((code, col)) = codes.plane {
            let plane = match code {
                GCode::G17 => Plane::Xy,
                GCode::G18 => Plane::Zx,
                _ => Plane::Yz,
            };
            if plane != self.state.plane {
                self.refuse_with_comp(
                    s,
                    col,
                    "Cannot change planes with cutter radius compensation on",
                )?;
            }
            self.state.plane = plane;
        }
        Ok(())
    }

    /// G61, G61.1, G64 with its P and Q (program units, converted to mm;
    /// absent or zero means none, as in LinuxCNC).
    #[inline]
    pub(super) fn set_path_control(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.path_control else {
            return Ok(());
        };
        self.refuse_with_comp(
            s,
            col,
            "Cannot change control mode with cutter radius compensation on",
        )?;
        let mm = self.state.units.mm_per_unit();
        let tol = |letter: u8| {
            w.get(letter)
                .map(|v| v.value * mm)
                .filter(|v| *v > 0.0 && v.is_finite())
        };
        let mode = match code {
            GCode::G61 => PathMode::ExactPath,
            GCode::G61_1 => PathMode::ExactStop,
            _ => PathMode::Blend {
                p: tol(b'P'),
                q: tol(b'Q'),
            },
        };
        s.emit(EventKind::PathControl(mode));
        Ok(())
    }

    /// G20, G21.
    #[inline]
    pub(super) fn set_length_units(&mut self, codes: &Codes, s: &mut Step) {
        if let Some((code, _)) = codes.units {
            self.state.units = if code == GCode::G20 {
                Units::Inch
            } else {
                Units::Millimetre
            };
            s.emit(EventKind::Units(self.state.units));
        }
    }

    /// Group 15: G7 (diameter mode), G8 (radius mode).
    #[inline]
    pub(super) fn set_lathe_diameter_mode(&mut self, codes: &Codes) {
        self.state.lathe_diameter = lathe_diameter_mode::mode_after(
            self.state.lathe_diameter,
            codes.lathe_diameter.map(|(c, _)| c),
        );
    }

    /// In diameter mode (after the block's G7/G8) the X word is read as half
    /// its value, and G76's I, J, K as LinuxCNC 2.9 scales them
    /// ([`lathe_diameter_mode`]).
    #[inline]
    pub(super) fn read_diameters(&self, w: &mut BlockWords, codes: &Codes) {
        let before = self.state.lathe_diameter;
        let after = lathe_diameter_mode::mode_after(before, codes.lathe_diameter.map(|(c, _)| c));
        if !before && !after {
            return;
        }
        let mut scale = |l: u8, f: f64| {
            let i = letter_slot(l);
            if w.present & (1 << i) != 0 {
                w.letters[i].value *= f;
            }
        };
        scale(b'X', lathe_diameter_mode::x_factor(after));
        if self.motion_to_be(codes) == Some(MotionMode::Threading) {
            let f = lathe_diameter_mode::threading_ijk_factor(before, after);
            for l in [b'I', b'J', b'K'] {
                scale(l, f);
            }
        }
    }

    /// G43 (H defaults to the tool in the spindle), G43.1 (dynamic: the
    /// axis words), G43.2 (added: H's tool or the axis words), G43.4 (TCP),
    /// G49.
    pub(super) fn set_tool_length_offset(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.tool_length else {
            return Ok(());
        };
        self.refuse_with_comp(
            s,
            col,
            "Cannot change tool offset with cutter radius compensation on",
        )?;
        let table_offset = |this: &Self, tool: u32| -> Result<Axes, GcodeError> {
            if tool == 0 {
                return Ok(Axes::ZERO);
            }
            this.tools
                .get(tool)
                .map(|t| t.offset)
                .ok_or_else(|| s.invalid(col, format!("tool {tool} is not in the tool table")))
        };
        let h = w
            .get(b'H')
            .map(|h| nonneg_int(*h, s.line, "H"))
            .transpose()?;
        let (axes, values) = self.axis_words(w, codes);
        let offset = match code {
            GCode::G49 => Axes::ZERO,
            // H0 is the tool in the spindle: LinuxCNC's tool index 0 is
            // the spindle's entry.
            GCode::G43 | GCode::G43_4 => match h {
                Some(0) => table_offset(self, self.spindle_entry_tool(codes))?,
                Some(tool) => table_offset(self, tool)?,
                None => table_offset(self, self.g43_default_tool(codes))?,
            },
            GCode::G43_1 => {
                let mut o = self.state.tool_offset;
                for a in axes.iter() {
                    o[a] = values[a.index()];
                }
                o
            }
            _ => {
                // G43.2
                if h.is_some() && !axes.is_empty() {
                    return Err(s.invalid(col, "G43.2: Can not have both H and axis words"));
                }
                let added = match h {
                    Some(0) => table_offset(self, self.spindle_entry_tool(codes))?,
                    Some(tool) => table_offset(self, tool)?,
                    None if axes.is_empty() => {
                        return Err(s.invalid(col, "G43.2: No axes specified and H word missing"));
                    }
                    None => {
                        let mut o = Axes::ZERO;
                        for a in axes.iter() {
                            o[a] = values[a.index()];
                        }
                        o
                    }
                };
                self.state.tool_offset.add(&added)
            }
        };
        self.state.tool_offset = offset;
        self.state.tool_length = offset[Axis::Z];
        self.apply_offsets();
        s.emit(EventKind::ToolLengthOffset {
            length: offset[Axis::Z],
        });
        let tcp = match code {
            GCode::G43_4 => Some(true),
            GCode::G49 if self.tcp_from_g43_4 => Some(false),
            _ => None,
        };
        if let Some(on) = tcp {
            self.state.tcp = on;
            self.tcp_from_g43_4 = on;
            s.emit(EventKind::Tcp(on));
        }
        Ok(())
    }

    /// G54 ... G59.3.
    pub(super) fn select_coordinate_system(
        &mut self,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.coord_system else {
            return Ok(());
        };
        self.refuse_with_comp(
            s,
            col,
            "Cannot change coordinate systems with cutter radius compensation on",
        )?;
        let system: u8 = match code {
            GCode::G54 => 1,
            GCode::G55 => 2,
            GCode::G56 => 3,
            GCode::G57 => 4,
            GCode::G58 => 5,
            GCode::G59 => 6,
            GCode::G59_1 => 7,
            GCode::G59_2 => 8,
            _ => 9,
        };
        self.state.work_system = system;
        let offset = self.state.work_offsets[usize::from(system - 1)];
        self.apply_offsets();
        s.emit(EventKind::WorkOffset {
            system,
            offset,
            rotation: self.state.rotation,
        });
        Ok(())
    }

    /// G90, G91.
    #[inline]
    pub(super) fn set_distance_mode(&mut self, codes: &Codes) {
        if let Some((code, _)) = codes.distance {
            self.state.distance = if code == GCode::G90 {
                DistanceMode::Absolute
            } else {
                DistanceMode::Incremental
            };
        }
    }

    /// G90.1, G91.1.
    #[inline]
    pub(super) fn set_arc_distance_mode(&mut self, codes: &Codes) {
        if let Some((code, _)) = codes.arc_distance {
            self.state.arc_distance = if code == GCode::G90_1 {
                DistanceMode::Absolute
            } else {
                DistanceMode::Incremental
            };
        }
    }

    /// G98, G99.
    #[inline]
    pub(super) fn set_retract_mode(&mut self, codes: &Codes, s: &Step) -> Result<(), GcodeError> {
        if let Some((code, col)) = codes.retract {
            self.refuse_with_comp(
                s,
                col,
                "Cannot change retract mode with cutter radius compensation on",
            )?;
            self.state.retract = if code == GCode::G98 {
                RetractMode::InitialLevel
            } else {
                RetractMode::RLevel
            };
        }
        Ok(())
    }
}
