//! G-code templates of a machine profile (`[gcode]`), for machines whose G-code dialect differs from the export's
//! own, in the manner of vpype-gcode's profiles: the lines written at the start and the end of the program, to lift
//! and lower the pen, at the start and the end of each layer, and at a pen change.
//!
//! ```toml
//! [gcode]
//! header = "G21\nG90\nM3 S{up}"
//! pen_up = "M3 S{up}"
//! pen_down = "M3 S{down}"
//! layer_start = "(layer {index}: {layer}, pen {pen})"
//! tool_change = "M0 (load {pen}, parked at {x} {y})"
//! footer = "G0 X0 Y0"
//! ```
//!
//! A template is one or more lines; `{name}` is replaced by a value where it is written, `{{` and `}}` are literal
//! braces. The placeholders:
//!
//! * `{x}`, `{y}`: where the carriage is, machine millimetres (with the export's decimals); at the lift that
//!   starts the program, before any move, where it goes first (the first stroke's start);
//! * `{layer}`: the layer's name; `{index}`: its number, counting from 1; `{pen}`: the name of the pen that draws
//!   it (from the pen table, else the layer's own name);
//! * `{up}`, `{down}`: the pen-up and the layer's pen-down position: Z millimetres for a Z pen, degrees for a
//!   servo pen.
//!
//! `header` and `footer` take none of them (they are written once, away from any layer). A placeholder not in
//! this list is refused when the profile is read, naming it and the template. An absent template keeps the
//! export's own lines (see [`crate::output::gcode_out`]); an empty one writes nothing.

use serde::{Deserialize, Deserializer, Serialize};

/// The placeholders a template written at a layer or a pen move may use.
pub const PLACEHOLDERS: [&str; 7] = ["x", "y", "layer", "index", "pen", "up", "down"];

/// The `[gcode]` section of a profile: each template replaces the export's own lines at that point when given.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GcodeTemplate {
    /// Written at the start of the program, after the comment naming the profile (default: `G21`, `G90`).
    #[serde(default, deserialize_with = "framing", skip_serializing_if = "Option::is_none")]
    pub header: Option<String>,
    /// Written at the end of the program, after the last lift (default: `M2` for a Z pen, nothing for a servo pen).
    #[serde(default, deserialize_with = "framing", skip_serializing_if = "Option::is_none")]
    pub footer: Option<String>,
    /// Lifts the pen (default: `G0 Z{up}`, or `M3 S{up}` for a servo pen). With `pen_up` or `pen_down` given,
    /// every lift and drop is the template's and the travel between strokes is flat: the export's overlap of the
    /// pen's moves with the travel is made of its own Z moves.
    #[serde(default, deserialize_with = "placed", skip_serializing_if = "Option::is_none")]
    pub pen_up: Option<String>,
    /// Lowers the pen (default: `G1 Z{down} F…` at the Z axis's rate, or `M3 S{down}` for a servo pen).
    #[serde(default, deserialize_with = "placed", skip_serializing_if = "Option::is_none")]
    pub pen_down: Option<String>,
    /// Written before each layer's first stroke, with the pen up (default: nothing).
    #[serde(default, deserialize_with = "placed", skip_serializing_if = "Option::is_none")]
    pub layer_start: Option<String>,
    /// Written after each layer's last stroke, once the pen is up (default: nothing).
    #[serde(default, deserialize_with = "placed", skip_serializing_if = "Option::is_none")]
    pub layer_end: Option<String>,
    /// Stops for a pen change, the carriage parked with the pen up (default: `M0 ; pen change: load {pen} for
    /// layer "{layer}"`).
    #[serde(default, deserialize_with = "placed", skip_serializing_if = "Option::is_none")]
    pub tool_change: Option<String>,
}

impl GcodeTemplate {
    /// Whether `pen_up` or `pen_down` replaces the export's own pen moves.
    pub fn replaces_pen_moves(&self) -> bool {
        self.pen_up.is_some() || self.pen_down.is_some()
    }
}

/// The values of the placeholders where a template is written.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Values<'a> {
    /// `{x}`, formatted.
    pub x: String,
    /// `{y}`, formatted.
    pub y: String,
    /// `{layer}`.
    pub layer: &'a str,
    /// `{index}` (from 1).
    pub index: usize,
    /// `{pen}`.
    pub pen: &'a str,
    /// `{up}`, formatted.
    pub up: String,
    /// `{down}`, formatted.
    pub down: String,
}

