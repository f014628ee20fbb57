//! The machine's axes: X and Y draw, Z lifts the pen, E drives a 3D printer's extruder.

/// Number of axes the core handles (X, Y, Z, E).
pub const NUM_AXES: usize = 4;

/// One machine axis. The discriminant is the axis index used in every per-axis array (`[T; NUM_AXES]`) and the
/// bit number in axis masks (`1 << axis as u8`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Axis {
    /// Horizontal axis.
    X = 0,
    /// Vertical (page) axis.
    Y = 1,
    /// Pen lift.
    Z = 2,
    /// Extruder (printer profile only).
    E = 3,
}

impl Axis {
    /// All axes in index order.
    pub const ALL: [Axis; NUM_AXES] = [Axis::X, Axis::Y, Axis::Z, Axis::E];

    /// Index into per-axis arrays.
    #[inline]
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Bit of this axis in an axis mask.
    #[inline]
    pub const fn bit(self) -> u8 {
        1 << (self as u8)
    }

    /// The G-code letter of the axis.
    pub const fn letter(self) -> char {
        match self {
            Axis::X => 'X',
            Axis::Y => 'Y',
            Axis::Z => 'Z',
            Axis::E => 'E',
        }
    }

    /// Axis from its index, `None` when out of range.
    pub const fn from_index(i: usize) -> Option<Axis> {
        match i {
            0 => Some(Axis::X),
            1 => Some(Axis::Y),
            2 => Some(Axis::Z),
            3 => Some(Axis::E),
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn index_bit_and_letter_agree() {
        for (i, a) in Axis::ALL.iter().enumerate() {
            assert_eq!(a.index(), i);
            assert_eq!(a.bit(), 1 << i);
            assert_eq!(Axis::from_index(i), Some(*a));
        }
        assert_eq!(Axis::from_index(4), None);
        assert_eq!(Axis::Z.letter(), 'Z');
    }
}
