//! Axis names and per-axis values.

use std::ops::{Index, IndexMut};

/// A machine axis addressed by a G-code word. X Y Z U V W are linear (mm),
/// A B C rotary (degree).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Axis {
    X,
    Y,
    Z,
    A,
    B,
    C,
    U,
    V,
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
}
