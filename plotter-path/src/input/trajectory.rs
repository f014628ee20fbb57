//! The seed plotter's trajectory text file: relative motor steps, trace by trace.
//!
//! Layout (whitespace-separated integers, one group per line):
//!
//! ```text
//! <number of traces>
//! <number of moves of trace 1>
//! <motor 1 (X) step counts of trace 1, one per move>
//! <motor 2 (Y) step counts of trace 1, one per move>
//! ... three lines per further trace ...
//! ```
//!
//! Every count is a signed relative step count. Move 1 of each trace is the pen-up travel from where the previous
//! trace ended (the first trace starts at the homed origin, step (0, 0)) to the trace's start; the remaining moves are
//! drawn with the pen down. A trace of one move is therefore a dot. Because the moves are the differences of
//! absolute step positions (see [`crate::geometry::steps`]), a file written here sums to exact positions and never drifts.
//!
//! Import accepts commas or tabs as separators and blank lines between traces, and reports any other deviation with
//! its line number.

use crate::geometry::steps::{MAX_STEP_COORD, StepDelta, StepDrawing, StepPos, StepStroke};

/// Errors reading a trajectory file.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TrajectoryError {
    /// A token is not an integer.
    #[error("{origin}:{line}: expected an integer, found {token:?}")]
    NotAnInteger {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// The offending token.
        token: String,
    },
    /// A line has the wrong number of values.
    #[error("{origin}:{line}: expected {expected} value(s) ({what}), found {found}")]
    Count {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// What the line holds.
        what: &'static str,
        /// Values expected.
        expected: usize,
        /// Values found.
        found: usize,
    },
    /// The file ends before all announced traces were read.
    #[error("{origin}:{line}: file ends inside trace {trace} of {traces} (expected {what})")]
    Truncated {
        /// File name.
        origin: String,
        /// Line number after the last line.
        line: usize,
        /// 1-based trace index being read.
        trace: usize,
        /// Announced number of traces.
        traces: usize,
        /// The missing line.
        what: &'static str,
    },
    /// Lines follow the last announced trace.
    #[error("{origin}:{line}: unexpected content after the {traces} announced trace(s)")]
    Trailing {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// Announced number of traces.
        traces: usize,
    },
    /// A trace has no moves (it needs at least its travel move) or a negative count.
    #[error("{origin}:{line}: a trace needs at least one move (its travel to the start), found {found}")]
    EmptyTrace {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// The count given.
        found: i64,
    },
    /// The accumulated position leaves the representable step range.
    #[error("{origin}:{line}: the position leaves the step range (±{MAX_STEP_COORD})")]
    OutOfRange {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
    },
}

/// Write `steps` as a trajectory file.
pub fn export(steps: &StepDrawing) -> String {
    use std::fmt::Write as _;
    let mut out = String::new();
    let _ = writeln!(out, "{}", steps.strokes.len());
    let mut at = StepPos::default();
    for s in &steps.strokes {
        let travel = at.delta_to(s.start);
        let _ = writeln!(out, "{}", s.moves.len() + 1);
        for axis in [|d: &StepDelta| d.dx, |d: &StepDelta| d.dy] {
            let mut line = axis(&travel).to_string();
            for d in &s.moves {
                let _ = write!(line, " {}", axis(d));
            }
            let _ = writeln!(out, "{line}");
        }
        at = s.end();
    }
    out
}

struct Lines<'a> {
    iter: std::iter::Enumerate<std::str::Lines<'a>>,
    last: usize,
}

impl<'a> Lines<'a> {
    /// Next line (1-based number, tokens), skipping blank lines.
    fn next_tokens(&mut self) -> Option<(usize, Vec<&'a str>)> {
        for (i, l) in self.iter.by_ref() {
            self.last = i + 1;
            let toks: Vec<&str> = l.split(|c: char| c.is_whitespace() || c == ',').filter(|t| !t.is_empty()).collect();
            if !toks.is_empty() {
                return Some((i + 1, toks));
            }
        }
        None
    }
}

