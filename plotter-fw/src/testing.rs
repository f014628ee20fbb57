//! Test support shared with the host crates' property tests (feature `proptest`); no part of the firmware.

use core::ops::{Range, RangeInclusive};
use proptest::prelude::*;
use std::string::String;

/// Number-like text as a G-code word's value: sign, digits, point, fraction, exponent, each part sometimes
/// malformed (`--`, `..`, `ee`). Each digit run is short, or `long` digits, or a run of `nines` nines (to reach
/// overflow and the length limits).
pub fn number_like(long: RangeInclusive<usize>, nines: Range<usize>) -> impl Strategy<Value = String> {
    let long = proptest::string::string_regex(&std::format!("[0-9]{{{},{}}}", long.start(), long.end()))
        .expect("a digit-run pattern");
    let digits = prop_oneof![
        4 => "[0-9]{0,8}",
        1 => long,
        1 => nines.prop_map(|n| "9".repeat(n)),
    ];
    (
        prop_oneof![Just(""), Just("-"), Just("+"), Just("--"), Just("+-")],
        digits.clone(),
        prop_oneof![Just(""), Just("."), Just("..")],
        digits,
        prop_oneof![Just(""), Just("e"), Just("E"), Just("e-"), Just("E+"), Just("e."), Just("ee")],
        "[0-9]{0,4}",
    )
        .prop_map(|(s, i, p, f, e, x)| std::format!("{s}{i}{p}{f}{e}{x}"))
}
