//! What an SVG may reference beyond its own bytes: the caller decides, never usvg's defaults.
//!
//! usvg resolves `<image href>` (and `feImage`) on its own unless told otherwise: any path, absolute or relative
//! to the working directory, read whole — a server importing an upload would open files of the sender's choosing
//! (a FIFO never returns, `/dev/zero` is read until memory runs out, and whether an image loaded shows in the
//! result, telling the sender which files exist). Here every reference goes through a [`Resolver`] built from a
//! [`ResourcePolicy`]:
//!
//! - [`ResourcePolicy::DataUrlsOnly`] (uploads, the web app): only `data:` URLs inside the document are read.
//!   Every other reference is refused with the same warning whatever it names, so the answer does not depend on
//!   which files exist.
//! - [`ResourcePolicy::BesideFile`] (the command line): `data:` URLs, and files named by a relative path in the
//!   SVG's folder or below it. Refused, with a warning naming the reference and why: URLs (`http:`, `file:`, …),
//!   absolute paths, any `..` component, paths that lead outside the folder through a symbolic link, anything
//!   that is not a regular file (directories, devices, FIFOs, sockets — checked from the metadata before the file
//!   is opened, and again on the opened handle), and files over the size cap (read through `take`, so a file that
//!   grows while it is read cannot exceed it either).
//!
//! **Nested SVG images** (`data:image/svg+xml`, or an `.svg` file) are decoded through the same checked path as
//! the outer document ([`super::decode::checked_text`], [`super::decode::parse_xml`]: gzip cap, encodings, entity
//! expansion, attribute count, node count), at most [`MAX_NESTING`] levels deep and [`MAX_NESTED_BYTES`] of SVG
//! text in all (usvg re-reads an image for every `<use>` of it, so the budget counts every reading). As the SVG
//! specification asks, a nested SVG may use `data:` URLs but no files. All embedded image data accepted in one
//! import is capped at [`MAX_IMAGE_BYTES`] (usvg keeps a copy for every `<use>` instance).
//!
//! Nested SVG images are not plotted (the walker traces raster images only); they are still read, so a mask that
//! holds one behaves as in a browser.

use std::io::Read;
use std::path::{Component, Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use usvg::ImageKind;

use super::decode;

/// Default cap on one referenced file, bytes.
pub const DEFAULT_MAX_FILE_BYTES: u64 = 32 << 20;

/// Deepest nesting of SVG images inside SVG images.
pub const MAX_NESTING: usize = 3;

/// Most SVG text read from nested SVG images in one import, bytes (every reading counts).
pub const MAX_NESTED_BYTES: u64 = 16 << 20;

/// Most embedded image data accepted in one import, bytes (every `<use>` instance counts).
pub const MAX_IMAGE_BYTES: u64 = 128 << 20;

/// What an SVG document may reference beyond its own bytes (see the module docs).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ResourcePolicy {
    /// Only `data:` URLs inside the document; every other reference is refused with one and the same warning.
    DataUrlsOnly,
    /// `data:` URLs, and regular files named by a relative path in `dir` or below it, each at most `max_bytes`.
    BesideFile {
        /// The folder references are resolved in (the SVG file's folder).
        dir: PathBuf,
        /// Largest file read, bytes.
        max_bytes: u64,
    },
}

impl ResourcePolicy {
    /// Files beside the SVG file `path` (in its folder or below), at most [`DEFAULT_MAX_FILE_BYTES`] each.
    pub fn beside(path: &Path) -> ResourcePolicy {
        let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        ResourcePolicy::BesideFile { dir: dir.to_path_buf(), max_bytes: DEFAULT_MAX_FILE_BYTES }
    }
}

/// Resolves the references of one import under a policy, keeping the budgets and what it refused.
pub(super) struct Resolver<'p> {
    policy: &'p ResourcePolicy,
    nested_bytes: AtomicU64,
    image_bytes: AtomicU64,
    /// `(reference, reason)` of every refusal, in order.
    refused: Mutex<Vec<(String, String)>>,
}

