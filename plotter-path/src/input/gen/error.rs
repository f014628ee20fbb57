//! The error type of the parametric generators: every variant names the figure kind and parameter at fault.

/// Why a figure could not be generated. Messages name the spec, kind or parameter involved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GenError {
    /// The spec text is malformed (empty kind, a parameter without `=`, ...).
    #[error("bad figure spec {spec:?}: {problem}")]
    Syntax {
        /// The spec as given.
        spec: String,
        /// What is wrong with it.
        problem: String,
    },
    /// The figure kind is not one this generator knows.
    #[error("unknown figure kind {kind:?} (known: {known})")]
    UnknownKind {
        /// The kind as given.
        kind: String,
        /// Comma-separated list of the known kinds.
        known: String,
    },
    /// A parameter is not accepted by this kind.
    #[error("{kind}: unknown parameter {param:?} (accepted: {accepted})")]
    UnknownParam {
        /// The figure kind.
        kind: String,
        /// The parameter name as given.
        param: String,
        /// Comma-separated list of the accepted parameters.
        accepted: String,
    },
    /// The same parameter was given twice.
    #[error("parameter {param:?} given more than once")]
    DuplicateParam {
        /// The parameter name.
        param: String,
    },
    /// A parameter value does not parse or is out of range.
    #[error("{kind}: parameter {param}={value:?}: {problem}")]
    BadValue {
        /// The figure kind.
        kind: String,
        /// The parameter name.
        param: String,
        /// The value as given (or as computed).
        value: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A roulette or rose ratio does not close within the allowed number of turns.
    #[error(
        "{kind}: {param}={value} does not close within {max_turns} turns{needed}; give it as a fraction a/b \
         with a small b, or raise max_turns",
        needed = needed_turns.map(|n| format!(" (it needs {n})")).unwrap_or_default()
    )]
    NotClosing {
        /// The figure kind.
        kind: String,
        /// The ratio parameter name (`q`, `k`).
        param: String,
        /// The ratio as given.
        value: String,
        /// The turn limit in force.
        max_turns: u64,
        /// The turns the ratio needs, when it is an exact fraction whose denominator is merely too large.
        needed_turns: Option<u64>,
    },
    /// A Fourier fit asked for more harmonics than the samples can determine (needs `2N + 1 ≤ samples`).
    #[error("{harmonics} harmonics need at least {} samples of the outline, but only {samples} were asked for", 2 * harmonics + 1)]
    TooManyHarmonics {
        /// Harmonics asked for (N).
        harmonics: usize,
        /// Samples of the outline.
        samples: usize,
    },
    /// A Fourier fit was given an outline it cannot use (open, empty, zero length).
    #[error("cannot fit a Fourier series to {what}: {problem}")]
    BadOutline {
        /// Which outline.
        what: String,
        /// What is wrong with it.
        problem: String,
    },
    /// An outline file could not be read or holds no usable path.
    #[error("cannot take an outline from {file}: {problem}")]
    OutlineFile {
        /// The file.
        file: String,
        /// What went wrong (the importer's message, or which path is missing).
        problem: String,
    },
    /// Sampling produced a non-finite coordinate (the parameters overflow `f64`).
    #[error("{kind}: curve evaluates to a non-finite point at t = {t}; parameters too large?")]
    NonFinite {
        /// The figure kind.
        kind: String,
        /// The curve parameter where it happened.
        t: f64,
    },
    /// Adaptive sampling would need more points than the safety limit.
    #[error("{kind}: meeting the chord tolerance {tolerance_mm} mm needs more than {limit} points; raise tol")]
    TooManyPoints {
        /// The figure kind.
        kind: String,
        /// The requested chord tolerance, mm.
        tolerance_mm: f64,
        /// The point limit.
        limit: usize,
    },
}
