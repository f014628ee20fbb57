//! The heater identities of the printer profile: which channel a command, a reading or an alarm is about. A leaf
//! type, so the HAL ([`crate::hal::Heaters`]), the error table and the heater driver all name heaters the same way.

/// Number of heater channels.
pub const NUM_HEATERS: usize = 2;

/// A heater channel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Heater {
    /// The hot end (tool 0), sensor `T0`.
    HotEnd = 0,
    /// The heated bed, sensor `B`.
    Bed = 1,
}

impl Heater {
    /// Both channels in index order.
    pub const ALL: [Heater; NUM_HEATERS] = [Heater::HotEnd, Heater::Bed];

    /// Index into per-heater arrays.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// The name used in alarms and errors.
    pub const fn name(self) -> &'static str {
        match self {
            Heater::HotEnd => "hot end sensor T0",
            Heater::Bed => "bed sensor B",
        }
    }
}