/// The sniffed kind of image bytes.
fn raster_kind(data: Arc<Vec<u8>>) -> Result<ImageKind, Arc<Vec<u8>>> {
    let d = data.as_slice();
    if d.starts_with(b"\x89PNG\r\n\x1a\n") {
        Ok(ImageKind::PNG(data))
    } else if d.starts_with(&[0xff, 0xd8, 0xff]) {
        Ok(ImageKind::JPEG(data))
    } else if d.starts_with(b"GIF87a") || d.starts_with(b"GIF89a") {
        Ok(ImageKind::GIF(data))
    } else if d.len() >= 12 && d.starts_with(b"RIFF") && &d[8..12] == b"WEBP" {
        Ok(ImageKind::WEBP(data))
    } else {
        Err(data)
    }
}

impl<'p> Resolver<'p> {
    pub(super) fn new(policy: &'p ResourcePolicy) -> Resolver<'p> {
        Resolver {
            policy,
            nested_bytes: AtomicU64::new(0),
            image_bytes: AtomicU64::new(0),
            refused: Mutex::new(Vec::new()),
        }
    }

    /// The usvg resolver for a document `depth` levels inside the imported one (0: the document itself).
    pub(super) fn href_resolver(&self, depth: usize) -> usvg::ImageHrefResolver<'_> {
        usvg::ImageHrefResolver {
            resolve_data: Box::new(move |mime, data, opts| {
                let len = data.len();
                self.data(mime, data, opts, depth)
                    .map_err(|why| self.refuse(format!("data:{mime} ({len} bytes)"), why))
                    .ok()
            }),
            resolve_string: Box::new(move |href, opts| {
                self.string(href, opts, depth).map_err(|why| self.refuse(shorten(href), why)).ok()
            }),
        }
    }

    fn refuse(&self, what: String, why: String) {
        if let Ok(mut r) = self.refused.lock() {
            r.push((what, why));
        }
    }

    /// One warning per distinct refusal (with a count when repeated), in the order met.
    pub(super) fn warnings(&self, name: &str) -> Vec<String> {
        let refused = self.refused.lock().map(|r| r.clone()).unwrap_or_default();
        let mut distinct: Vec<((String, String), usize)> = Vec::new();
        for r in refused {
            match distinct.iter_mut().find(|(d, _)| *d == r) {
                Some((_, n)) => *n += 1,
                None => distinct.push((r, 1)),
            }
        }
        distinct
            .into_iter()
            .map(|((what, why), n)| {
                let times = if n > 1 { format!(" ({n} times)") } else { String::new() };
                format!("{name}: image \"{what}\" not loaded{times}: {why}")
            })
            .collect()
    }

    fn charge(&self, counter: &AtomicU64, bytes: u64, limit: u64, what: &str) -> Result<(), String> {
        let before = counter.fetch_add(bytes, Ordering::Relaxed);
        if before.saturating_add(bytes) > limit {
            return Err(format!("{what} exceed {} MiB in all", limit >> 20));
        }
        Ok(())
    }

    fn data(
        &self,
        mime: &str,
        data: Arc<Vec<u8>>,
        opts: &usvg::Options<'_>,
        depth: usize,
    ) -> Result<ImageKind, String> {
        self.charge(&self.image_bytes, data.len() as u64, MAX_IMAGE_BYTES, "embedded images")?;
        let sniffed = raster_kind(data);
        match (mime, sniffed) {
            ("image/png" | "image/jpeg" | "image/jpg" | "image/gif" | "image/webp" | "text/plain", Ok(kind)) => {
                Ok(kind)
            }
            ("image/svg+xml" | "text/plain", Err(data)) => self.nested_svg(&data, opts, depth),
            (_, Ok(_)) => Err(format!("declared as {mime} but holds a different image type")),
            (_, Err(_)) => Err(format!("{mime} is not an image type that can be read (PNG, JPEG, GIF, WebP, SVG)")),
        }
    }

