//! The parameter store of RS-274/NGC as LinuxCNC 2.9 keeps it (its G-code
//! manual, chapter "Parameters"):
//!
//! * numbered parameters `#1` … `#5601` (LinuxCNC's `RS274NGC_MAX_PARAMETERS`
//!   is 5602, exclusive); an unset one reads 0. `#1`–`#30` carry subroutine
//!   arguments and are saved and restored around every call. `#5161`–`#5390`
//!   (G28/G30 homes, G92 offsets, the nine work coordinate systems) are the
//!   persistent ones LinuxCNC keeps in its var file (see [`super::var_file`]).
//! * named local parameters `#<name>`: local to the subroutine call (or to the
//!   main program) that set them; reading one that was never set is an error.
//! * named global parameters `#<_name>` (leading underscore): visible
//!   everywhere. `#<_value>` and `#<_value_returned>` are 0 at start and
//!   set by every `return` / `endsub` (the value, or 0 when none is
//!   returned; LinuxCNC 2.9). The predefined read-only globals `#<_vmajor>`
//!   (2) and `#<_vminor>` (9) are provided, `#<_x>` … `#<_w>` (the
//!   current point, read only: `#5420` … `#5428`) and `#<_line>` (the
//!   number of the line being read in its file, 1-based: LinuxCNC's
//!   sequence number, read only); LinuxCNC's other predefined state
//!   parameters (`#<_feed>`, `#<_motion_mode>`, ...) are not, and reading
//!   one is the "not defined" error.
//! * `#5161`–`#5413` (homes, G92 and work offsets, coordinate system, the
//!   tool in the spindle) and `#5420`–`#5428` (current point) are written by
//!   the interpreter from its state, as LinuxCNC does (see
//!   [`is_state_parameter`]).
//! * INI values `#<_ini[section]name>` (read only): the number of entry
//!   `NAME` in the first `[SECTION]` of the INI file given with
//!   [`Parameters::load_ini`], section and name upper-cased as LinuxCNC
//!   looks them up; an entry that is missing or not a plain number is "not
//!   defined", as in LinuxCNC.
//!
//! Names are read as LinuxCNC reads them: case-insensitive, spaces and tabs
//! inside `<>` removed.

use std::collections::{BTreeSet, HashMap};

/// Exclusive upper bound of numbered parameters (LinuxCNC
/// `RS274NGC_MAX_PARAMETERS`): valid numbers are 1 … 5601.
pub const MAX_NUMBERED: u32 = 5602;

/// The numbered parameters LinuxCNC writes to its var file even when the file
/// did not list them: G28 home (5161–5169), G30 home (5181–5189), G92 offsets
/// and their enable flag (5210–5219), the selected coordinate system (5220)
/// and the nine coordinate systems (5221–5390, 20 apart).
pub fn is_required_persistent(n: u32) -> bool {
    matches!(n, 5161..=5169 | 5181..=5189 | 5210..=5219 | 5220)
        || ((5221..=5390).contains(&n) && (n - 5221) % 20 < 9)
}

/// Number of subroutine argument parameters (`#1`–`#30`).
pub const SUB_ARGS: usize = 30;

/// The numbered parameters the interpreter keeps from its state, as
/// LinuxCNC 2.9 does: G28/G30 homes (5161–5169, 5181–5189), G92 offsets and
/// their enable flag (5210–5219), the selected coordinate system (5220), the
/// nine coordinate systems with their rotation (5221 + 20·k … 5230 + 20·k),
/// the tool in the spindle and its tool table entry (5400–5413) and the
/// current point (5420–5428).
pub fn is_state_parameter(n: u32) -> bool {
    matches!(n, 5161..=5169 | 5181..=5189 | 5210..=5220 | 5400..=5413 | 5420..=5428)
        || ((5221..=5390).contains(&n) && (n - 5221) % 20 < 10)
}

