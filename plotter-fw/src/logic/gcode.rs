//! G-code line parsing: line number and checksum, comments, words with exact decimal values.
//!
//! Numbers are parsed as exact fixed-point integers in millionths ([`MICRO`] per unit), not floats: positions
//! are kept in micrometre-exact integers, so relative moves (`G91`) add up without any drift however many there
//! are, and the only rounding is the single conversion of an absolute target to whole steps.
//!
//! Exponent notation is not G-code: `E` starts the extruder word, as in Marlin. A number run straight into an `E`
//! with digits (`X1E5`, `X1e-05`) is therefore either X1 with E5 (a slicer without spaces) or 1·10⁵ (a script
//! printing floats); the line is refused as ambiguous ([`ErrorCode::AmbiguousE`]) instead of being split silently.
//! Command letters (`G1E5`) are exempt: their numbers are never written with exponents.

use crate::errors::ErrorCode;
use crate::range::MICRO;

/// XOR checksum of a G-code line (all bytes before `*`), as in RepRap firmwares.
pub fn xor_checksum(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0, |c, b| c ^ b)
}

/// Most G or M codes on one line.
pub const MAX_CODES: usize = 4;

/// The numbering wrapper of a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Envelope<'a> {
    /// `N<n>` when present.
    pub number: Option<u32>,
    /// Whether a `*<cs>` checksum was present (and correct).
    pub checked: bool,
    /// The words part (between `N<n>` and `*`).
    pub body: &'a [u8],
}

/// Why the envelope was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnvelopeError {
    /// `*<cs>` did not match the XOR of the bytes before it (or was not a number).
    Checksum,
    /// `N` without a valid number.
    BadNumber,
}

/// Split `N<n> ... *<cs>` and verify the checksum. Lines without either are passed through.
pub fn envelope(line: &[u8]) -> Result<Envelope<'_>, EnvelopeError> {
    let (content, checked) = match line.iter().rposition(|&c| c == b'*') {
        Some(star) => {
            let cs = core::str::from_utf8(&line[star + 1..])
                .ok()
                .map(str::trim)
                .and_then(|s| s.parse::<u8>().ok())
                .ok_or(EnvelopeError::Checksum)?;
            if xor_checksum(&line[..star]) != cs {
                return Err(EnvelopeError::Checksum);
            }
            (&line[..star], true)
        }
        None => (line, false),
    };
    let trimmed = trim_start(content);
    if let Some(rest) = trimmed.strip_prefix(b"N").or_else(|| trimmed.strip_prefix(b"n")) {
        let digits = rest.iter().take_while(|c| c.is_ascii_digit()).count();
        let n = core::str::from_utf8(&rest[..digits]).ok().and_then(|s| s.parse::<u32>().ok());
        let n = n.ok_or(EnvelopeError::BadNumber)?;
        return Ok(Envelope { number: Some(n), checked, body: &rest[digits..] });
    }
    Ok(Envelope { number: None, checked, body: content })
}

fn trim_start(s: &[u8]) -> &[u8] {
    let skip = s.iter().take_while(|c| c.is_ascii_whitespace()).count();
    &s[skip..]
}

/// The words of one line: G and M codes in order, every other letter at most once.
///
/// An axis letter without a number (`G28 X`: home X only, as in grbl and Marlin) is accepted on a line with `G28`
/// only; it is present ([`Words::has`]) but has no value ([`Words::get`]).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Words {
    /// G codes (integer codes only).
    pub g: heapless::Vec<u16, MAX_CODES>,
    /// M codes.
    pub m: heapless::Vec<u16, MAX_CODES>,
    present: u32,
    bare: u32,
    values: [i64; 26],
}

/// Letters that may stand without a number (axis flags of `G28`).
const BARE_LETTERS: &[u8] = b"XYZE";

impl Words {
    /// Value of `letter` (uppercase) in millionths, when present with a number.
    pub fn get(&self, letter: u8) -> Option<i64> {
        let i = usize::from(letter.checked_sub(b'A')?);
        (i < 26 && (self.present & !self.bare) & (1 << i) != 0).then(|| self.values[i])
    }

    /// Whether `letter` is present (with or without a number).
    pub fn has(&self, letter: u8) -> bool {
        letter.checked_sub(b'A').is_some_and(|i| i < 26 && self.present & (1 << i) != 0)
    }

    /// Mask of present letters other than G and M (bit `letter - 'A'`).
    pub fn letters(&self) -> u32 {
        self.present
    }
}