/// Read a trajectory file. `origin` names the file in errors.
pub fn import(text: &str, origin: &str) -> Result<StepDrawing, TrajectoryError> {
    let o = || origin.to_string();
    let int = |line: usize, t: &str| -> Result<i64, TrajectoryError> {
        t.parse::<i64>().map_err(|_| TrajectoryError::NotAnInteger { origin: o(), line, token: t.to_string() })
    };
    let mut lines = Lines { iter: text.lines().enumerate(), last: 0 };
    let Some((l0, toks)) = lines.next_tokens() else {
        return Ok(StepDrawing::default());
    };
    if toks.len() != 1 {
        return Err(TrajectoryError::Count {
            origin: o(),
            line: l0,
            what: "number of traces",
            expected: 1,
            found: toks.len(),
        });
    }
    let n = int(l0, toks[0])?;
    let traces = usize::try_from(n).map_err(|_| TrajectoryError::NotAnInteger {
        origin: o(),
        line: l0,
        token: toks[0].to_string(),
    })?;
    let mut strokes = Vec::with_capacity(traces.min(1 << 16));
    let mut at = (0i64, 0i64);
    let limit = i64::from(MAX_STEP_COORD);
    for trace in 1..=traces {
        let truncated = |what, last| TrajectoryError::Truncated { origin: o(), line: last + 1, trace, traces, what };
        let (lc, toks) = lines.next_tokens().ok_or_else(|| truncated("number of moves", lines.last))?;
        if toks.len() != 1 {
            return Err(TrajectoryError::Count {
                origin: o(),
                line: lc,
                what: "number of moves",
                expected: 1,
                found: toks.len(),
            });
        }
        let m = int(lc, toks[0])?;
        let moves = usize::try_from(m).ok().filter(|&m| m > 0).ok_or(TrajectoryError::EmptyTrace {
            origin: o(),
            line: lc,
            found: m,
        })?;
        let mut axes: [Vec<i64>; 2] = [Vec::new(), Vec::new()];
        let mut axis_lines = [0usize; 2];
        for (k, what) in ["motor 1 moves", "motor 2 moves"].into_iter().enumerate() {
            let (la, toks) = lines.next_tokens().ok_or_else(|| truncated(what, lines.last))?;
            if toks.len() != moves {
                return Err(TrajectoryError::Count { origin: o(), line: la, what, expected: moves, found: toks.len() });
            }
            axes[k] = toks.iter().map(|t| int(la, t)).collect::<Result<_, _>>()?;
            axis_lines[k] = la;
        }
        let mut positions = Vec::with_capacity(moves);
        for (dx, dy) in axes[0].iter().zip(&axes[1]) {
            at = (at.0.saturating_add(*dx), at.1.saturating_add(*dy));
            if at.0.abs() > limit {
                return Err(TrajectoryError::OutOfRange { origin: o(), line: axis_lines[0] });
            }
            if at.1.abs() > limit {
                return Err(TrajectoryError::OutOfRange { origin: o(), line: axis_lines[1] });
            }
            // Both coordinates were range-checked against MAX_STEP_COORD just above.
            let p = StepPos::new(
                i32::try_from(at.0).unwrap_or(MAX_STEP_COORD),
                i32::try_from(at.1).unwrap_or(MAX_STEP_COORD),
            );
            positions.push(p);
        }
        let start = positions[0];
        let moves = positions.windows(2).map(|w| w[0].delta_to(w[1])).filter(|d| !d.is_zero()).collect();
        strokes.push(StepStroke { start, moves });
    }
    if let Some((line, _)) = lines.next_tokens() {
        return Err(TrajectoryError::Trailing { origin: o(), line, traces });
    }
    Ok(StepDrawing::from_strokes(strokes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn sample() -> StepDrawing {
        StepDrawing {
            strokes: vec![
                StepStroke {
                    start: StepPos::new(10, 20),
                    moves: vec![StepDelta { dx: 5, dy: 0 }, StepDelta { dx: 0, dy: -3 }],
                },
                StepStroke { start: StepPos::new(0, 0), moves: vec![] },
            ],
            layers: vec![],
        }
    }

    #[test]
    fn exact_text_layout() {
        assert_eq!(export(&sample()), "2\n3\n10 5 0\n20 0 -3\n1\n-15\n-17\n");
    }

    #[test]
    fn round_trip_and_lenient_separators() {
        let s = sample();
        assert_eq!(import(&export(&s), "t").unwrap(), s);
        let loose = "2\n\n3\n10, 5,\t0\n20 0 -3\n\n1\n-15\n-17\n\n";
        assert_eq!(import(loose, "t").unwrap(), s);
        assert_eq!(import("", "t").unwrap(), StepDrawing::default());
        assert_eq!(import("0\n", "t").unwrap(), StepDrawing::default());
    }

    #[test]
    fn errors_carry_line_numbers() {
        let e = import("1\n2\n1 2\n3\n", "f.txt").unwrap_err();
        assert_eq!(
            e,
            TrajectoryError::Count { origin: "f.txt".into(), line: 4, what: "motor 2 moves", expected: 2, found: 1 }
        );
        assert!(e.to_string().starts_with("f.txt:4:"), "{e}");
        let e = import("1\n1\nx\n3\n", "f").unwrap_err();
        assert!(matches!(e, TrajectoryError::NotAnInteger { line: 3, ref token, .. } if token == "x"), "{e}");
        let e = import("2\n1\n1\n1\n", "f").unwrap_err();
        assert!(matches!(e, TrajectoryError::Truncated { line: 5, trace: 2, traces: 2, .. }), "{e}");
        let e = import("1\n1\n1\n1\n7\n", "f").unwrap_err();
        assert!(matches!(e, TrajectoryError::Trailing { line: 5, .. }), "{e}");
        let e = import("1\n0\n\n\n", "f").unwrap_err();
        assert!(matches!(e, TrajectoryError::EmptyTrace { line: 2, found: 0, .. }), "{e}");
        let e = import("-1\n", "f").unwrap_err();
        assert!(matches!(e, TrajectoryError::NotAnInteger { line: 1, .. }), "{e}");
        let e = import("1\n2\n2000000000 2000000000\n0 0\n", "f").unwrap_err();
        assert!(matches!(e, TrajectoryError::OutOfRange { line: 3, .. }), "{e}");
        let e = import("1 2\n", "f").unwrap_err();
        assert!(matches!(e, TrajectoryError::Count { line: 1, .. }), "{e}");
    }

    fn arb_drawing() -> impl Strategy<Value = StepDrawing> {
        let delta = (-500i32..500, -500i32..500)
            .prop_filter("non-zero", |(x, y)| *x != 0 || *y != 0)
            .prop_map(|(dx, dy)| StepDelta { dx, dy });
        let stroke = ((-9000i32..9000, -9000i32..9000), prop::collection::vec(delta, 0..30))
            .prop_map(|((x, y), moves)| StepStroke { start: StepPos::new(x, y), moves });
        prop::collection::vec(stroke, 0..20).prop_map(StepDrawing::from_strokes)
    }

    proptest! {
        #[test]
        fn export_import_round_trips(d in arb_drawing()) {
            prop_assert_eq!(import(&export(&d), "p").unwrap(), d);
        }
    }
}