/// Why a parameter cannot be read or written (LinuxCNC's wording).
#[derive(Debug, Clone, PartialEq)]
pub enum ParamError {
    /// A numbered parameter outside 1 … 5601.
    OutOfRange(f64),
    /// A parameter number that is not an integer.
    NotInteger(f64),
    /// A named parameter read before it was set.
    Undefined(String),
    /// A write to a read-only parameter.
    ReadOnly(String),
}

impl std::fmt::Display for ParamError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ParamError::OutOfRange(n) => write!(
                f,
                "Parameter number out of range: #{n} (valid: 1 to {})",
                MAX_NUMBERED - 1
            ),
            ParamError::NotInteger(n) => write!(f, "Parameter number is not an integer: #{n}"),
            ParamError::Undefined(name) => write!(f, "Named parameter #<{name}> not defined"),
            ParamError::ReadOnly(name) => {
                write!(f, "Cannot assign to read-only parameter #<{name}>")
            }
        }
    }
}

/// The normalised form of a parameter name: lower case, blanks removed.
pub fn normalise_name(raw: &str) -> String {
    raw.chars()
        .filter(|c| !matches!(c, ' ' | '\t'))
        .flat_map(char::to_lowercase)
        .collect()
}

/// Read-only predefined globals and their values.
const PREDEFINED: [(&str, f64); 2] = [("_vmajor", 2.0), ("_vminor", 9.0)];

/// Read-only predefined globals of the current point and the numbered
/// parameter each reads (LinuxCNC: `#<_x>` is `#5420`, … `#<_w>` `#5428`).
const CURRENT_POINT: [(&str, u32); 9] = [
    ("_x", 5420),
    ("_y", 5421),
    ("_z", 5422),
    ("_a", 5423),
    ("_b", 5424),
    ("_c", 5425),
    ("_u", 5426),
    ("_v", 5427),
    ("_w", 5428),
];

/// Numbered, named local and named global parameters (values in program
/// units where they are lengths, as LinuxCNC keeps them).
#[derive(Debug, Clone, PartialEq)]
pub struct Parameters {
    numbered: Vec<f64>,
    globals: HashMap<String, f64>,
    /// Locals of the main program (index 0) and of each active call.
    locals: Vec<HashMap<String, f64>>,
    /// Numbers listed in the var file read at start: written back with the
    /// required persistent ones (LinuxCNC keeps every parameter its var file
    /// lists).
    listed: BTreeSet<u32>,
    /// INI values by `SECTION]NAME` (upper case): the numeric entries of the
    /// first section of each name.
    ini: HashMap<String, f64>,
    /// `#<_line>`: the 1-based number of the line being read in its file
    /// (0 before the first).
    line: f64,
}

impl Default for Parameters {
    fn default() -> Self {
        Parameters {
            numbered: vec![0.0; MAX_NUMBERED as usize],
            // LinuxCNC starts with both return globals at 0.
            globals: HashMap::from([
                ("_value".to_string(), 0.0),
                ("_value_returned".to_string(), 0.0),
            ]),
            locals: vec![HashMap::new()],
            listed: BTreeSet::new(),
            ini: HashMap::new(),
            line: 0.0,
        }
    }
}

impl Parameters {
    /// All numbered parameters 0, no named ones.
    pub fn new() -> Self {
        Self::default()
    }

    /// The index of a numbered parameter given as a value (LinuxCNC accepts
    /// a number within 0.0001 of an integer).
    pub fn index(n: f64) -> Result<u32, ParamError> {
        let r = n.round();
        if (n - r).abs() > 1e-4 {
            return Err(ParamError::NotInteger(n));
        }
        if !(1.0..f64::from(MAX_NUMBERED)).contains(&r) {
            return Err(ParamError::OutOfRange(n));
        }
        Ok(r as u32)
    }

    /// Value of numbered parameter `n` (1 … 5601).
    pub fn get(&self, n: u32) -> f64 {
        self.numbered.get(n as usize).copied().unwrap_or(0.0)
    }