/// A `{name}` in `template` that is not among `allowed`, or a lone brace: the error's text. `Ok` when every
/// placeholder is known.
fn check(template: &str, allowed: &[&str]) -> Result<(), String> {
    let mut rest = template;
    while let Some(i) = rest.find(['{', '}']) {
        let after = &rest[i + 1..];
        if rest[i..].starts_with("{{") || rest[i..].starts_with("}}") {
            rest = &after[1..];
            continue;
        }
        if rest[i..].starts_with('}') {
            return Err("a lone `}` (write `}}` for a brace)".to_string());
        }
        let Some(end) = after.find('}') else {
            return Err("a `{` without its `}` (write `{{` for a brace)".to_string());
        };
        let name = &after[..end];
        if !allowed.contains(&name) {
            let known = if allowed.is_empty() {
                "this template takes no placeholders".to_string()
            } else {
                format!("use {}", allowed.iter().map(|a| format!("{{{a}}}")).collect::<Vec<_>>().join(", "))
            };
            return Err(format!("unknown placeholder {{{name}}}: {known}"));
        }
        rest = &after[end + 1..];
    }
    Ok(())
}

/// A template with no placeholders (`header`, `footer`).
fn framing<'de, D: Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
    let t = String::deserialize(d)?;
    check(&t, &[]).map_err(serde::de::Error::custom)?;
    Ok(Some(t))
}

/// A template written at a layer or a pen move ([`PLACEHOLDERS`]).
fn placed<'de, D: Deserializer<'de>>(d: D) -> Result<Option<String>, D::Error> {
    let t = String::deserialize(d)?;
    check(&t, &PLACEHOLDERS).map_err(serde::de::Error::custom)?;
    Ok(Some(t))
}

/// `template` with its placeholders replaced by `values` and `{{`/`}}` made single braces, as lines (a final
/// line end dropped, so that the template `"M5\n"` is one line; an empty template is no line). The template was
/// checked when the profile was read; a placeholder this does not know is kept as written.
pub fn render(template: &str, values: &Values<'_>) -> Vec<String> {
    let mut out = String::with_capacity(template.len() + 16);
    let mut rest = template;
    while let Some(i) = rest.find(['{', '}']) {
        out.push_str(&rest[..i]);
        let tail = &rest[i..];
        if tail.starts_with("{{") || tail.starts_with("}}") {
            out.push_str(&tail[..1]);
            rest = &tail[2..];
            continue;
        }
        let end = tail.find('}').filter(|_| tail.starts_with('{'));
        let Some(end) = end else {
            out.push_str(&tail[..1]);
            rest = &tail[1..];
            continue;
        };
        let value = match &tail[1..end] {
            "x" => values.x.clone(),
            "y" => values.y.clone(),
            "layer" => values.layer.to_string(),
            "index" => values.index.to_string(),
            "pen" => values.pen.to_string(),
            "up" => values.up.clone(),
            "down" => values.down.clone(),
            _ => tail[..=end].to_string(),
        };
        out.push_str(&value);
        rest = &tail[end + 1..];
    }
    out.push_str(rest);
    let out = out.strip_suffix('\n').unwrap_or(&out);
    if out.is_empty() { Vec::new() } else { out.lines().map(str::to_string).collect() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placeholders_are_replaced_and_braces_escaped() {
        let v = Values {
            x: "12.5".into(),
            y: "0".into(),
            layer: "sun",
            index: 2,
            pen: "red",
            up: "90".into(),
            down: "30".into(),
        };
        assert_eq!(render("M3 S{up}", &v), ["M3 S90"]);
        assert_eq!(render("(layer {index} {layer}, {pen})\nG0 X{x} Y{y}\n", &v), ["(layer 2 sun, red)", "G0 X12.5 Y0"]);
        assert_eq!(render("({{x}} is {x}) S{down}", &v), ["({x} is 12.5) S30"]);
        assert!(render("", &v).is_empty());
    }

    #[test]
    fn an_unknown_placeholder_is_named() {
        assert_eq!(
            check("M3 S{angle}", &PLACEHOLDERS).unwrap_err(),
            "unknown placeholder {angle}: use {x}, {y}, \
             {layer}, {index}, {pen}, {up}, {down}"
        );
        assert_eq!(check("G0 X{x}", &[]).unwrap_err(), "unknown placeholder {x}: this template takes no placeholders");
        assert!(check("M3 S{up", &PLACEHOLDERS).unwrap_err().contains("without its `}`"));
        assert!(check("M3 }", &PLACEHOLDERS).unwrap_err().contains("lone `}`"));
        assert!(check("{{literal}} {x}", &PLACEHOLDERS).is_ok());
        // Through serde, as a profile's [gcode] section is read.
        let t: GcodeTemplate = toml::from_str("pen_up = \"M3 S{up}\"\nfooter = \"M2\"").unwrap();
        assert_eq!((t.pen_up.as_deref(), t.footer.as_deref()), (Some("M3 S{up}"), Some("M2")));
        let e = toml::from_str::<GcodeTemplate>("pen_down = \"M3 S{angle}\"").unwrap_err().to_string();
        assert!(e.contains("unknown placeholder {angle}") && e.contains("pen_down"), "{e}");
        assert!(toml::from_str::<GcodeTemplate>("pen_lift = \"M5\"").is_err());
    }
}
