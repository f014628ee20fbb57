//! Parsing of figure specs `KIND?param=value&param=value…` (optionally prefixed `gen:`) into a kind and typed
//! parameter values, with errors that name the parameter.
//!
//! Every parameter read is remembered, so once a figure has read all the parameters it understands,
//! [`Params::finish`] can reject anything left over and list what the kind accepts — a misspelt parameter is an
//! error, never silently ignored.

use super::GenError;
use super::rational::{Ratio, RatioError};

/// The parameters of one spec, with a record of which were read.
#[derive(Debug, Clone)]
pub(crate) struct Params {
    kind: String,
    entries: Vec<(String, String)>,
    used: Vec<bool>,
    accepted: Vec<&'static str>,
}

impl Params {
    /// Split `spec` into its kind (lower-cased) and parameters.
    pub(crate) fn parse(spec: &str) -> Result<Params, GenError> {
        let syntax = |problem: String| GenError::Syntax { spec: spec.to_string(), problem };
        let body = spec.trim();
        let body = body.strip_prefix("gen:").unwrap_or(body);
        let (kind, query) = body.split_once('?').unwrap_or((body, ""));
        let kind = kind.trim().to_ascii_lowercase();
        if kind.is_empty() {
            return Err(syntax("no figure kind before '?'".to_string()));
        }
        let mut entries: Vec<(String, String)> = Vec::new();
        for piece in query.split('&').map(str::trim).filter(|p| !p.is_empty()) {
            let Some((key, value)) = piece.split_once('=') else {
                return Err(syntax(format!("parameter {piece:?} has no '=value'")));
            };
            let key = key.trim();
            if key.is_empty() {
                return Err(syntax(format!("parameter {piece:?} has no name")));
            }
            if entries.iter().any(|(k, _)| k == key) {
                return Err(GenError::DuplicateParam { param: key.to_string() });
            }
            entries.push((key.to_string(), value.trim().to_string()));
        }
        let used = vec![false; entries.len()];
        Ok(Params { kind, entries, used, accepted: Vec::new() })
    }

    /// The figure kind, lower-cased.
    pub(crate) fn kind(&self) -> &str {
        &self.kind
    }

    /// Replace the kind used in error messages (for a nested figure).
    pub(crate) fn set_kind(&mut self, kind: &str) {
        self.kind = kind.to_string();
    }

    /// The raw text of `key`, marking it read.
    pub(crate) fn text(&mut self, key: &'static str) -> Option<String> {
        if !self.accepted.contains(&key) {
            self.accepted.push(key);
        }
        let i = self.entries.iter().position(|(k, _)| k == key)?;
        self.used[i] = true;
        Some(self.entries[i].1.clone())
    }

    fn bad(&self, key: &str, value: &str, problem: impl Into<String>) -> GenError {
        GenError::BadValue {
            kind: self.kind.clone(),
            param: key.to_string(),
            value: value.to_string(),
            problem: problem.into(),
        }
    }