    /// Sets a numbered parameter the interpreter keeps from its state
    /// (see [`is_state_parameter`]); `n` must be 1 … 5601.
    pub(crate) fn set_state(&mut self, n: u32, value: f64) {
        self.numbered[n as usize] = value;
    }

    /// Sets `#<_line>`, the 1-based number of the line being read in its
    /// file (LinuxCNC's sequence number), before the line's values are read.
    pub(crate) fn set_line(&mut self, line: u64) {
        self.line = line as f64;
    }

    /// Sets numbered parameter `n`; `n` outside 1 … 5601 is an error.
    pub fn set(&mut self, n: u32, value: f64) -> Result<(), ParamError> {
        if n == 0 || n >= MAX_NUMBERED {
            return Err(ParamError::OutOfRange(f64::from(n)));
        }
        self.numbered[n as usize] = value;
        Ok(())
    }

    /// Makes the entries of an INI file (its text) readable as
    /// `#<_ini[section]name>`, replacing those of an earlier one. Lines are
    /// `[SECTION]` headers and `NAME = VALUE` entries; lines starting with
    /// `#` or `;` are comments. Only the first section of a name is read
    /// and, in it, the first entry of a name (LinuxCNC's INI lookup); only
    /// values that are a plain decimal number (an exponent allowed) are
    /// kept.
    pub fn load_ini(&mut self, text: &str) {
        self.ini.clear();
        for (section, key, value) in super::linuxcnc_ini::LinuxcncIni::parse(text).entries() {
            let plain = !value.is_empty()
                && value
                    .bytes()
                    .all(|c| c.is_ascii_digit() || matches!(c, b'+' | b'-' | b'.' | b'e' | b'E'));
            let number = value.parse::<f64>().ok().filter(|v| plain && v.is_finite());
            // The first entry of a name counts even when it is not a number.
            self.ini
                .insert(format!("{section}]{key}"), number.unwrap_or(f64::NAN));
        }
    }

    /// The INI value behind a normalised `_ini[section]name` parameter name.
    fn ini_value(&self, name: &str) -> Option<Result<f64, ParamError>> {
        let rest = name.strip_prefix("_ini[")?;
        let undefined = || ParamError::Undefined(name.to_string());
        let Some((section, key)) = rest.split_once(']') else {
            return Some(Err(undefined()));
        };
        let k = format!("{}]{}", section.to_uppercase(), key.to_uppercase());
        Some(
            self.ini
                .get(&k)
                .copied()
                .filter(|v| v.is_finite())
                .ok_or_else(undefined),
        )
    }

    /// Value of a named parameter (name already normalised).
    pub fn get_named(&self, name: &str) -> Result<f64, ParamError> {
        if let Some(&(_, v)) = PREDEFINED.iter().find(|(n, _)| *n == name) {
            return Ok(v);
        }
        if let Some(&(_, n)) = CURRENT_POINT.iter().find(|(c, _)| *c == name) {
            return Ok(self.get(n));
        }
        if name == "_line" {
            return Ok(self.line);
        }
        if let Some(v) = self.ini_value(name) {
            return v;
        }
        let found = if name.starts_with('_') {
            self.globals.get(name)
        } else {
            self.locals.last().and_then(|l| l.get(name))
        };
        found
            .copied()
            .ok_or_else(|| ParamError::Undefined(name.to_string()))
    }

    /// Whether a named parameter (name already normalised) is defined
    /// (`EXISTS[#<name>]`).
    pub fn exists(&self, name: &str) -> bool {
        self.get_named(name).is_ok()
    }

    /// Sets a named parameter (name already normalised): a global when it
    /// starts with `_`, else a local of the current call.
    pub fn set_named(&mut self, name: &str, value: f64) -> Result<(), ParamError> {
        if PREDEFINED.iter().any(|(n, _)| *n == name)
            || CURRENT_POINT.iter().any(|(n, _)| *n == name)
            || name == "_line"
            || name.starts_with("_ini[")
        {
            return Err(ParamError::ReadOnly(name.to_string()));
        }
        if name.starts_with('_') {
            self.globals.insert(name.to_string(), value);
        } else if let Some(l) = self.locals.last_mut() {
            l.insert(name.to_string(), value);
        }
        Ok(())
    }

