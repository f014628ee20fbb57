//! Downloads of the prepared drawing as a file (`GET /api/export?format=gcode|hpgl|svg`): the G-code program for the
//! chosen profile (as `plotter plot --export x.gcode` writes it), an HP-GL program for an HP plotter (the 7475A
//! unless `hpgl_device` names another; its first sheet that holds the drawing), or a plain SVG of the laid-out
//! drawing. The answer is an attachment named after the drawing.
//!
//! Writing the file runs like preparing a drawing: off the async threads, in one of the server's slots, with its
//! memory reserved in the budget first (the text is a few dozen bytes per point, far below what preparing the
//! same drawing reserves), so downloads cannot exhaust the server either.

use std::sync::Arc;

use axum::extract::rejection::QueryRejection;
use axum::extract::{Query, State};
use axum::http::{HeaderValue, StatusCode, header};
use axum::response::{IntoResponse, Response};
use serde::Deserialize;

use super::budget;
use super::command::hpgl_choice;
use super::error::ApiError;
use super::heavy::heavy;
use super::state::Shared;

/// What a download may be.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ExportFormat {
    /// G-code in the profile's terms.
    Gcode,
    /// HP-GL for an HP plotter.
    Hpgl,
    /// Plain SVG of the laid-out drawing.
    Svg,
}

impl ExportFormat {
    /// The format a request names; the error lists the choices.
    pub(crate) fn parse(name: &str) -> Result<ExportFormat, String> {
        match name.trim().to_ascii_lowercase().as_str() {
            "gcode" => Ok(ExportFormat::Gcode),
            "hpgl" => Ok(ExportFormat::Hpgl),
            "svg" => Ok(ExportFormat::Svg),
            other => Err(format!("export format {other:?} is not gcode, hpgl or svg")),
        }
    }

    /// File extension and media type.
    fn file(self) -> (&'static str, &'static str) {
        match self {
            ExportFormat::Gcode => ("gcode", "text/x-gcode; charset=utf-8"),
            ExportFormat::Hpgl => ("hpgl", "application/vnd.hp-hpgl"),
            ExportFormat::Svg => ("svg", "image/svg+xml"),
        }
    }
}

/// The query of a download.
#[derive(Debug, Deserialize)]
pub(crate) struct ExportQuery {
    /// `gcode`, `hpgl` or `svg`.
    format: String,
    /// HP-GL: the plotter model (default the 7475A).
    #[serde(default)]
    hpgl_device: Option<String>,
}

/// A download's file name: the drawing's name without its extension, kept to letters, digits, `-`, `_` and `.`
/// (so the header needs no quoting rules), then the format's extension.
pub(crate) fn file_name(drawing: &str, extension: &str) -> String {
    let stem = drawing.rsplit_once('.').map_or(drawing, |(s, _)| s);
    let mut safe: String = stem
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') { c } else { '-' })
        .take(80)
        .collect();
    if safe.trim_matches(['-', '.']).is_empty() {
        safe = "drawing".into();
    }
    format!("{safe}.{extension}")
}

/// `GET /api/export`: the prepared drawing as a file.
pub(crate) async fn download(
    State(shared): State<Arc<Shared>>,
    query: Result<Query<ExportQuery>, QueryRejection>,
) -> Result<Response, ApiError> {
    let bad = |m: String| ApiError::new(StatusCode::BAD_REQUEST, m);
    let Query(q) = query.map_err(|e| bad(format!("export: {}", e.body_text())))?;
    let format = ExportFormat::parse(&q.format).map_err(bad)?;
    let device = match format {
        ExportFormat::Hpgl => Some(hpgl_choice(q.hpgl_device.as_deref(), None, None, None).map_err(bad)?.device),
        _ => None,
    };
    let (prepared, profile, name) = {
        let i = shared.lock();
        let name = i.loaded.as_ref().map_or_else(|| "drawing".to_string(), |l| l.name.clone());
        (i.prepared.clone(), i.machine_profile(), name)
    };
    let prepared = prepared.ok_or_else(|| ApiError::new(StatusCode::CONFLICT, "load a drawing first"))?;
    let memory = budget::prepare_estimate(&prepared.drawing) / 4;
    let text = heavy(&shared, (memory, "writing the export"), move |_cancel| match format {
        ExportFormat::Gcode => Ok(plotter_path::output::gcode_out::export(&profile, &prepared.steps)),
        ExportFormat::Svg => Ok(plotter_path::output::svg_out::to_svg_string(&prepared.drawing)),
        ExportFormat::Hpgl => {
            let device = device.unwrap_or(&plotter_path::geometry::hpgl_devices::DEVICES[0]);
            plotter_host::job::hpgl::program_for(&profile, &prepared.drawing, device, None)
                .map(|(program, _)| program.text)
                .map_err(|e| format!("{e:#}"))
        }
    })
    .await?
    .map_err(bad)?;
    let (extension, media) = format.file();
    let disposition = format!("attachment; filename=\"{}\"", file_name(&name, extension));
    let disposition = HeaderValue::from_str(&disposition).unwrap_or_else(|_| HeaderValue::from_static("attachment"));
    Ok(([(header::CONTENT_TYPE, HeaderValue::from_static(media)), (header::CONTENT_DISPOSITION, disposition)], text)
        .into_response())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_and_file_names() {
        assert_eq!(ExportFormat::parse("GCode"), Ok(ExportFormat::Gcode));
        assert_eq!(ExportFormat::parse("pdf").unwrap_err(), "export format \"pdf\" is not gcode, hpgl or svg");
        assert_eq!(file_name("duck.svg", "gcode"), "duck.gcode");
        assert_eq!(file_name("gen:rose?k=5", "svg"), "gen-rose-k-5.svg");
        assert_eq!(file_name("\"; evil=1.svg", "hpgl"), "---evil-1.hpgl");
        assert_eq!(file_name("..", "svg"), "drawing.svg");
    }
}
