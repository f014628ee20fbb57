//! The G-code word parser both imports share — the drawing import ([`super::gcode_in`]) and the print import
//! ([`super::gcode_print`]): comments and checksums stripped, a line split into letter/number words, G and M codes
//! read as whole tenths, and the errors, warnings and input echoes they report.
//!
//! The firmware's parser (`plotter_fw::gcode`) is the no_std one the machine runs: exact fixed-point numbers in
//! millionths, no exponents (a number run into `E` is refused), its own line number and checksum check. The host
//! imports read files from other tools and keep f64 values, accept exponent notation on a plotter (scripts print
//! floats that way) and report a number run into `E` as Marlin reads it; they share the firmware's one rule for
//! that case ([`plotter_fw::gcode::runs_into_e`]) and its command letters.

/// Errors importing G-code.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GcodeError {
    /// A command this importer does not understand and cannot safely skip.
    #[error("{origin}:{line}: unsupported command {word}: {why}")]
    Unsupported {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// The word, e.g. `G18`.
        word: String,
        /// Why it cannot be skipped.
        why: &'static str,
    },
    /// The line does not parse or is inconsistent.
    #[error("{origin}:{line}: {message}")]
    Malformed {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// Something the importer skipped or assumed; the drawing is still usable.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GcodeWarning {
    /// First line (1-based) where it happened, 0 when it concerns the whole file.
    pub line: usize,
    /// How many times it happened.
    pub count: usize,
    /// What was skipped or assumed.
    pub message: String,
}

impl std::fmt::Display for GcodeWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line > 0 {
            write!(f, "line {}: ", self.line)?;
        }
        write!(f, "{}", self.message)?;
        if self.count > 1 { write!(f, " ({} times)", self.count) } else { Ok(()) }
    }
}

/// One parsed word: letter and value with its source text.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Word<'t> {
    pub(crate) letter: char,
    pub(crate) value: f64,
    pub(crate) text: &'t str,
    /// The number runs straight into an `E` word (`X1E5`): exponent or extrusion, the caller decides how to
    /// report it (see [`Exponents`]).
    pub(crate) runs_into_e: bool,
}

/// How [`words`] reads a letter `e`/`E` right after the digits of a number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Exponents {
    /// No extruder (a plotter profile): `1e-05`, `3.5e1`, `2E1` are numbers in exponent notation, which is what
    /// scripts printing floats write.
    Numbers,
    /// An extruder (a printer profile): `E` starts a word, as in Marlin, so `X1E5` is X1 and E5 — but it is flagged
    /// ([`Word::runs_into_e`]), because a script may have meant 1·10⁵.
    EWords,
}

/// Letters whose numbers are command codes (`G1`, `M104`, `T0`, `N12`): never exponents, so `G1E5` is G1 and E5
/// without doubt (as in the firmware's parser, `plotter_fw::gcode`).
const CODE_LETTERS: &[u8] = b"GMNT";

/// Longest piece of input echoed in a message, characters.
const ECHO_MAX: usize = 40;

/// A number as shown in a message: plain when short (`2539999974.6`), in exponent notation otherwise (`3.4e38`,
/// `1e-300`), so no value prints as hundreds of digits.
pub(crate) fn num(v: f64) -> String {
    let plain = v.to_string();
    if plain.len() <= 24 { plain } else { format!("{v:e}") }
}

/// `text` as echoed in an error or warning: at most [`ECHO_MAX`] characters, then `…` (a 1 MB number must not
/// become a 1 MB message).
pub(crate) fn echo(text: &str) -> String {
    match text.char_indices().nth(ECHO_MAX) {
        Some((cut, _)) => format!("{}…", &text[..cut]),
        None => text.to_string(),
    }
}

pub(crate) fn strip_comments(line: &str) -> String {
    let mut out = String::with_capacity(line.len());
    let mut in_paren = false;
    for c in line.chars() {
        match c {
            '(' => in_paren = true,
            ')' if in_paren => in_paren = false,
            ';' if !in_paren => break,
            '*' if !in_paren => break, // checksum follows
            _ if !in_paren => out.push(c),
            _ => {}
        }
    }
    out
}

/// Split a line (comments stripped) into words. Numbers are decimals; whether `e`/`E` after one is an exponent or
/// the next word is `exponents`' choice. A number beyond `f64` (`X1e400`, a run of 400 digits) is a range error.
pub(crate) fn words<'t>(
    code: &'t str,
    origin: &str,
    line: usize,
    exponents: Exponents,
) -> Result<Vec<Word<'t>>, GcodeError> {
    let bytes = code.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        if c.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        if !c.is_ascii_alphabetic() {
            return Err(GcodeError::Malformed {
                origin: origin.into(),
                line,
                message: format!("unexpected character {:?}", char::from(c)),
            });
        }
        let start = i;
        i += 1;
        while i < bytes.len() && bytes[i].is_ascii_whitespace() {
            i += 1;
        }
        let num_start = i;
        while i < bytes.len() && (bytes[i].is_ascii_digit() || matches!(bytes[i], b'+' | b'-' | b'.')) {
            i += 1;
        }
        let letter = char::from(c).to_ascii_uppercase();
        let after_number = i > num_start && !CODE_LETTERS.contains(&c.to_ascii_uppercase());
        let mut runs_into_e = false;
        if after_number && plotter_fw::gcode::runs_into_e(&bytes[i..]) {
            let sign = usize::from(matches!(bytes.get(i + 1), Some(b'+' | b'-')));
            let exponent_digits = bytes[i + 1 + sign..].iter().take_while(|b| b.is_ascii_digit()).count();
            if exponents == Exponents::Numbers && exponent_digits > 0 {
                i += 1 + sign + exponent_digits;
            } else {
                runs_into_e = true;
            }
        }
        let num = &code[num_start..i];
        let value = match num.parse::<f64>() {
            Ok(v) if v.is_finite() => v,
            Ok(_) => {
                return Err(GcodeError::Malformed {
                    origin: origin.into(),
                    line,
                    message: format!("{letter}{}: number out of range", echo(num)),
                });
            }
            Err(_) => {
                return Err(GcodeError::Malformed {
                    origin: origin.into(),
                    line,
                    message: format!("{letter} needs a number, found {:?}", echo(num)),
                });
            }
        };
        out.push(Word { letter, value, text: code[start..i].trim(), runs_into_e });
    }
    Ok(out)
}

/// Add a warning, or count one more occurrence of the same message (reported with its first line).
pub(crate) fn record_warning(warnings: &mut Vec<GcodeWarning>, line: usize, message: String) {
    if let Some(w) = warnings.iter_mut().find(|w| w.message == message) {
        w.count += 1;
    } else {
        warnings.push(GcodeWarning { line, count: 1, message });
    }
}

/// A G/M code times ten (`G92.1` → 921), saturating far outside the codes in use.
pub(crate) fn code10(v: f64) -> i64 {
    // Clamped to a small range first, so the conversion is exact.
    #[allow(clippy::cast_possible_truncation)]
    let c = (v * 10.0).round().clamp(-1e6, 1e6) as i64;
    c
}