    /// Enters a subroutine: saves `#1`–`#30` (returned), sets them to
    /// `args` (missing ones 0) and opens a fresh local scope.
    pub fn enter_call(&mut self, args: &[f64]) -> [f64; SUB_ARGS] {
        let mut saved = [0.0; SUB_ARGS];
        saved.copy_from_slice(&self.numbered[1..=SUB_ARGS]);
        for (k, slot) in self.numbered[1..=SUB_ARGS].iter_mut().enumerate() {
            *slot = args.get(k).copied().unwrap_or(0.0);
        }
        self.locals.push(HashMap::new());
        saved
    }

    /// Leaves a subroutine: restores `#1`–`#30` and drops its locals.
    pub fn leave_call(&mut self, saved: &[f64; SUB_ARGS]) {
        self.numbered[1..=SUB_ARGS].copy_from_slice(saved);
        if self.locals.len() > 1 {
            self.locals.pop();
        }
    }

    /// The nine work coordinate systems G54 … G59.3 as the parameters hold
    /// them (5221 + 20·k + axis, axes in the order X Y Z A B C U V W), in the
    /// var file's length units (mm for mtwin's machines) and degrees.
    pub fn work_offsets(&self) -> [crate::gcode::Axes; 9] {
        let mut out = [crate::gcode::Axes::ZERO; 9];
        for (k, o) in out.iter_mut().enumerate() {
            for (j, axis) in crate::gcode::Axis::ALL.into_iter().enumerate() {
                o[axis] = self.get(5221 + 20 * k as u32 + j as u32);
            }
        }
        out
    }

    /// The rotations about Z of G54 … G59.3 as the parameters hold them
    /// (5230 + 20·k, G10 L2 R), degrees.
    pub fn work_rotations(&self) -> [f64; 9] {
        std::array::from_fn(|k| self.get(5230 + 20 * k as u32))
    }

    /// Marks `n` as listed in the var file (written back).
    pub(crate) fn mark_listed(&mut self, n: u32) {
        self.listed.insert(n);
    }

