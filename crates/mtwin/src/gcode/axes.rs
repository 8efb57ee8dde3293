//! Axis names and per-axis values.

use std::ops::{Index, IndexMut};

use crate::model::Machine;

/// Why a machine's axes do not map one to one onto G-code axis words.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum AxisLetterError {
    /// A machine axis name is not a G-code axis letter.
    #[error("machine axis '{0}' has no G-code letter (name axes X Y Z A B C U V W)")]
    NotALetter(String),
    /// Two machine axes read as the same G-code letter (`x` and `X`).
    #[error("machine axes '{first}' and '{second}' are both G-code letter {letter}")]
    Twice {
        /// The earlier axis, in machine axis order.
        first: String,
        /// The later axis.
        second: String,
        /// The letter both stand for.
        letter: char,
    },
}

/// A machine axis addressed by a G-code word. X Y Z U V W are linear (mm),
/// A B C rotary (degree).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Axis {
    /// Linear X, mm.
    X,
    /// Linear Y, mm.
    Y,
    /// Linear Z, mm.
    Z,
    /// Rotary A (about X), degree.
    A,
    /// Rotary B (about Y), degree.
    B,
    /// Rotary C (about Z), degree.
    C,
    /// Linear U (parallel to X), mm.
    U,
    /// Linear V (parallel to Y), mm.
    V,
    /// Linear W (parallel to Z), mm.
    W,
}

impl Axis {
    /// All axes in canonical order (the order of LinuxCNC's canon calls).
    pub const ALL: [Axis; 9] = [
        Axis::X,
        Axis::Y,
        Axis::Z,
        Axis::A,
        Axis::B,
        Axis::C,
        Axis::U,
        Axis::V,
        Axis::W,
    ];

    /// Position in [`Axis::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The axis a word letter addresses (case-insensitive), if any.
    pub fn from_letter(letter: u8) -> Option<Axis> {
        Some(match letter.to_ascii_uppercase() {
            b'X' => Axis::X,
            b'Y' => Axis::Y,
            b'Z' => Axis::Z,
            b'A' => Axis::A,
            b'B' => Axis::B,
            b'C' => Axis::C,
            b'U' => Axis::U,
            b'V' => Axis::V,
            b'W' => Axis::W,
            _ => return None,
        })
    }

    /// The axis a machine axis name stands for: a one-letter name that is a word
    /// letter (case-insensitive), else `None`.
    pub fn from_name(name: &str) -> Option<Axis> {
        match name.as_bytes() {
            [b] => Axis::from_letter(*b),
            _ => None,
        }
    }

    /// The G-code axis of every axis of `machine`, in machine axis order: every name
    /// must be a word letter, and no two may name the same one (`x` and `X`).
    pub fn of_machine(machine: &Machine) -> Result<Vec<Axis>, AxisLetterError> {
        let mut letters = Vec::with_capacity(machine.axes.len());
        for (i, a) in machine.axes.iter().enumerate() {
            let g = Axis::from_name(&a.name)
                .ok_or_else(|| AxisLetterError::NotALetter(a.name.clone()))?;
            if let Some(j) = letters.iter().position(|&h| h == g) {
                return Err(AxisLetterError::Twice {
                    first: machine.axes[j].name.clone(),
                    second: machine.axes[i].name.clone(),
                    letter: char::from(g.letter()),
                });
            }
            letters.push(g);
        }
        Ok(letters)
    }

    /// Upper-case word letter of the axis.
    pub const fn letter(self) -> u8 {
        b"XYZABCUVW"[self as usize]
    }

    /// Rotary axes (A, B, C) are in degrees and are not scaled by G20.
    pub const fn is_rotary(self) -> bool {
        matches!(self, Axis::A | Axis::B | Axis::C)
    }
}

/// One value per axis, indexed by [`Axis`]; positions in mm (linear) and
/// degree (rotary) unless a field's documentation says otherwise.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Axes(pub [f64; 9]);

impl Axes {
    /// All axes at zero.
    pub const ZERO: Axes = Axes([0.0; 9]);

    /// Component-wise sum.
    pub fn add(&self, other: &Axes) -> Axes {
        Axes(std::array::from_fn(|i| self.0[i] + other.0[i]))
    }

    /// Component-wise difference `self - other`.
    pub fn sub(&self, other: &Axes) -> Axes {
        Axes(std::array::from_fn(|i| self.0[i] - other.0[i]))
    }

    /// Euclidean length of the X Y Z components.
    pub fn xyz_norm(&self) -> f64 {
        (self.0[0].powi(2) + self.0[1].powi(2) + self.0[2].powi(2)).sqrt()
    }

    /// Euclidean length of the U V W components.
    pub fn uvw_norm(&self) -> f64 {
        (self.0[6].powi(2) + self.0[7].powi(2) + self.0[8].powi(2)).sqrt()
    }

    /// Euclidean length of the A B C components (degree).
    pub fn abc_norm(&self) -> f64 {
        (self.0[3].powi(2) + self.0[4].powi(2) + self.0[5].powi(2)).sqrt()
    }

    /// X Y Z as an array.
    pub fn xyz(&self) -> [f64; 3] {
        [self.0[0], self.0[1], self.0[2]]
    }
}

impl Index<Axis> for Axes {
    type Output = f64;
    fn index(&self, axis: Axis) -> &f64 {
        &self.0[axis.index()]
    }
}

