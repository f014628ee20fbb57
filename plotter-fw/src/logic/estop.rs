//! `M112`, the emergency stop, spotted in the received bytes: it must act even while earlier lines wait (a heating
//! wait, a full planner queue), so the machine's receive path feeds every byte to an [`EmergencyParser`] and stops
//! everything the moment one fires, long before the line's turn comes.

/// Spots `M112` in the received bytes, before the line is queued: an emergency stop must act even while earlier
/// lines wait (a heating wait, a full planner queue). It accepts the line start, an optional `N<n>` line number and
/// spaces, then `M112` followed by a non-digit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct EmergencyParser {
    state: u8,
}

impl EmergencyParser {
    const START: u8 = 0;
    const NUMBER: u8 = 1;
    const SKIP: u8 = 10;

    /// A parser at a line start.
    pub const fn new() -> Self {
        EmergencyParser { state: Self::START }
    }

    /// Feed one received byte; `true` when it completed an `M112`.
    pub fn feed(&mut self, b: u8) -> bool {
        if b == b'\n' || b == b'\r' {
            let fire = self.state == 5;
            self.state = Self::START;
            return fire;
        }
        let next = match (self.state, b.to_ascii_uppercase()) {
            (Self::START, b' ') => Self::START,
            (Self::START, b'N') => Self::NUMBER,
            (Self::NUMBER, c) if c.is_ascii_digit() => Self::NUMBER,
            (Self::NUMBER, b' ') => Self::NUMBER,
            (Self::START | Self::NUMBER, b'M') => 2,
            (2, b'1') => 3,
            (3, b'1') => 4,
            (4, b'2') => 5,
            (5, c) if c.is_ascii_digit() => Self::SKIP,
            (5, _) => {
                self.state = Self::SKIP;
                return true;
            }
            _ => Self::SKIP,
        };
        self.state = next;
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn emergency_parser() {
        let fire = |s: &str| {
            let mut p = EmergencyParser::new();
            s.bytes().filter(|b| p.feed(*b)).count()
        };
        assert_eq!(fire("M112\n"), 1);
        assert_eq!(fire("N12 M112*33\n"), 1);
        assert_eq!(fire("G1 X1\nm112 ; stop\n"), 1);
        assert_eq!(fire("M1120\n"), 0);
        assert_eq!(fire("G1 M112\n"), 0);
        assert_eq!(fire("M11\n"), 0);
    }
}