    /// The numbers a var file written now holds: those the read file listed
    /// and every required persistent one, ascending.
    pub fn persistent_numbers(&self) -> Vec<u32> {
        let mut all: BTreeSet<u32> = self.listed.clone();
        all.extend((1..MAX_NUMBERED).filter(|&n| is_required_persistent(n)));
        all.into_iter().collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbered_range_and_integer_rule() {
        assert_eq!(Parameters::index(5601.0), Ok(5601));
        assert_eq!(Parameters::index(1.00001), Ok(1));
        assert!(matches!(
            Parameters::index(5602.0),
            Err(ParamError::OutOfRange(_))
        ));
        assert!(matches!(
            Parameters::index(0.0),
            Err(ParamError::OutOfRange(_))
        ));
        assert!(matches!(
            Parameters::index(1.5),
            Err(ParamError::NotInteger(_))
        ));
        let mut p = Parameters::new();
        assert_eq!(p.get(31), 0.0);
        p.set(31, 2.5).unwrap();
        assert_eq!(p.get(31), 2.5);
        assert!(p.set(5602, 1.0).is_err());
    }

    /// `#<_line>` reads the line set for reading and cannot be assigned.
    #[test]
    fn line_is_a_read_only_global() {
        let mut p = Parameters::new();
        assert_eq!(p.get_named("_line"), Ok(0.0));
        p.set_line(42);
        assert_eq!(p.get_named("_line"), Ok(42.0));
        assert!(p.exists("_line"));
        assert_eq!(
            p.set_named("_line", 1.0),
            Err(ParamError::ReadOnly("_line".to_string()))
        );
    }

    #[test]
    fn names_scopes_and_calls() {
        let mut p = Parameters::new();
        assert_eq!(normalise_name("My Depth"), "mydepth");
        p.set_named("depth", 1.0).unwrap();
        p.set_named("_g", 7.0).unwrap();
        p.set(1, 11.0).unwrap();
        p.set(31, 31.0).unwrap();
        let saved = p.enter_call(&[5.0, 6.0]);
        assert_eq!((p.get(1), p.get(2), p.get(3)), (5.0, 6.0, 0.0));
        assert!(
            matches!(p.get_named("depth"), Err(ParamError::Undefined(_))),
            "locals of the caller are not visible"
        );
        assert_eq!(p.get_named("_g"), Ok(7.0));
        p.set_named("depth", 2.0).unwrap();
        p.leave_call(&saved);
        assert_eq!(p.get(1), 11.0);
        assert_eq!(p.get(31), 31.0);
        assert_eq!(p.get_named("depth"), Ok(1.0));
        assert_eq!(p.get_named("_vmajor"), Ok(2.0));
        assert!(p.set_named("_vmajor", 3.0).is_err());
        // #<_x> … #<_w> read #5420 … #5428 and are read only.
        p.set(5420, 4.5).unwrap();
        p.set(5428, -1.0).unwrap();
        assert_eq!((p.get_named("_x"), p.get_named("_w")), (Ok(4.5), Ok(-1.0)));
        assert!(p.set_named("_y", 3.0).is_err() && p.exists("_z"));
        assert!(p.exists("_g") && !p.exists("_h"));
    }

    #[test]
    fn ini_values_are_read_only_numbers_of_the_first_section() {
        let mut p = Parameters::new();
        p.load_ini(
            "[EMC]\nX = 1\n[VARS]\nTOOLCHANGE_X = 10\n  B =  -2.5  \nC = 0x10\nD = 20 ; c\n\
             E = 1.5e1\nB = 99\n; B = 7\nlower = 3\n[VARS]\nF = 4\n",
        );
        let get = |n: &str| p.get_named(&normalise_name(n));
        assert_eq!(get("_ini[vars]toolchange_x"), Ok(10.0));
        assert_eq!(get("_InI[ V ars]b"), Ok(-2.5), "the first entry of a name");
        assert_eq!(get("_ini[vars]e"), Ok(15.0));
        assert_eq!(get("_ini[emc]x"), Ok(1.0));
        for undefined in [
            "_ini[vars]c",
            "_ini[vars]d",
            "_ini[vars]lower",
            "_ini[vars]f",
            "_ini[nosuch]x",
            "_ini[vars",
        ] {
            assert!(
                matches!(get(undefined), Err(ParamError::Undefined(_))),
                "{undefined}"
            );
        }
        assert!(matches!(
            p.set_named("_ini[vars]toolchange_x", 1.0),
            Err(ParamError::ReadOnly(_))
        ));
        assert_eq!(Parameters::new().get_named("_value"), Ok(0.0));
    }

    #[test]
    fn work_offsets_come_from_5221_on() {
        let mut p = Parameters::new();
        p.set(5221, 1.0).unwrap(); // G54 X
        p.set(5243, -2.0).unwrap(); // G55 Z
        p.set(5386, 90.0).unwrap(); // G59.3 C
        let w = p.work_offsets();
        use crate::gcode::Axis;
        assert_eq!(
            (w[0][Axis::X], w[1][Axis::Z], w[8][Axis::C]),
            (1.0, -2.0, 90.0)
        );
        assert_eq!(w[0][Axis::Y], 0.0);
    }

    #[test]
    fn required_persistent_set() {
        let n: Vec<u32> = Parameters::new().persistent_numbers();
        // 9 + 9 + 10 + 1 + 9 systems × 9 axes.
        assert_eq!(n.len(), 9 + 9 + 10 + 1 + 81);
        assert_eq!(n.first(), Some(&5161));
        assert_eq!(n.last(), Some(&5389));
        assert!(n.contains(&5221) && n.contains(&5229) && !n.contains(&5230));
    }
}
