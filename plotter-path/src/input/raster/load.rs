//! Loading an image file and preparing the working gray image: size, gray conversion, blur.

use super::error::{RasterError, RasterWarning};
use super::{MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE, MAX_WORK_PIXELS, TraceOptions};
use image::{DynamicImage, GrayImage, ImageFormat, ImageReader, Limits};
use std::io::Cursor;
use std::path::Path;

/// Read and decode a PNG or JPEG file.
///
/// The format is recognised from the file's magic bytes, not its name. The header is checked against
/// [`MAX_IMAGE_SIDE`] / [`MAX_IMAGE_PIXELS`] before anything is decoded, so a small file that claims an enormous
/// size (a "decompression bomb") is refused without allocating.
pub fn load_image(path: &Path) -> Result<DynamicImage, RasterError> {
    let bytes = std::fs::read(path).map_err(|source| RasterError::Io { path: path.to_owned(), source })?;
    decode_image(&bytes, path)
}

/// Decode PNG or JPEG bytes; `path` only labels errors.
pub fn decode_image(bytes: &[u8], path: &Path) -> Result<DynamicImage, RasterError> {
    let format = match image::guess_format(bytes) {
        Ok(ImageFormat::Png) => ImageFormat::Png,
        Ok(ImageFormat::Jpeg) => ImageFormat::Jpeg,
        Ok(other) => {
            return Err(RasterError::UnsupportedFormat {
                path: path.to_owned(),
                detail: format!("{other:?} images are not supported"),
            });
        }
        Err(_) => {
            let shown: String = bytes.iter().take(8).map(|b| format!("{b:02x}")).collect::<Vec<_>>().join(" ");
            let detail =
                if bytes.is_empty() { "the file is empty".to_owned() } else { format!("file starts with {shown}") };
            return Err(RasterError::UnsupportedFormat { path: path.to_owned(), detail });
        }
    };
    let name = if format == ImageFormat::Png { "PNG" } else { "JPEG" };
    let decode_err = |source| RasterError::Decode { path: path.to_owned(), format: name, source };
    let (width, height) = ImageReader::with_format(Cursor::new(bytes), format).into_dimensions().map_err(decode_err)?;
    check_size(&path.display().to_string(), width, height)?;
    let mut reader = ImageReader::with_format(Cursor::new(bytes), format);
    let mut limits = Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    reader.limits(limits);
    reader.decode().map_err(decode_err)
}

/// Refuse images beyond the documented limits.
pub(crate) fn check_size(input: &str, width: u32, height: u32) -> Result<(), RasterError> {
    if width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE || u64::from(width) * u64::from(height) > MAX_IMAGE_PIXELS {
        return Err(RasterError::TooLarge {
            input: input.to_owned(),
            width,
            height,
            max_side: MAX_IMAGE_SIDE,
            max_pixels: MAX_IMAGE_PIXELS,
        });
    }
    Ok(())
}

/// The working image every mode traces.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// Luma, 0 = black ink, 255 = white paper (transparent pixels count as paper).
    pub gray: GrayImage,
    /// Size of one working pixel in millimetres.
    pub pixel_mm: f64,
    /// What was changed on the way.
    pub warnings: Vec<RasterWarning>,
}

