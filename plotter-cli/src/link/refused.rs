//! The firmware refusing a line with `error:<code> <text>`, as a typed error: callers that handle one refusal
//! (a homing that would press the pen onto the drawing, error 16) match its code, not its printed wording.

/// Our firmware answered a line with `error:<code> <text>`: the line was not executed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{machine}: {line:?} refused: error {code}: {text}")]
pub struct Refused {
    /// The machine's name, as the session calls it.
    pub machine: String,
    /// The line the firmware refused.
    pub line: String,
    /// The firmware's error code (`plotter_fw::errors::ErrorCode::code`).
    pub code: u8,
    /// The firmware's text for it.
    pub text: String,
}

impl Refused {
    /// Whether `e`, or any error it carries as its cause, is a refusal with `code`.
    pub fn has_code(e: &anyhow::Error, code: u8) -> bool {
        e.chain().any(|c| c.downcast_ref::<Refused>().is_some_and(|r| r.code == code))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context as _;

    fn refusal(code: u8) -> Refused {
        Refused { machine: "kit".into(), line: "G28 P1".into(), code, text: "homing would mark the paper".into() }
    }

    #[test]
    fn prints_as_the_session_always_did_and_is_found_under_context() {
        let e = anyhow::Error::new(refusal(16));
        assert_eq!(format!("{e}"), "kit: \"G28 P1\" refused: error 16: homing would mark the paper");
        let wrapped = Err::<(), _>(e).context("homing failed").unwrap_err();
        assert!(Refused::has_code(&wrapped, 16));
        assert!(!Refused::has_code(&wrapped, 15));
        // The same words in a plain message are not a refusal.
        let lookalike = anyhow::anyhow!("kit: \"G28 P1\" refused: error 16: homing would mark the paper");
        assert!(!Refused::has_code(&lookalike, 16));
    }
}