impl IndexMut<Axis> for Axes {
    fn index_mut(&mut self, axis: Axis) -> &mut f64 {
        &mut self.0[axis.index()]
    }
}

/// A set of axes (which axis words a block programmed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub struct AxisMask(u16);

impl AxisMask {
    /// The empty set.
    pub const EMPTY: AxisMask = AxisMask(0);

    /// All nine axes X Y Z A B C U V W.
    pub const ALL: AxisMask = AxisMask((1 << 9) - 1);

    /// Adds an axis.
    pub fn insert(&mut self, axis: Axis) {
        self.0 |= 1 << axis.index();
    }

    /// Whether the axis is in the set.
    pub fn contains(self, axis: Axis) -> bool {
        self.0 & (1 << axis.index()) != 0
    }

    /// Whether no axis is in the set.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The axes in the set, in canonical order.
    pub fn iter(self) -> impl Iterator<Item = Axis> {
        Axis::ALL.into_iter().filter(move |a| self.contains(*a))
    }

    /// The axes in both sets.
    pub fn intersection(self, other: AxisMask) -> AxisMask {
        AxisMask(self.0 & other.0)
    }

    /// The G-code axes of a machine model: each axis whose name is a word
    /// letter (`x`, `Y`, ...). A name that is no letter adds nothing (the
    /// interpolator refuses such a machine with its own message).
    pub fn of_machine(machine: &Machine) -> AxisMask {
        let mut m = AxisMask::EMPTY;
        for a in &machine.axes {
            if let Some(g) = Axis::from_name(&a.name) {
                m.insert(g);
            }
        }
        m
    }

    /// The axes of a LinuxCNC INI file, read as LinuxCNC's task reads them
    /// at start: every letter of `[TRAJ] COORDINATES` that names an axis
    /// (any case; repeated letters of gantry joints count once); a `[TRAJ]`
    /// section without `COORDINATES` is an X Y Z machine. `None` when the
    /// file has no `[TRAJ]` section (an INI given only for its parameters,
    /// remaps or subroutine path describes no machine). `[KINS]` sets the
    /// joints of the kinematics, not the axes a program may name.
    pub fn of_linuxcnc_ini(text: &str) -> Option<AxisMask> {
        let ini = super::linuxcnc_ini::LinuxcncIni::parse(text);
        if !ini.has_section("TRAJ") {
            return None;
        }
        let mut m = AxisMask::EMPTY;
        for b in ini.get("TRAJ", "COORDINATES").unwrap_or("X Y Z").bytes() {
            if let Some(a) = Axis::from_letter(b) {
                m.insert(a);
            }
        }
        Some(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::read_machine;

    fn letters(m: AxisMask) -> String {
        m.iter().map(|a| char::from(a.letter())).collect()
    }

    #[test]
    fn axis_mask_of_a_machine_and_of_a_linuxcnc_ini() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/machines/ac-trunnion.toml");
        let m = read_machine(&path).expect("example machine reads");
        assert_eq!(letters(AxisMask::of_machine(&m)), "XYZAC");
        // A gantry's doubled letter counts once, any case, other characters ignored.
        let ini = "[EMC]\nCOORDINATES = Q\n[TRAJ]\nCOORDINATES = x Y YZ w\nCOORDINATES = A\n";
        assert_eq!(
            AxisMask::of_linuxcnc_ini(ini).map(letters).as_deref(),
            Some("XYZW")
        );
        // [TRAJ] without COORDINATES: LinuxCNC's X Y Z machine.
        let xyz = "[TRAJ]\nLINEAR_UNITS = mm\n";
        assert_eq!(
            AxisMask::of_linuxcnc_ini(xyz).map(letters).as_deref(),
            Some("XYZ")
        );
        // No [TRAJ]: the INI describes no machine.
        assert_eq!(
            AxisMask::of_linuxcnc_ini("[RS274NGC]\nSUBROUTINE_PATH = s\n"),
            None
        );
        let both = AxisMask::of_machine(&m).intersection(AxisMask::of_linuxcnc_ini(ini).unwrap());
        assert_eq!(letters(both), "XYZ");
    }

    #[test]
    fn machine_axes_map_one_to_one_onto_letters() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../examples/machines/ac-trunnion.toml");
        let m = read_machine(&path).expect("example machine reads");
        let letters = Axis::of_machine(&m).expect("X Y Z A C");
        let names: Vec<String> = letters
            .iter()
            .map(|g| char::from(g.letter()).to_string())
            .collect();
        assert_eq!(names, m.axis_names());
        assert_eq!(Axis::from_name("c"), Some(Axis::C));
        assert_eq!(Axis::from_name("XX"), None);
        assert_eq!(Axis::from_name(""), None);

        let mut q = m.clone();
        q.axes[1].name = "Q".into();
        assert_eq!(
            Axis::of_machine(&q),
            Err(AxisLetterError::NotALetter("Q".into()))
        );
        let mut twice = m.clone();
        let x = twice.axes.iter().position(|a| a.name == "X").expect("X");
        let other = (x + 1) % twice.axes.len();
        twice.axes[other].name = "x".into();
        let (first, second) = if x < other { ("X", "x") } else { ("x", "X") };
        assert_eq!(
            Axis::of_machine(&twice),
            Err(AxisLetterError::Twice {
                first: first.into(),
                second: second.into(),
                letter: 'X',
            })
        );
    }
}