/// Gray conversion (alpha composited over white), resize to the requested width in mm at the pixel pitch, blur.
///
/// Without a target width each source pixel becomes one working pixel of `pitch` mm. With a width of `W` mm the
/// image is resampled (triangle filter) to `round(W / pitch)` pixels across, keeping the aspect ratio, and one pixel
/// is then exactly `W / columns` mm. A working size above [`MAX_WORK_PIXELS`] is reduced (with a warning).
pub fn prepare(image: &DynamicImage, options: &TraceOptions) -> Result<Prepared, RasterError> {
    let pitch = options.pitch();
    let la = image.to_luma_alpha8();
    let (sw, sh) = la.dimensions();
    let mut gray = GrayImage::from_fn(sw, sh, |x, y| {
        let [l, a] = la.get_pixel(x, y).0;
        // Composite over white: l·a + 255·(1 − a), in integers with rounding.
        let v = (u32::from(l) * u32::from(a) + 255 * (255 - u32::from(a)) + 127) / 255;
        image::Luma([u8::try_from(v).unwrap_or(255)])
    });
    let mut warnings = Vec::new();
    let (mut tw, mut th) = (sw, sh);
    let mut pixel_mm = pitch;
    if let Some(width_mm) = options.width_mm {
        let cols = (width_mm / pitch).round().max(1.0);
        let rows = (cols * f64::from(sh) / f64::from(sw)).round().max(1.0);
        tw = to_u32(cols);
        th = to_u32(rows);
    }
    let total = u64::from(tw) * u64::from(th);
    if total > MAX_WORK_PIXELS {
        #[allow(clippy::cast_precision_loss)] // both sides are < 2^53
        let factor = (MAX_WORK_PIXELS as f64 / total as f64).sqrt();
        let (nw, nh) =
            (to_u32((f64::from(tw) * factor).floor().max(1.0)), to_u32((f64::from(th) * factor).floor().max(1.0)));
        warnings.push(RasterWarning::Downscaled { from: (tw, th), to: (nw, nh) });
        tw = nw;
        th = nh;
    }
    if (tw, th) != (sw, sh) {
        gray = image::imageops::resize(&gray, tw, th, image::imageops::FilterType::Triangle);
    }
    match options.width_mm {
        Some(width_mm) => pixel_mm = width_mm / f64::from(tw),
        None if tw != sw => pixel_mm = pitch * f64::from(sw) / f64::from(tw),
        None => {}
    }
    if options.blur_px > 0.0 {
        gray = imageproc::filter::gaussian_blur_f32(&gray, options.blur_px);
    }
    Ok(Prepared { gray, pixel_mm, warnings })
}

