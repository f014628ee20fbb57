//! Raster-tracing options shared by every front end: how PNG/JPEG images become paths (outline, centerline,
//! edges, hatch), as flags [`TraceArgs`] and as library options ([`TraceArgs::options`]).

use std::path::Path;

use anyhow::Result;
use clap::builder::PossibleValue;
use clap::{Args, ValueEnum};
use plotter_path::Pen;
use plotter_path::config::color::parse_hex_color;
use plotter_path::config::profile::PenSpec;
use plotter_path::input::raster::separate::{Colors, Ink};
use plotter_path::input::raster::{self, HatchOptions, HatchScheme, Mode, Threshold, ToneCurve, TraceOptions};

/// Tracing mode as a command-line value: one of the library's modes, spelled and described as the library does
/// (`Mode::name`, `Mode::summary`), so a new style needs no second list here.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ModeArg(pub Mode);

/// Every mode as a command-line value, in the library's documentation order.
const MODE_ARGS: [ModeArg; Mode::ALL.len()] = {
    let mut out = [ModeArg(Mode::Outline); Mode::ALL.len()];
    let mut i = 0;
    while i < out.len() {
        out[i] = ModeArg(Mode::ALL[i]);
        i += 1;
    }
    out
};

impl ValueEnum for ModeArg {
    fn value_variants<'a>() -> &'a [Self] {
        &MODE_ARGS
    }

    fn to_possible_value(&self) -> Option<PossibleValue> {
        Some(PossibleValue::new(self.0.name()).help(self.0.summary()))
    }
}

/// How the picture's colours become pens.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Default)]
pub enum ColorsArg {
    /// One black pen shading the picture's gray
    #[default]
    Gray,
    /// Cyan, magenta, yellow and black pens, black taking the gray the colours share
    Cmyk,
    /// The machine profile's pens (their colours from the pen table), each pixel's colour mixed from them
    Pens,
}

/// How darker hatch levels add lines.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Default)]
pub enum SchemeArg {
    /// Spacing and crossings computed from each tone's darkness and the pen width, lines joined into zig-zags
    #[default]
    Tone,
    /// Each level adds a direction (cross-hatching)
    Directions,
    /// Each level halves the spacing
    Density,
}