/// A parse failure with the byte column (0-based in the body) where it happened.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParseError {
    /// The error class.
    pub code: ErrorCode,
    /// Column in the line body.
    pub column: usize,
}

/// Parse a decimal number (`-12.5`, `+.5`, `3.`) into millionths, rounding beyond six decimals. At most 12
/// integer digits. Returns the value and the bytes consumed.
pub fn parse_micro(s: &[u8]) -> Option<(i64, usize)> {
    let mut i = 0;
    let neg = match s.first() {
        Some(b'-') => {
            i += 1;
            true
        }
        Some(b'+') => {
            i += 1;
            false
        }
        _ => false,
    };
    let mut int: i64 = 0;
    let mut int_digits = 0;
    while let Some(&c) = s.get(i).filter(|c| c.is_ascii_digit()) {
        int = int * 10 + i64::from(c - b'0');
        int_digits += 1;
        i += 1;
        if int_digits > 12 {
            return None;
        }
    }
    let mut frac: i64 = 0;
    let mut frac_digits = 0;
    let mut round_up = false;
    if s.get(i) == Some(&b'.') {
        i += 1;
        while let Some(&c) = s.get(i).filter(|c| c.is_ascii_digit()) {
            if frac_digits < 6 {
                frac = frac * 10 + i64::from(c - b'0');
            } else if frac_digits == 6 {
                round_up = c >= b'5';
            }
            frac_digits += 1;
            i += 1;
        }
    }
    if int_digits == 0 && frac_digits == 0 {
        return None;
    }
    for _ in frac_digits.min(6)..6 {
        frac *= 10;
    }
    let v = int * MICRO + frac + i64::from(round_up);
    Some((if neg { -v } else { v }, i))
}

/// Parse the words of a line body (after [`envelope`]). Whitespace is ignored, `;` starts a comment to the end,
/// `(...)` is an inline comment. Letters are case-insensitive.
pub fn parse_words(body: &[u8]) -> Result<Words, ParseError> {
    let mut w = Words::default();
    let mut bare_column = None;
    let mut i = 0;
    while i < body.len() {
        let c = body[i];
        if c.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        if c == b';' {
            break;
        }
        if c == b'(' {
            match body[i..].iter().position(|&c| c == b')') {
                Some(end) => {
                    i += end + 1;
                    continue;
                }
                None => return Err(ParseError { code: ErrorCode::ExpectedCommand, column: i }),
            }
        }
        let letter = c.to_ascii_uppercase();
        if !letter.is_ascii_uppercase() {
            return Err(ParseError { code: ErrorCode::ExpectedCommand, column: i });
        }
        // Spaces between a letter and its number are tolerated.
        let mut j = i + 1;
        while body.get(j).is_some_and(|c| *c == b' ') {
            j += 1;
        }
        let number = body.get(j).is_some_and(|c| c.is_ascii_digit() || b"+-.".contains(c));
        if !number && BARE_LETTERS.contains(&letter) {
            // A bare axis letter (checked against G28 once the whole line is read).
            let bit = 1u32 << (letter - b'A');
            if w.present & bit != 0 {
                return Err(ParseError { code: ErrorCode::UnsupportedWord, column: i });
            }
            w.present |= bit;
            w.bare |= bit;
            bare_column.get_or_insert(i + 1);
            i = j;
            continue;
        }
        let (value, used) = parse_micro(&body[j..]).ok_or(ParseError {
            code: if !number {
                ErrorCode::ExpectedCommand
            } else if too_many_digits(&body[j..]) {
                ErrorCode::OutOfRange
            } else {
                ErrorCode::BadNumber
            },
            column: j,
        })?;
        let end = j + used;
        if !CODE_LETTERS.contains(&letter) && runs_into_e(&body[end..]) {
            // `X1E5`: Marlin reads X1 E5, a script printing floats meant 1·10⁵. Neither is guessed.
            return Err(ParseError { code: ErrorCode::AmbiguousE, column: end });
        }
        match letter {
            b'G' | b'M' => {
                let code = (value % MICRO == 0 && value >= 0)
                    .then(|| u16::try_from(value / MICRO).ok())
                    .flatten()
                    .ok_or(ParseError { code: ErrorCode::UnknownCommand, column: i })?;
                let list = if letter == b'G' { &mut w.g } else { &mut w.m };
                list.push(code).map_err(|_| ParseError { code: ErrorCode::UnsupportedWord, column: i })?;
            }
            _ => {
                let bit = 1u32 << (letter - b'A');
                if w.present & bit != 0 {
                    return Err(ParseError { code: ErrorCode::UnsupportedWord, column: i });
                }
                w.present |= bit;
                w.values[usize::from(letter - b'A')] = value;
            }
        }
        i = end;
    }
    if let Some(column) = bare_column
        && !w.g.contains(&28)
    {
        return Err(ParseError { code: ErrorCode::ExpectedCommand, column });
    }
    Ok(w)
}