    /// A finite number, if given.
    pub(crate) fn opt_f64(&mut self, key: &'static str) -> Result<Option<f64>, GenError> {
        let Some(v) = self.text(key) else { return Ok(None) };
        match v.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(Some(x)),
            _ => Err(self.bad(key, &v, "not a finite number")),
        }
    }

    /// A finite number, or `default`.
    pub(crate) fn f64(&mut self, key: &'static str, default: f64) -> Result<f64, GenError> {
        Ok(self.opt_f64(key)?.unwrap_or(default))
    }

    /// A whole number in `min..=max`, if given.
    pub(crate) fn opt_count(&mut self, key: &'static str, min: u64, max: u64) -> Result<Option<u64>, GenError> {
        let Some(v) = self.text(key) else { return Ok(None) };
        match v.parse::<u64>() {
            Ok(x) if (min..=max).contains(&x) => Ok(Some(x)),
            _ => Err(self.bad(key, &v, format!("must be a whole number from {min} to {max}"))),
        }
    }

    /// A whole number in `min..=max`, or `default`.
    pub(crate) fn count(&mut self, key: &'static str, default: u64, min: u64, max: u64) -> Result<u64, GenError> {
        Ok(self.opt_count(key, min, max)?.unwrap_or(default))
    }

    /// A positive ratio (`a/b` or decimal) whose reduced denominator is at most `max_turns`, or `default`.
    pub(crate) fn ratio(&mut self, key: &'static str, default: Ratio, max_turns: u64) -> Result<Ratio, GenError> {
        let Some(v) = self.text(key) else { return Ok(default) };
        Ratio::parse(&v, max_turns).map_err(|e| match e {
            RatioError::Invalid(problem) => self.bad(key, &v, problem),
            RatioError::TooManyTurns(needed) => GenError::NotClosing {
                kind: self.kind.clone(),
                param: key.to_string(),
                value: v.clone(),
                max_turns,
                needed_turns: Some(needed),
            },
            RatioError::NoCloseFraction => GenError::NotClosing {
                kind: self.kind.clone(),
                param: key.to_string(),
                value: v.clone(),
                max_turns,
                needed_turns: None,
            },
        })
    }

    /// Fail on any parameter that was never read, listing the accepted ones.
    pub(crate) fn finish(self) -> Result<(), GenError> {
        if let Some(i) = self.used.iter().position(|u| !u) {
            return Err(GenError::UnknownParam {
                kind: self.kind,
                param: self.entries[i].0.clone(),
                accepted: self.accepted.join(", "),
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_kind_and_values() {
        let mut p = Params::parse("gen:Epicycloid?q=5/2&r=12.5& d = 3 &").unwrap();
        assert_eq!(p.kind(), "epicycloid");
        assert_eq!(p.f64("r", 1.0).unwrap(), 12.5);
        assert_eq!(p.f64("missing", 7.0).unwrap(), 7.0);
        assert_eq!(p.ratio("q", Ratio { num: 1, den: 1 }, 10).unwrap(), Ratio { num: 5, den: 2 });
        assert_eq!(p.count("d", 0, 0, 10).unwrap(), 3);
        p.finish().unwrap();
    }

    #[test]
    fn errors_name_the_problem() {
        let e = Params::parse("?r=1").unwrap_err();
        assert!(e.to_string().contains("no figure kind"), "{e}");
        let e = Params::parse("circle?r").unwrap_err();
        assert!(e.to_string().contains("\"r\" has no '=value'"), "{e}");
        let e = Params::parse("circle?r=1&r=2").unwrap_err();
        assert_eq!(e, GenError::DuplicateParam { param: "r".to_string() });
        let mut p = Params::parse("circle?r=abc").unwrap();
        assert_eq!(p.f64("r", 1.0).unwrap_err().to_string(), "circle: parameter r=\"abc\": not a finite number");
        let mut p = Params::parse("circle?r=inf").unwrap();
        assert!(p.f64("r", 1.0).is_err());
        let mut p = Params::parse("circle?r=2&radius=3").unwrap();
        p.f64("r", 1.0).unwrap();
        p.f64("tol", 1.0).unwrap();
        let e = p.finish().unwrap_err();
        assert_eq!(e.to_string(), "circle: unknown parameter \"radius\" (accepted: r, tol)");
        let mut p = Params::parse("epicycloid?q=1.41421356").unwrap();
        let e = p.ratio("q", Ratio { num: 3, den: 1 }, 100).unwrap_err();
        assert!(matches!(e, GenError::NotClosing { needed_turns: None, max_turns: 100, .. }), "{e}");
        let mut p = Params::parse("epicycloid?q=-3").unwrap();
        assert!(p.ratio("q", Ratio { num: 3, den: 1 }, 100).unwrap_err().to_string().contains("positive"));
        let mut p = Params::parse("lissajous?fx=2.5").unwrap();
        assert!(p.count("fx", 1, 1, 10).unwrap_err().to_string().contains("whole number from 1 to 10"));
    }
}