    fn string(&self, href: &str, opts: &usvg::Options<'_>, depth: usize) -> Result<ImageKind, String> {
        let (dir, max_bytes) = match self.policy {
            ResourcePolicy::DataUrlsOnly => return Err("only data: URLs are read here".to_string()),
            ResourcePolicy::BesideFile { .. } if depth > 0 => {
                return Err("an SVG image inside an SVG may only use data: URLs".to_string());
            }
            ResourcePolicy::BesideFile { dir, max_bytes } => (dir, *max_bytes),
        };
        let path = Path::new(href);
        if href.split_once(':').is_some_and(|(scheme, _)| {
            scheme.len() > 1 && scheme.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '+' | '-' | '.'))
        }) {
            return Err("URLs are not fetched; use a file path relative to the SVG or a data: URL".to_string());
        }
        if path.is_absolute() || path.has_root() {
            return Err("absolute paths are not read; name the file relative to the SVG's folder".to_string());
        }
        if path.components().any(|c| matches!(c, Component::ParentDir | Component::Prefix(_))) {
            return Err("'..' is not allowed: the file must be in the SVG's folder or below it".to_string());
        }
        let base = dir.canonicalize().map_err(|e| format!("cannot open the SVG's folder {} ({e})", dir.display()))?;
        let full = base.join(path).canonicalize().map_err(|e| format!("cannot open it ({e})"))?;
        if !full.starts_with(&base) {
            return Err("it leads outside the SVG's folder (a symbolic link)".to_string());
        }
        let not_regular = "not a regular file (a directory, device, FIFO or socket)".to_string();
        let meta = std::fs::metadata(&full).map_err(|e| format!("cannot open it ({e})"))?;
        if !meta.is_file() {
            return Err(not_regular);
        }
        let too_big = || format!("larger than the {} MiB limit", (max_bytes >> 20).max(1));
        if meta.len() > max_bytes {
            return Err(too_big());
        }
        let file = std::fs::File::open(&full).map_err(|e| format!("cannot open it ({e})"))?;
        // The file may have been swapped between the check and the open: check the handle too.
        if !file.metadata().is_ok_and(|m| m.is_file()) {
            return Err(not_regular);
        }
        let mut data = Vec::new();
        file.take(max_bytes + 1).read_to_end(&mut data).map_err(|e| format!("cannot read it ({e})"))?;
        if data.len() as u64 > max_bytes {
            return Err(too_big());
        }
        self.charge(&self.image_bytes, data.len() as u64, MAX_IMAGE_BYTES, "embedded images")?;
        let ext = full.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        match raster_kind(Arc::new(data)) {
            Ok(kind) => Ok(kind),
            Err(data) if matches!(ext.as_deref(), Some("svg" | "svgz")) => self.nested_svg(&data, opts, depth),
            Err(_) => Err("not a PNG, JPEG, GIF, WebP or SVG image".to_string()),
        }
    }

    /// An SVG image inside the document `depth` levels deep, through the outer document's checks.
    fn nested_svg(&self, data: &[u8], opts: &usvg::Options<'_>, depth: usize) -> Result<ImageKind, String> {
        if depth + 1 > MAX_NESTING {
            return Err(format!("SVG images nested more than {MAX_NESTING} deep"));
        }
        let spent = self.nested_bytes.load(Ordering::Relaxed);
        let room = MAX_NESTED_BYTES.saturating_sub(spent);
        let text = decode::checked_text(data, room).map_err(|e| format!("nested SVG: {e}"))?;
        self.charge(&self.nested_bytes, text.len() as u64, MAX_NESTED_BYTES, "nested SVG images")?;
        let xml = decode::parse_xml(&text).map_err(|e| format!("nested SVG: {e}"))?;
        super::check_page_size(xml.root_element()).map_err(|e| format!("nested SVG: {e}"))?;
        let nested = usvg::Options {
            resources_dir: None,
            dpi: opts.dpi,
            font_family: opts.font_family.clone(),
            font_size: opts.font_size,
            languages: opts.languages.clone(),
            shape_rendering: opts.shape_rendering,
            text_rendering: opts.text_rendering,
            image_rendering: opts.image_rendering,
            default_size: opts.default_size,
            image_href_resolver: self.href_resolver(depth + 1),
            fontdb: opts.fontdb.clone(),
            ..usvg::Options::default()
        };
        let tree = usvg::Tree::from_xmltree(&xml, &nested).map_err(|e| format!("nested SVG: {e}"))?;
        Ok(ImageKind::SVG(tree))
    }
}