/// Image tracing flags (used by `trace`, and by any command that accepts PNG/JPEG input).
#[derive(Debug, Clone, Args)]
pub struct TraceArgs {
    /// What to extract from the image
    #[arg(long, value_enum, default_value_t = ModeArg(Mode::Outline), help_heading = "Image tracing")]
    pub mode: ModeArg,
    /// Drawing width in mm (the image is resampled to width / pitch pixels); default: one pitch per image pixel
    #[arg(long, help_heading = "Image tracing")]
    pub width: Option<f64>,
    /// Pixel pitch in mm (default: the pen width)
    #[arg(long, help_heading = "Image tracing")]
    pub pitch: Option<f64>,
    /// Pen width in mm
    #[arg(long, default_value_t = Pen::default().width_mm, help_heading = "Image tracing")]
    pub pen_width: f64,
    /// Ink threshold: `otsu` or a luma 0-255 (pixels darker than it are ink)
    #[arg(long, default_value = "otsu", help_heading = "Image tracing")]
    pub threshold: Threshold,
    /// Swap ink and paper (light drawing on dark background; hatch shades light tones)
    #[arg(long, help_heading = "Image tracing")]
    pub invert: bool,
    /// Gaussian blur sigma in pixels before thresholding (0 = off)
    #[arg(long, default_value_t = 0.0, help_heading = "Image tracing")]
    pub blur: f32,
    /// Path simplification tolerance in pixels (Ramer-Douglas-Peucker; 0 = off)
    #[arg(long, default_value_t = TraceOptions::default().simplify_px, help_heading = "Image tracing")]
    pub simplify: f64,
    /// Drop regions and holes smaller than this, square pixels
    #[arg(long, default_value_t = TraceOptions::default().min_area_px, help_heading = "Image tracing")]
    pub min_area: f64,
    /// Drop strokes and edge chains shorter than this, pixels
    #[arg(long, default_value_t = TraceOptions::default().min_length_px, help_heading = "Image tracing")]
    pub min_length: f64,
    /// Canny low hysteresis threshold (edges mode)
    #[arg(long, default_value_t = TraceOptions::default().canny_low, help_heading = "Image tracing")]
    pub canny_low: f32,
    /// Canny high hysteresis threshold (edges mode)
    #[arg(long, default_value_t = TraceOptions::default().canny_high, help_heading = "Image tracing")]
    pub canny_high: f32,
    /// Gray value 0-255 that plots as full black; darker tones are clipped to it
    #[arg(long, default_value_t = ToneCurve::default().black, help_heading = "Image tracing")]
    pub black_point: u8,
    /// Gray value 0-255 that stays paper white; lighter tones are clipped to it
    #[arg(long, default_value_t = ToneCurve::default().white, help_heading = "Image tracing")]
    pub white_point: u8,
    /// Mid-tone gamma: above 1 lightens the mid-tones, below 1 darkens them
    #[arg(long, default_value_t = ToneCurve::default().gamma, help_heading = "Image tracing")]
    pub gamma: f64,
    /// Contrast around mid-gray: 1 keeps the picture's, 2 doubles it, below 1 flattens it
    #[arg(long, default_value_t = ToneCurve::default().contrast, help_heading = "Image tracing")]
    pub contrast: f64,
    /// Closest spacing of hatch lines in mm for the tone scheme (default: 1.5 x the pen width); tones darker than three crossed families reach there are filled solid, lines one pen width apart at black
    #[arg(long, help_heading = "Image tracing")]
    pub min_spacing: Option<f64>,
    /// Join every stipple dot into one continuous line (stipple mode)
    #[arg(long, help_heading = "Image tracing")]
    pub tsp: bool,
    /// Number of hatched gray levels, 1-16 (hatch mode; 1-8 with the directions and density schemes)
    #[arg(long, default_value_t = HatchOptions::default().levels, help_heading = "Image tracing")]
    pub levels: u8,
    /// Hatch line spacing in mm (hatch mode, directions and density schemes; the tone scheme computes its own)
    #[arg(long, default_value_t = HatchOptions::default().spacing_mm, help_heading = "Image tracing")]
    pub spacing: f64,
    /// Hatch base angle in degrees, counter-clockwise (hatch mode)
    #[arg(long, default_value_t = HatchOptions::default().angle_deg, allow_negative_numbers = true, help_heading = "Image tracing")]
    pub angle: f64,
    /// Also draw the outline of every shaded cell (mosaic mode; the outlines darken the picture beyond its tone)
    #[arg(long, help_heading = "Image tracing")]
    pub outline_cells: bool,
    /// Largest mosaic cell in mm (default: 16 x --min-spacing); cells shrink to 4 x --min-spacing where the picture is dark or busy
    #[arg(long, help_heading = "Image tracing")]
    pub cell_size: Option<f64>,
    /// Separate the picture's colours into pens, one layer per pen plotted with a pen change, each shaded by its own share in the chosen style (hatch, stipple, squiggle, spiral, flow, sketch, mosaic) at its own angle
    #[arg(long, value_enum, default_value_t = ColorsArg::Gray, help_heading = "Image tracing")]
    pub colors: ColorsArg,
    /// How darker hatch levels add lines (hatch mode)
    #[arg(long, value_enum, default_value_t = SchemeArg::Tone, help_heading = "Image tracing")]
    pub hatch_scheme: SchemeArg,
}

impl TraceArgs {
    /// The library options these flags mean.
    pub fn options(&self) -> TraceOptions {
        TraceOptions {
            mode: self.mode.0,
            width_mm: self.width,
            pitch_mm: self.pitch,
            pen: Pen { width_mm: self.pen_width, ..Pen::default() },
            blur_px: self.blur,
            threshold: self.threshold,
            invert: self.invert,
            simplify_px: self.simplify,
            min_area_px: self.min_area,
            min_length_px: self.min_length,
            canny_low: self.canny_low,
            canny_high: self.canny_high,
            cancel: plotter_path::geometry::cancel::Cancel::never(),
            tone: ToneCurve {
                black: self.black_point,
                white: self.white_point,
                gamma: self.gamma,
                contrast: self.contrast,
            },
            min_spacing_mm: self.min_spacing,
            stipple: raster::stipple::StippleOptions { tsp: self.tsp, ..raster::stipple::StippleOptions::default() },
            mosaic: raster::mosaic::MosaicOptions { outline: self.outline_cells, cell_mm: self.cell_size },
            colors: match self.colors {
                ColorsArg::Gray => Colors::Gray,
                ColorsArg::Cmyk => Colors::Cmyk,
                ColorsArg::Pens => Colors::Pens(Vec::new()),
            },
            hatch: HatchOptions {
                levels: self.levels,
                spacing_mm: self.spacing,
                angle_deg: self.angle,
                scheme: match self.hatch_scheme {
                    SchemeArg::Tone => HatchScheme::Tone,
                    SchemeArg::Directions => HatchScheme::Directions,
                    SchemeArg::Density => HatchScheme::Density,
                },
            },
        }
    }
}

