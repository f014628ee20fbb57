//! Page-layout flags shared by every command that takes a drawing (`preview`, `stats`, `convert`, `plot`, ...).

use anyhow::Result;
use clap::{Args, ValueEnum};
use plotter_path::geometry::layout::{self, LayoutOptions, Orientation, Paper};
use plotter_path::kurbo::Vec2;

/// Orientation as a command-line value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OrientationArg {
    /// Taller than wide.
    Portrait,
    /// Wider than tall.
    Landscape,
}

/// Layout flags. Applied in a fixed order: rotate, paper, scale or fit, centre, translate.
#[derive(Debug, Clone, Args, Default)]
pub struct LayoutArgs {
    /// Paper: a3, a4, a5, letter, or WIDTHxHEIGHT in mm (e.g. 300x200)
    #[arg(long, help_heading = "Layout")]
    pub paper: Option<String>,
    /// Paper orientation (named papers default to portrait)
    #[arg(long, value_enum, help_heading = "Layout")]
    pub orientation: Option<OrientationArg>,
    /// Shorthand for --orientation landscape
    #[arg(long, conflicts_with = "orientation", help_heading = "Layout")]
    pub landscape: bool,
    /// Margin on every side, mm (used by --fit and --center)
    #[arg(long, default_value_t = 10.0, help_heading = "Layout")]
    pub margin: f64,
    /// Scale to the largest size fitting inside the margins, keeping the aspect ratio (implies --center)
    #[arg(long, help_heading = "Layout")]
    pub fit: bool,
    /// Centre the drawing on the page
    #[arg(long, help_heading = "Layout")]
    pub center: bool,
    /// Rotate by 90° clockwise this many times (negative: counter-clockwise)
    #[arg(long, default_value_t = 0, allow_negative_numbers = true, help_heading = "Layout")]
    pub rotate: i32,
    /// Scale by this factor about the drawing's top-left corner
    #[arg(long, conflicts_with = "fit", help_heading = "Layout")]
    pub scale: Option<f64>,
    /// Move by DX,DY mm after everything else (e.g. --translate 10,-5)
    #[arg(long, value_parser = parse_offset, allow_hyphen_values = true, help_heading = "Layout")]
    pub translate: Option<Vec2>,
}

fn parse_offset(s: &str) -> Result<Vec2, String> {
    let (x, y) = s.split_once(',').ok_or_else(|| format!("expected DX,DY in mm, got '{s}'"))?;
    let num = |v: &str| v.trim().parse::<f64>().map_err(|_| format!("'{v}' is not a number in --translate {s}"));
    Ok(Vec2::new(num(x)?, num(y)?))
}

impl LayoutArgs {
    /// The library options these flags mean.
    pub fn options(&self) -> Result<LayoutOptions> {
        let paper = self.paper.as_deref().map(str::parse::<Paper>).transpose()?;
        let orientation = if self.landscape {
            Some(Orientation::Landscape)
        } else {
            self.orientation.map(|o| match o {
                OrientationArg::Portrait => Orientation::Portrait,
                OrientationArg::Landscape => Orientation::Landscape,
            })
        };
        Ok(LayoutOptions {
            paper,
            orientation,
            margin_mm: self.margin,
            fit: self.fit,
            center: self.center,
            rotate_quarters: self.rotate,
            scale: self.scale,
            translate: self.translate.unwrap_or(Vec2::ZERO),
        })
    }

    /// Lay `drawing` out in place; returns the scale factor applied (1 when none, see [`layout::apply`]).
    pub fn apply(&self, drawing: &mut plotter_path::Drawing) -> Result<f64> {
        Ok(layout::apply(drawing, &self.options()?)?)
    }
}