/// A reference as shown in a warning: at most 80 characters.
fn shorten(href: &str) -> String {
    match href.char_indices().nth(80) {
        Some((i, _)) => format!("{}…", &href[..i]),
        None => href.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;
    use std::time::{Duration, Instant};

    use super::super::{SvgError, SvgOptions, import_svg};
    use super::*;

    /// A `data:` URL with every byte but letters and digits percent-encoded, so it nests without XML escaping.
    pub(crate) fn data_url(mime: &str, bytes: &[u8]) -> String {
        let mut s = format!("data:{mime},");
        for b in bytes {
            if b.is_ascii_alphanumeric() {
                s.push(char::from(*b));
            } else {
                s.push_str(&format!("%{b:02X}"));
            }
        }
        s
    }

    fn png() -> Vec<u8> {
        let img = image::GrayImage::from_fn(4, 4, |x, _| image::Luma([if x < 2 { 0 } else { 255 }]));
        let mut png = Vec::new();
        image::DynamicImage::ImageLuma8(img)
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        png
    }

    /// A fresh folder for one test.
    fn scratch(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("plotter-resources-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A line under a mask whose content is a white square and an `<image>` naming `href`: the mask is partly
    /// transparent (and says so) exactly when the image loads.
    fn masked(href: &str) -> String {
        format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100">
  <mask id="m" maskUnits="userSpaceOnUse" x="0" y="0" width="100" height="100">
    <rect width="100" height="100" fill="white"/>
    <image x="0" y="0" width="10" height="10" href="{href}"/>
  </mask>
  <g mask="url(#m)"><line x1="0" y1="50" x2="100" y2="50" stroke="black"/></g>
</svg>"#
        )
    }

    /// Import `doc`, leaving out the survey's "image not traced" notes (present whatever is loaded).
    fn import(doc: &str, policy: &ResourcePolicy) -> Result<super::super::Imported, SvgError> {
        let mut imported = import_svg(doc.as_bytes(), "t.svg", policy, &SvgOptions::default())?;
        imported.warnings.retain(|w| !w.contains("embedded raster image not traced"));
        Ok(imported)
    }

    const PARTIAL: &str = "mask(s) are partly transparent";

    /// Issue 22, item 1: under the web policy an `<image>` naming an existing file and one naming a missing
    /// file give the same drawing and the same warnings (the href itself aside): no file-existence oracle. The
    /// command-line policy, reading the same existing file, shows the difference the oracle was made of.
    #[test]
    fn web_policy_answers_alike_for_existing_and_missing_files() {
        let dir = scratch("oracle");
        std::fs::write(dir.join("there.png"), png()).unwrap();
        let there = dir.join("there.png").display().to_string();
        let missing = dir.join("missing.png").display().to_string();
        let web = ResourcePolicy::DataUrlsOnly;
        let a = import(&masked(&there), &web).unwrap();
        let b = import(&masked(&missing), &web).unwrap();
        assert_eq!(a.drawing, b.drawing);
        let neutral = |w: &[String], href: &str| w.iter().map(|s| s.replace(href, "HREF")).collect::<Vec<_>>();
        assert_eq!(neutral(&a.warnings, &there), neutral(&b.warnings, &missing));
        assert_eq!(neutral(&a.warnings, &there), ["t.svg: image \"HREF\" not loaded: only data: URLs are read here"]);
        // /dev/zero and a relative path are refused alike, at once.
        for href in ["/dev/zero", "there.png", "../x.png", "file:///etc/passwd"] {
            let r = import(&masked(href), &web).unwrap();
            assert_eq!(r.warnings, [format!("t.svg: image \"{href}\" not loaded: only data: URLs are read here")]);
        }
        // Beside the file, the existing image loads (the mask turns partly transparent) and the missing one does not.
        let cli = ResourcePolicy::beside(&dir.join("t.svg"));
        let loaded = import(&masked("there.png"), &cli).unwrap();
        assert!(loaded.warnings.iter().any(|w| w.contains(PARTIAL)), "{:?}", loaded.warnings);
        let absent = import(&masked("missing.png"), &cli).unwrap();
        assert!(!absent.warnings.iter().any(|w| w.contains(PARTIAL)), "{:?}", absent.warnings);
        assert!(absent.warnings[0].contains("\"missing.png\" not loaded: cannot open it"), "{:?}", absent.warnings);
        // A data: URL is read under both policies.
        let inline = import(&masked(&data_url("image/png", &png())), &web).unwrap();
        assert!(inline.warnings.iter().any(|w| w.contains(PARTIAL)), "{:?}", inline.warnings);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Issue 22, item 1 on the command line: what may be read beside the file, and each refusal with its reason.
    /// A FIFO, /dev/zero (directly and through a link) and a directory return at once without being opened.
    #[cfg(unix)]
    #[test]
    fn beside_file_reads_regular_files_in_the_folder_only() {
        use std::os::unix::fs::FileTypeExt;
        let dir = scratch("beside");
        std::fs::create_dir(dir.join("sub")).unwrap();
        std::fs::write(dir.join("sub/ok.png"), png()).unwrap();
        std::fs::write(dir.join("big.png"), vec![0u8; 2048]).unwrap();
        std::fs::write(dir.join("text.png"), b"not an image").unwrap();
        let fifo = dir.join("fifo.png");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status().unwrap();
        assert!(made.success());
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
        std::os::unix::fs::symlink("/dev/zero", dir.join("zero.png")).unwrap();
        std::os::unix::fs::symlink("/etc", dir.join("etc")).unwrap();
        let policy = ResourcePolicy::BesideFile { dir: dir.clone(), max_bytes: 1024 };
        let start = Instant::now();
        let cases = [
            ("sub/ok.png", None),
            ("fifo.png", Some("not a regular file (a directory, device, FIFO or socket)")),
            ("sub", Some("not a regular file (a directory, device, FIFO or socket)")),
            ("zero.png", Some("it leads outside the SVG's folder (a symbolic link)")),
            ("etc/passwd", Some("it leads outside the SVG's folder (a symbolic link)")),
            ("/dev/zero", Some("absolute paths are not read; name the file relative to the SVG's folder")),
            ("sub/../../x.png", Some("'..' is not allowed: the file must be in the SVG's folder or below it")),
            (
                "http://example.com/a.png",
                Some("URLs are not fetched; use a file path relative to the SVG or a data: URL"),
            ),
            ("big.png", Some("larger than the 1 MiB limit")),
            ("text.png", Some("not a PNG, JPEG, GIF, WebP or SVG image")),
        ];
        for (href, refusal) in cases {
            let r = import(&masked(href), &policy).unwrap();
            match refusal {
                None => assert!(r.warnings.iter().any(|w| w.contains(PARTIAL)), "{href}: {:?}", r.warnings),
                Some(why) => assert_eq!(r.warnings, [format!("t.svg: image \"{href}\" not loaded: {why}")]),
            }
        }
        assert!(start.elapsed() < Duration::from_secs(5), "{:?}", start.elapsed());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    fn nest(inner: &str) -> String {
        format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100"><image width="10" height="10" href="{}"/><line x1="0" y1="5" x2="50" y2="5" stroke="black"/></svg>"#,
            data_url("image/svg+xml", inner.as_bytes())
        )
    }

    /// Issue 22, item 3: an SVG image inside the document meets the outer document's limits — entity expansion,
    /// attribute count, gzip, nesting depth and a total budget — as a warning naming the limit; the rest imports.
    #[test]
    fn nested_svg_images_meet_the_outer_limits() {
        let web = ResourcePolicy::DataUrlsOnly;
        let warnings = |doc: &str| import(doc, &web).unwrap().warnings;
        let inner_ok =
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="4" height="4"><rect width="4" height="4"/></svg>"#;
        assert!(warnings(&nest(inner_ok)).is_empty());
        // Billion laughs inside.
        let mut laughs = String::from("<!DOCTYPE svg [<!ENTITY l0 \"lol\">");
        for i in 1..10 {
            laughs.push_str(&format!("<!ENTITY l{i} \"{}\">", format!("&l{};", i - 1).repeat(10)));
        }
        laughs.push_str("]><svg xmlns=\"http://www.w3.org/2000/svg\"><text>&l9;</text></svg>");
        let w = warnings(&nest(&laughs));
        assert!(w.len() == 1 && w[0].contains("nested SVG: entity &l8; expands to more than 64 MiB"), "{w:?}");
        // Too many attributes inside.
        let attrs: String = (0..300).map(|i| format!(" a{i}=\"1\"")).collect();
        let w = warnings(&nest(&format!("<svg xmlns=\"http://www.w3.org/2000/svg\"><g{attrs}/></svg>")));
        assert!(w.len() == 1 && w[0].contains("nested SVG: <g> at line 1 has more than 256 attributes"), "{w:?}");
        // A size usvg cannot handle (it panicked on this one, found by the fuzz test).
        let w = warnings(&nest(r#"<svg xmlns="http://www.w3.org/2000/svg" width="3e38" height="10"/>"#));
        assert!(w.len() == 1 && w[0].contains("nested SVG: <svg> width=\"3e38\" at line 1 is 7.938e37 mm"), "{w:?}");
        // Nesting: levels 1..=3 load, the fourth is refused.
        let mut doc = inner_ok.to_string();
        for _ in 0..4 {
            doc = nest(&doc);
        }
        let w = warnings(&doc);
        assert!(w.len() == 1 && w[0].ends_with("not loaded: SVG images nested more than 3 deep"), "{w:?}");
        // Budget: a nested SVG of 1 048 635 bytes shown by 40 `<use>`s is read 15 times (15 × 1 048 635 ≤ 16 MiB <
        // 16 × 1 048 635); the other 25 are refused.
        let big = format!("<svg xmlns=\"http://www.w3.org/2000/svg\"><desc>{}</desc></svg>", "x".repeat(1 << 20));
        let uses: String = (0..40).map(|i| format!("<use href=\"#i\" x=\"{i}\"/>")).collect();
        let doc = format!(
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="100" height="100"><defs><image id="i" width="1" height="1" href="{}"/></defs>{uses}<line x1="0" y1="5" x2="50" y2="5" stroke="black"/></svg>"#,
            data_url("image/svg+xml", big.as_bytes())
        );
        let start = Instant::now();
        let w = warnings(&doc);
        assert_eq!(
            w,
            ["t.svg: image \"data:image/svg+xml (1048635 bytes)\" not loaded (25 times): nested SVG images exceed 16 \
              MiB in all"]
        );
        assert!(start.elapsed() < Duration::from_secs(5), "{:?}", start.elapsed());
    }
}
