//! G40, G41, G42, G41.1, G42.1: turning cutter radius compensation on and
//! off as LinuxCNC reads them (the path itself: `gcode::cutter_comp`).

use super::*;

impl Interpreter {
    /// G40, G41, G42, G41.1, G42.1: cutter radius compensation off or on,
    /// with the radius of the D word's tool (G41, G42: the tool in the
    /// spindle without D) or half the D word (G41.1, G42.1), as LinuxCNC
    /// reads them. See [`cutter_comp`].
    pub(super) fn cutter_compensation(
        &mut self,
        w: &BlockWords,
        codes: &Codes,
        s: &mut Step,
    ) -> Result<(), GcodeError> {
        let Some((code, col)) = codes.cutter_comp else {
            return Ok(());
        };
        let plane = self.state.plane;
        if code == GCode::G40 {
            return self
                .comp
                .turn_off(&mut self.state.position, plane, s.out, s.line, col);
        }
        if let Dialect::Fanuc { .. } = self.opts.dialect {
            return Err(GcodeError::unsupported(
                s.line,
                col,
                format!(
                    "cutter radius compensation {code} in the Fanuc dialect (its offset numbers \
                     and start-up rules are not LinuxCNC's)"
                ),
            ));
        }
        if self.state.rotation != 0.0 {
            return Err(GcodeError::unsupported(
                s.line,
                col,
                format!(
                    "cutter radius compensation {code} in a rotated coordinate system (G10 L2 R)"
                ),
            ));
        }
        self.comp.check_turn_on(plane, s.line, col)?;
        let left = matches!(code, GCode::G41 | GCode::G41_1);
        let name = if left { 41 } else { 42 };
        let (radius, orientation) = if matches!(code, GCode::G41_1 | GCode::G42_1) {
            let d = w
                .get(b'D')
                .ok_or_else(|| s.invalid(col, format!("G{name}.1 with no D word")))?;
            let orientation = match w.get(b'L') {
                None => 0,
                Some(l) => {
                    if plane != Plane::Zx {
                        return Err(s.invalid(
                            l.column,
                            format!("G{name}.1 with L word, but plane is not G18"),
                        ));
                    }
                    cutter_comp::lathe_orientation(l.value).map_err(|m| s.invalid(l.column, m))?
                }
            };
            (d.value / 2.0 * self.state.units.mm_per_unit(), orientation)
        } else {
            let (tool, column) = match w.get(b'D') {
                None => (self.spindle_entry_tool(codes), col),
                Some(d) => {
                    // LinuxCNC: the nearest integer, within 0.0001.
                    let t = (d.value + 0.5).trunc();
                    if (t - d.value).abs() >= 0.0001 {
                        return Err(s.invalid(
                            d.column,
                            format!("G{name} requires D word to be a whole number"),
                        ));
                    }
                    if t < 0.0 {
                        return Err(s.invalid(d.column, "Negative d word tool radius index used"));
                    }
                    if t > f64::from(u32::MAX) {
                        return Err(s.invalid(
                            d.column,
                            format!("Requested tool {t} not found in the tool table"),
                        ));
                    }
                    // D0: the tool in the spindle.
                    match t as u32 {
                        0 => (self.spindle_entry_tool(codes), d.column),
                        t => (t, d.column),
                    }
                }
            };
            let (diameter, orientation) = if tool == 0 {
                (0.0, 0)
            } else {
                let t = self.tools.get(tool).ok_or_else(|| {
                    s.invalid(
                        column,
                        format!("Requested tool {tool} not found in the tool table"),
                    )
                })?;
                (t.diameter, t.orientation)
            };
            if orientation != 0 && orientation != 9 && plane != Plane::Zx {
                return Err(s.invalid(
                    col,
                    format!("G{name} with lathe tool, but plane is not G18"),
                ));
            }
            (diameter / 2.0, orientation)
        };
        let side = if left { Side::Left } else { Side::Right };
        self.comp.turn_on(side, radius, orientation, plane);
        Ok(())
    }
}