/// What the command line tells the user to do when `--colors pens` finds no pen with a colour in the machine
/// profile: the flags that choose the machine (`plot`, `stats`, `optimize`, `trace` take them), or another
/// separation. Other front ends say what they offer ([`TraceArgs::options_for_profile`]).
pub const PENS_FROM_FLAGS: &str = "give a model (--model) or a profile (--profile) whose [[pens]] have colours for \
                                   --colors pens, or use --colors cmyk";

impl TraceArgs {
    /// [`TraceArgs::options_with_pens`] with the pen table of the machine profile named `profile` (`pens`), refused
    /// when `--colors pens` finds no pen with a colour in it: the message names the profile and ends with
    /// `what_to_do`, how the user of this front end gives other pens ([`PENS_FROM_FLAGS`] on the command line, the
    /// page's machine choice in the web app).
    pub fn options_for_profile(&self, profile: &str, pens: &[PenSpec], what_to_do: &str) -> Result<TraceOptions> {
        let options = self.options_with_pens(pens);
        if options.colors == Colors::Pens(Vec::new()) {
            anyhow::bail!(
                "separating the picture into the machine's pens: the machine profile {profile:?} has no pen with a \
                 colour in its pen table: {what_to_do}"
            );
        }
        Ok(options)
    }

    /// The library options these flags mean, `--colors pens` taking the pens of `pens` (a profile's pen table)
    /// that have a colour.
    pub fn options_with_pens(&self, pens: &[PenSpec]) -> TraceOptions {
        let mut options = self.options();
        if options.colors == Colors::Pens(Vec::new()) {
            let inks = pens
                .iter()
                .filter_map(|p| {
                    let color = p.color.as_deref().and_then(parse_hex_color)?;
                    Some(Ink { name: p.name.clone(), color })
                })
                .collect();
            options.colors = Colors::Pens(inks);
        }
        options
    }
}

/// Trace the image at `path` with `args` (`--colors pens` separating it into the coloured pens of `pens`, a pen
/// table), printing the tracer's warnings to stderr. `traced.drawing` is the result in mm (origin at the image's
/// top-left corner, `page_mm` = the image size), ready for layout.
pub fn trace_image(path: &Path, args: &TraceArgs, pens: &[PenSpec]) -> Result<raster::Traced> {
    let options = args.options_with_pens(pens);
    let mut traced = raster::trace_file(path, &options)?;
    join_stipples(&mut traced.drawing, &options);
    for w in &traced.warnings {
        eprintln!("warning: {}: {w}", path.display());
    }
    Ok(traced)
}

/// `--tsp`: a stippled drawing's dots joined into one continuous line, routed by the path optimizer (which comes
/// after the inputs in the pipeline, so the join happens here, on the traced drawing).
pub fn join_stipples(drawing: &mut plotter_path::Drawing, options: &raster::TraceOptions) {
    if options.mode == raster::Mode::Stipple && options.stipple.tsp {
        plotter_path::optimize::one_line::join_into_one_line(drawing);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        trace: TraceArgs,
    }

    fn pen(name: &str, color: Option<&str>) -> PenSpec {
        PenSpec {
            name: name.into(),
            color: color.map(Into::into),
            width_mm: None,
            down_z_mm: None,
            servo_down_deg: None,
            draw_feed_mm_s: None,
            hatch: None,
        }
    }

    #[test]
    fn colors_pens_takes_the_pen_tables_coloured_pens() {
        let table = [pen("red 0.5", Some("#ff0000")), pen("plain", None), pen("blue", Some("#0000ff"))];
        let args = Wrap::try_parse_from(["t", "--mode", "mosaic", "--colors", "pens"]).unwrap().trace;
        let want = Colors::Pens(vec![
            Ink { name: "red 0.5".into(), color: plotter_path::Rgb(255, 0, 0) },
            Ink { name: "blue".into(), color: plotter_path::Rgb(0, 0, 255) },
        ]);
        assert_eq!(args.options_with_pens(&table).colors, want);
        // Without a table (plain `trace`) the options say so when checked.
        let e = args.options().validate().unwrap_err().to_string();
        assert!(e.contains("--colors") && e.contains("pen table"), "{e}");
        let args = Wrap::try_parse_from(["t", "--colors", "cmyk"]).unwrap().trace;
        assert_eq!(args.options_with_pens(&table).colors, Colors::Cmyk);
        assert_eq!(Wrap::try_parse_from(["t"]).unwrap().trace.options().colors, Colors::Gray);
    }
}
