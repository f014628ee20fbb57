//! Reading drawings from the command line: the input flags and the loader that turns a file (or `-` for stdin)
//! into a [`Drawing`], printing every import warning to stderr.

use std::io::Read;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use plotter_path::Drawing;
use plotter_path::svg::{self, LayerBy, SvgOptions};

/// How SVG shapes are grouped into layers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Default)]
pub(crate) enum LayerByArg {
    /// One layer per top-level group (Inkscape layer label, else group id)
    #[default]
    Group,
    /// One layer per stroke colour
    Color,
    /// Everything in one layer
    None,
}

/// Input flags shared by commands that read a drawing.
#[derive(Debug, Clone, Args)]
pub(crate) struct InputArgs {
    /// Maximum chord error when flattening curves, mm
    #[arg(long, default_value_t = svg::DEFAULT_TOLERANCE_MM, help_heading = "Input")]
    pub(crate) tolerance: f64,
    /// How SVG shapes are grouped into layers
    #[arg(long, value_enum, default_value_t = LayerByArg::Group, help_heading = "Input")]
    pub(crate) layer_by: LayerByArg,
    /// Keep only these layers (names as listed by `plotter stats`), comma-separated
    #[arg(long, value_delimiter = ',', help_heading = "Input")]
    pub(crate) layers: Vec<String>,
}

impl InputArgs {
    fn svg_options(&self) -> Result<SvgOptions> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            bail!("--tolerance must be a positive number of mm, got {}", self.tolerance);
        }
        Ok(SvgOptions {
            tolerance_mm: self.tolerance,
            layer_by: match self.layer_by {
                LayerByArg::Group => LayerBy::Group,
                LayerByArg::Color => LayerBy::Color,
                LayerByArg::None => LayerBy::None,
            },
            layers: self.layers.clone(),
        })
    }
}

/// Print import warnings to stderr, prefixed so they stand out from results.
pub(crate) fn warn_all(warnings: &[String]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// Load the drawing at `path` (`-` reads SVG from stdin).
pub(crate) fn load_drawing(path: &Path, args: &InputArgs) -> Result<Drawing> {
    let options = args.svg_options()?;
    let imported = if path == Path::new("-") {
        let mut data = Vec::new();
        std::io::stdin().read_to_end(&mut data).context("cannot read SVG from stdin")?;
        svg::import_svg(&data, "<stdin>", None, &options)?
    } else {
        svg::load_svg(path, &options)?
    };
    warn_all(&imported.warnings);
    Ok(imported.drawing)
}

/// Write `bytes` to `out` (`-` is stdout).
pub(crate) fn write_output(out: &PathBuf, bytes: &[u8]) -> Result<()> {
    if out.as_os_str() == "-" {
        use std::io::Write;
        let mut stdout = std::io::stdout().lock();
        stdout.write_all(bytes).context("cannot write to stdout")?;
        stdout.flush().context("cannot write to stdout")?;
    } else {
        std::fs::write(out, bytes).with_context(|| format!("cannot write {}", out.display()))?;
    }
    Ok(())
}