/// Round-trip a non-negative, already-rounded float that is known to fit (image sizes) into `u32`.
fn to_u32(v: f64) -> u32 {
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)] // clamped to the u32 range first
    let out = v.clamp(0.0, f64::from(u32::MAX)) as u32;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{ImageEncoder, LumaA};

    fn png_bytes(img: &GrayImage) -> Vec<u8> {
        let mut out = Vec::new();
        image::codecs::png::PngEncoder::new(&mut out)
            .write_image(img.as_raw(), img.width(), img.height(), image::ExtendedColorType::L8)
            .unwrap();
        out
    }

    #[test]
    fn png_round_trip() {
        let img = GrayImage::from_fn(5, 4, |x, y| image::Luma([u8::try_from(x * 10 + y).unwrap()]));
        let d = decode_image(&png_bytes(&img), Path::new("a.png")).unwrap();
        assert_eq!(d.to_luma8(), img);
    }

    #[test]
    fn text_file_is_not_an_image() {
        let e = decode_image(b"hello, world", Path::new("notes.txt")).unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, RasterError::UnsupportedFormat { .. }));
        assert!(msg.contains("notes.txt") && msg.contains("not a PNG or JPEG"), "{msg}");
        let e = decode_image(b"", Path::new("empty.png")).unwrap_err();
        assert!(e.to_string().contains("empty"), "{e}");
    }

    #[test]
    fn other_formats_are_named() {
        let e = decode_image(b"GIF89a\x01\x00\x01\x00", Path::new("x.gif")).unwrap_err();
        assert!(e.to_string().contains("Gif"), "{e}");
    }

    #[test]
    fn truncated_png_is_corrupt() {
        let img = GrayImage::from_fn(64, 64, |x, y| image::Luma([u8::try_from((x * y) % 256).unwrap()]));
        let bytes = png_bytes(&img);
        let e = decode_image(&bytes[..bytes.len() / 2], Path::new("cut.png")).unwrap_err();
        assert!(matches!(e, RasterError::Decode { format: "PNG", .. }), "{e:?}");
        assert!(e.to_string().contains("cut.png") && e.to_string().contains("corrupt"), "{e}");
        // Flip bytes inside the compressed data: the checksum or the inflater must object.
        let mut bad = bytes.clone();
        let mid = bad.len() / 2;
        for b in &mut bad[mid..mid + 16] {
            *b ^= 0x5a;
        }
        assert!(matches!(decode_image(&bad, Path::new("bad.png")), Err(RasterError::Decode { .. })));
    }

    #[test]
    fn huge_header_is_refused_before_decoding() {
        // A valid 1×1 PNG whose IHDR is patched to claim 100 000 × 100 000 pixels (CRC fixed up).
        let mut bytes = png_bytes(&GrayImage::from_pixel(1, 1, image::Luma([0])));
        bytes[16..20].copy_from_slice(&100_000u32.to_be_bytes());
        bytes[20..24].copy_from_slice(&100_000u32.to_be_bytes());
        let crc = crc32(&bytes[12..29]);
        bytes[29..33].copy_from_slice(&crc.to_be_bytes());
        let e = decode_image(&bytes, Path::new("bomb.png")).unwrap_err();
        assert!(matches!(e, RasterError::TooLarge { width: 100_000, height: 100_000, .. }), "{e:?}");
        assert!(e.to_string().contains("bomb.png") && e.to_string().contains("limit"), "{e}");
    }

    fn crc32(data: &[u8]) -> u32 {
        let mut c = 0xffff_ffffu32;
        for &b in data {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 { 0xedb8_8320 ^ (c >> 1) } else { c >> 1 };
            }
        }
        !c
    }

    #[test]
    fn transparent_is_paper_and_width_sets_scale() {
        let img = image::GrayAlphaImage::from_fn(40, 20, |x, _| if x < 20 { LumaA([0, 0]) } else { LumaA([0, 255]) });
        let opts = TraceOptions { width_mm: Some(10.0), pitch_mm: Some(0.5), ..TraceOptions::default() };
        let p = prepare(&DynamicImage::ImageLumaA8(img), &opts).unwrap();
        assert_eq!(p.gray.dimensions(), (20, 10));
        assert!((p.pixel_mm - 0.5).abs() < 1e-12);
        assert_eq!(p.gray.get_pixel(2, 5).0[0], 255);
        assert_eq!(p.gray.get_pixel(17, 5).0[0], 0);
        assert!(p.warnings.is_empty());
    }

    #[test]
    fn native_size_uses_the_pitch() {
        let img = GrayImage::from_pixel(30, 10, image::Luma([200]));
        let opts = TraceOptions { pitch_mm: Some(0.25), ..TraceOptions::default() };
        let p = prepare(&DynamicImage::ImageLuma8(img), &opts).unwrap();
        assert_eq!(p.gray.dimensions(), (30, 10));
        assert!((p.pixel_mm - 0.25).abs() < 1e-12);
    }

    #[test]
    fn oversized_working_image_is_downscaled_with_a_warning() {
        let img = GrayImage::from_pixel(10, 10, image::Luma([0]));
        // 10 m wide at 0.1 mm pitch would be 100 000 × 100 000 pixels.
        let opts = TraceOptions { width_mm: Some(10_000.0), pitch_mm: Some(0.1), ..TraceOptions::default() };
        let p = prepare(&DynamicImage::ImageLuma8(img), &opts).unwrap();
        let (w, h) = p.gray.dimensions();
        assert!(u64::from(w) * u64::from(h) <= MAX_WORK_PIXELS);
        assert!(matches!(p.warnings[..], [RasterWarning::Downscaled { from: (100_000, 100_000), .. }]));
        assert!((p.pixel_mm * f64::from(w) - 10_000.0).abs() < 1e-6);
    }
}