/// Letters whose values are command numbers (`G1`, `M104`, `T0`, `N12`), never written with an exponent: `G1E5` is
/// G1 and E5 without doubt.
const CODE_LETTERS: &[u8] = b"GMNT";

/// Whether `s` (the bytes right after a number) starts with an `E` word's number: `e`/`E` followed by a digit, a
/// sign or a point. After a number, that is either an exponent (`1E5` = 100000, as scripts print floats) or the
/// extruder word (`X1E5` = X1 E5, as Marlin and slicers without spaces mean it).
pub fn runs_into_e(s: &[u8]) -> bool {
    matches!(s.first(), Some(b'e' | b'E')) && s.get(1).is_some_and(|c| c.is_ascii_digit() || b"+-.".contains(c))
}

/// Whether `s` starts with a number whose integer part has more digits than [`parse_micro`] takes.
fn too_many_digits(s: &[u8]) -> bool {
    let s = s.strip_prefix(b"-").or_else(|| s.strip_prefix(b"+")).unwrap_or(s);
    s.iter().take_while(|c| c.is_ascii_digit()).count() > 12
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn numbers_are_exact() {
        assert_eq!(parse_micro(b"12.5"), Some((12_500_000, 4)));
        assert_eq!(parse_micro(b"-0.001"), Some((-1000, 6)));
        assert_eq!(parse_micro(b".5X"), Some((500_000, 2)));
        assert_eq!(parse_micro(b"3."), Some((3_000_000, 2)));
        assert_eq!(parse_micro(b"0.0000015"), Some((2, 9)));
        assert_eq!(parse_micro(b"-"), None);
        assert_eq!(parse_micro(b"1234567890123"), None);
    }

    #[test]
    fn envelope_checks() {
        let line = b"N7 G1 X10";
        let cs = xor_checksum(line);
        let full = std::format!("N7 G1 X10*{cs}");
        let e = envelope(full.as_bytes()).unwrap();
        assert_eq!((e.number, e.checked, e.body), (Some(7), true, &b" G1 X10"[..]));
        let bad = std::format!("N7 G1 X11*{cs}");
        assert_eq!(envelope(bad.as_bytes()), Err(EnvelopeError::Checksum));
        assert_eq!(envelope(b"G0 X1").unwrap().number, None);
        assert_eq!(envelope(b"N G0"), Err(EnvelopeError::BadNumber));
    }

    #[test]
    fn words_and_comments() {
        let w = parse_words(b"g90 G1 x10.5 Y-2 (comment) F1200 ; rest X99").unwrap();
        assert_eq!(w.g.as_slice(), &[90, 1]);
        assert_eq!(w.get(b'X'), Some(10_500_000));
        assert_eq!(w.get(b'Y'), Some(-2_000_000));
        assert_eq!(w.get(b'F'), Some(1_200_000_000));
        assert!(!w.has(b'Z'));
        assert_eq!(parse_words(b"G1 X1 X2").unwrap_err().code, ErrorCode::UnsupportedWord);
        assert_eq!(parse_words(b"G1 X").unwrap_err(), ParseError { code: ErrorCode::ExpectedCommand, column: 4 });
        assert_eq!(parse_words(b"G0 X Y1").unwrap_err(), ParseError { code: ErrorCode::ExpectedCommand, column: 4 });
        assert_eq!(parse_words(b"G1 X1234567890123").unwrap_err().code, ErrorCode::OutOfRange);
        assert_eq!(parse_words(b"G1 X-123456789012.5").unwrap().get(b'X'), Some(-123_456_789_012_500_000));
        assert_eq!(parse_words(b"G1 X1.2.3").unwrap_err().code, ErrorCode::ExpectedCommand);
        assert_eq!(parse_words(b"G1 X--1").unwrap_err().code, ErrorCode::BadNumber);
        assert_eq!(parse_words(b"G38.2").unwrap_err().code, ErrorCode::UnknownCommand);
        assert_eq!(parse_words(b"#1").unwrap_err().code, ErrorCode::ExpectedCommand);
    }

    #[test]
    fn bare_axis_letters_only_with_g28() {
        let w = parse_words(b"G28 X").unwrap();
        assert!(w.has(b'X') && !w.has(b'Y'));
        assert_eq!(w.get(b'X'), None);
        let w = parse_words(b"g28 y z").unwrap();
        assert!(w.has(b'Y') && w.has(b'Z') && !w.has(b'X'));
        let w = parse_words(b"X G28").unwrap();
        assert!(w.has(b'X'));
        assert_eq!(parse_words(b"G28 X X").unwrap_err().code, ErrorCode::UnsupportedWord);
        assert_eq!(parse_words(b"G28 F").unwrap_err().code, ErrorCode::ExpectedCommand, "only axis letters");
        assert_eq!(parse_words(b"G28 X5").unwrap().get(b'X'), Some(5_000_000));
    }

    #[test]
    fn a_number_run_into_e_is_ambiguous() {
        // The reproducers: a Python float and an exponent that Marlin would extrude as E40.
        for (line, column) in [("G1 X1e-05", 5), ("G1 X1e40", 5), ("G1 X1E5 Y2", 5), ("G1 Y2 X-3.5e+1", 11)] {
            assert_eq!(parse_words(line.as_bytes()), Err(ParseError { code: ErrorCode::AmbiguousE, column }), "{line}");
        }
        assert_eq!(parse_words(b"G1 X.5E.5").unwrap_err().code, ErrorCode::AmbiguousE);
        // With a space, E is the extruder word; command letters are never exponents.
        let w = parse_words(b"G1 X1 E40").unwrap();
        assert_eq!((w.get(b'X'), w.get(b'E')), (Some(MICRO), Some(40 * MICRO)));
        let w = parse_words(b"G1E5").unwrap();
        assert_eq!((w.g.as_slice(), w.get(b'E')), (&[1][..], Some(5 * MICRO)));
        let w = parse_words(b"M303E0S210").unwrap();
        assert_eq!((w.get(b'E'), w.get(b'S')), (Some(0), Some(210 * MICRO)));
        // `E` not followed by a number after a value: a bare E, only valid with G28.
        assert_eq!(parse_words(b"G28 X1E").unwrap().get(b'X'), Some(MICRO));
        assert_eq!(parse_words(b"G1 X1E").unwrap_err().code, ErrorCode::ExpectedCommand);
        assert!(runs_into_e(b"e-1") && runs_into_e(b"E.5") && !runs_into_e(b"E") && !runs_into_e(b"EX"));
    }

    /// A number-like word: sign, digits (sometimes a huge run), point, fraction, exponent.
    fn number_like() -> impl Strategy<Value = std::string::String> {
        crate::testing::number_like(11..=14, 1..80)
    }

    proptest! {
        /// Random number-like words through the parser: a value exactly as the decimal grammar reads it, or a clear
        /// error at a column inside the line; never a panic, never a silently split exponent.
        #[test]
        fn number_words_give_a_value_or_a_clear_error(letter in prop::sample::select(&b"XYZEFSPR"[..]), num in number_like()) {
            let line = std::format!("G1 {}{num}", letter as char);
            match parse_words(line.as_bytes()) {
                Ok(w) => {
                    // Accepted: the whole number is one plain decimal (no exponent split off) with its exact value.
                    let (v, used) = parse_micro(num.as_bytes()).expect("an accepted word parses");
                    prop_assert_eq!(used, num.len());
                    prop_assert_eq!(w.get(letter), Some(v));
                    prop_assert!(!num.bytes().any(|c| c == b'e' || c == b'E'));
                }
                Err(e) => {
                    prop_assert!(e.column <= line.len(), "{:?} {}", e, line);
                    let ambiguous = parse_micro(num.as_bytes()).is_some_and(|(_, used)| runs_into_e(&num.as_bytes()[used..]));
                    prop_assert_eq!(e.code == ErrorCode::AmbiguousE, ambiguous, "{:?} {}", e, line);
                }
            }
        }

        #[test]
        fn decimal_round_trip(int in -999_999i64..999_999, frac in 0i64..1_000_000) {
            let s = std::format!("{}{}.{:06}", if int < 0 { "-" } else { "" }, int.abs(), frac);
            let v = int.abs() * MICRO + frac;
            prop_assert_eq!(parse_micro(s.as_bytes()), Some((if int < 0 { -v } else { v }, s.len())));
        }

        #[test]
        fn never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..100)) {
            let _ = envelope(&bytes).map(|e| parse_words(e.body));
        }
    }
}
