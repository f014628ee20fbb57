//! Errors and warnings of the raster tracer.

use std::fmt;
use std::path::PathBuf;

/// Why an image could not be traced. Every variant names the input.
#[derive(Debug, thiserror::Error)]
pub enum RasterError {
    /// The file could not be read.
    #[error("{path}: cannot read image file: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// The bytes are not a PNG or JPEG image.
    #[error("{path}: not a PNG or JPEG image ({detail})")]
    UnsupportedFormat {
        /// The file.
        path: PathBuf,
        /// What was found instead.
        detail: String,
    },
    /// The file claims to be PNG/JPEG but cannot be decoded (truncated, corrupt).
    #[error("{path}: corrupt or truncated {format} image: {source}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// "PNG" or "JPEG".
        format: &'static str,
        /// The decoder's complaint.
        source: image::ImageError,
    },
    /// The image is larger than the documented limit ([`super::MAX_IMAGE_SIDE`], [`super::MAX_IMAGE_PIXELS`]).
    #[error(
        "{input}: image is {width}×{height} pixels, larger than the limit of {max_side} pixels per side and \
         {max_pixels} pixels in total"
    )]
    TooLarge {
        /// The file or image label.
        input: String,
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// The per-side limit.
        max_side: u32,
        /// The total pixel limit.
        max_pixels: u64,
    },
    /// Tracing found no ink: a blank image, or every region was too small to keep.
    #[error("{input}: nothing to draw ({reason})")]
    NothingToDraw {
        /// The file or image label.
        input: String,
        /// What was found.
        reason: String,
    },
    /// The tracing was cancelled ([`super::TraceOptions::cancel`]) before it ended.
    #[error("{input}: tracing cancelled (the drawing was no longer wanted)")]
    Cancelled {
        /// The file or image label.
        input: String,
    },
    /// An option is out of range.
    #[error("invalid trace option {name} = {value}: {reason}")]
    InvalidOption {
        /// The option name as the CLI spells it.
        name: &'static str,
        /// The offending value.
        value: String,
        /// The allowed range.
        reason: &'static str,
    },
}

/// Something the tracer dropped or changed on the way; reported, never silent.
#[derive(Debug, Clone, PartialEq)]
pub enum RasterWarning {
    /// The working resolution was reduced to stay under [`super::MAX_WORK_PIXELS`].
    Downscaled {
        /// Requested working size.
        from: (u32, u32),
        /// Size actually used.
        to: (u32, u32),
    },
    /// Regions (or holes) smaller than the minimum area were dropped.
    SpecksDropped {
        /// How many loops were dropped.
        count: usize,
        /// The minimum area, in square pixels.
        min_area_px: f64,
    },
    /// Chains or strokes shorter than the minimum length were dropped.
    ShortPathsDropped {
        /// How many.
        count: usize,
        /// The minimum length, in pixels.
        min_length_px: f64,
    },
}

impl fmt::Display for RasterWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RasterWarning::Downscaled { from, to } => write!(
                f,
                "working image {}×{} exceeds the pixel limit; traced at {}×{} instead",
                from.0, from.1, to.0, to.1
            ),
            RasterWarning::SpecksDropped { count, min_area_px } => {
                write!(f, "dropped {count} speck(s) smaller than {min_area_px} px²")
            }
            RasterWarning::ShortPathsDropped { count, min_length_px } => {
                write!(f, "dropped {count} path(s) shorter than {min_length_px} px")
            }
        }
    }
}
