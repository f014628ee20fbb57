//! From file bytes to a parsed XML tree, through every check that keeps hostile files bounded: gzip (`.svgz`, or
//! gzip bytes under any name) inflated up to a cap, the byte order mark or the declared `encoding` (ISO-8859-x,
//! Windows-125x, UTF-16, … through encoding_rs, the decoder of the WHATWG Encoding Standard that browsers follow),
//! the bound on internal DTD entity expansion ([`super::dtd`]), the bound on attributes per element
//! ([`super::attributes`]) and roxmltree's node limit. [`checked_text`] and [`parse_xml`] are the one path every
//! SVG takes — the imported file and every SVG image nested in it ([`super::resources`]).

use std::io::Read;

use usvg::roxmltree;

use super::attributes::check_attributes;
use super::dtd::{Dtd, check_entities};

/// Largest decompressed size accepted from a gzip-compressed SVG.
pub const MAX_INFLATED_BYTES: u64 = 256 << 20;

/// Most XML nodes accepted (bounds the parser's memory on huge or hostile files).
pub const MAX_NODES: u32 = 5_000_000;

/// True when `data` starts with the gzip magic number.
pub fn is_gzip(data: &[u8]) -> bool {
    data.starts_with(&[0x1f, 0x8b])
}

/// Inflate gzip data, refusing more than `max` bytes.
pub fn gunzip(data: &[u8], max: u64) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let mut reader = flate2::read::GzDecoder::new(data).take(max.saturating_add(1));
    reader.read_to_end(&mut out).map_err(|e| format!("gzip-compressed data is corrupt ({e})"))?;
    if out.len() as u64 > max {
        return Err(format!("gzip-compressed data inflates to more than {}", mib(max)));
    }
    Ok(out)
}

fn mib(bytes: u64) -> String {
    if bytes >= 1 << 20 { format!("{} MiB", bytes >> 20) } else { format!("{bytes} bytes") }
}

/// SVG file bytes (plain or gzip-compressed, inflating to at most `max_inflated` bytes) as checked XML text:
/// decoded, not empty, entity expansion and attribute counts within bounds (see the module docs).
pub fn checked_text(data: &[u8], max_inflated: u64) -> Result<String, String> {
    let inflated;
    let data = if is_gzip(data) {
        inflated = gunzip(data, max_inflated)?;
        inflated.as_slice()
    } else {
        data
    };
    let text = decode_xml(data)?;
    if text.trim().is_empty() {
        return Err(format!(
            "the file is empty ({} bytes{})",
            data.len(),
            if data.is_empty() { "" } else { ", all white space" }
        ));
    }
    let dtd = check_entities(&text)?;
    check_markup(&text, &dtd)?;
    Ok(text)
}

/// The attribute bound over the document's elements and over every entity value (entities may hold elements).
fn check_markup(text: &str, dtd: &Dtd<'_>) -> Result<(), String> {
    let first_line = super::dtd::line_of(text, dtd.end);
    check_attributes(&text[dtd.end..], |line| format!("line {}", line + first_line - 1))?;
    for (name, value) in &dtd.entities {
        check_attributes(value, |line| format!("line {line} of entity &{name};"))?;
    }
    Ok(())
}

/// Parse checked text ([`checked_text`]) with DTDs allowed and at most [`MAX_NODES`] nodes.
pub fn parse_xml(text: &str) -> Result<roxmltree::Document<'_>, String> {
    let parsing = roxmltree::ParsingOptions { allow_dtd: true, nodes_limit: MAX_NODES, ..Default::default() };
    roxmltree::Document::parse_with_options(text, parsing).map_err(|e| e.to_string())
}

/// Decode XML bytes to text: BOM first, then a UTF-16 signature without BOM, then the declared encoding, else
/// UTF-8 (which must then be valid: a browser shows an XML error for malformed UTF-8 too).
pub fn decode_xml(data: &[u8]) -> Result<String, String> {
    if let Some((encoding, bom_len)) = encoding_rs::Encoding::for_bom(data) {
        return decode_with(encoding, &data[bom_len..]);
    }
    // "<?" in UTF-16 without a byte order mark.
    if data.starts_with(&[0x3c, 0x00, 0x3f, 0x00]) {
        return decode_with(encoding_rs::UTF_16LE, data);
    }
    if data.starts_with(&[0x00, 0x3c, 0x00, 0x3f]) {
        return decode_with(encoding_rs::UTF_16BE, data);
    }
    if let Some(label) = declared_encoding(data) {
        let encoding = encoding_rs::Encoding::for_label(label.as_bytes())
            .ok_or_else(|| format!("unknown encoding \"{label}\" declared in the XML declaration"))?;
        // A UTF-16 declaration in a file that reached this point has no BOM and is ASCII-readable: it lies.
        if encoding != encoding_rs::UTF_16LE && encoding != encoding_rs::UTF_16BE && encoding != encoding_rs::UTF_8 {
            return decode_with(encoding, data);
        }
    }
    match std::str::from_utf8(data) {
        Ok(text) => Ok(text.to_owned()),
        Err(e) => {
            let at = e.valid_up_to();
            let line = data[..at].iter().filter(|b| **b == b'\n').count() + 1;
            Err(format!(
                "not UTF-8 text: invalid byte 0x{:02x} at line {line} (byte {at}); declare the file's encoding in \
                 its XML declaration",
                data[at]
            ))
        }
    }
}

fn decode_with(encoding: &'static encoding_rs::Encoding, data: &[u8]) -> Result<String, String> {
    let (text, had_errors) = encoding.decode_without_bom_handling(data);
    if had_errors && encoding == encoding_rs::UTF_8 {
        return Err("not UTF-8 text: malformed byte sequence".to_owned());
    }
    if had_errors {
        // Single-byte encodings map every byte; only UTF-16 (odd length, lone surrogates) gets here.
        return Err(format!("malformed {} text", encoding.name()));
    }
    Ok(text.into_owned())
}

/// The `encoding="…"` of an XML declaration at the very start, read as ASCII.
fn declared_encoding(data: &[u8]) -> Option<String> {
    let head = &data[..data.len().min(200)];
    if !head.starts_with(b"<?xml") {
        return None;
    }
    let end = head.windows(2).position(|w| w == b"?>")?;
    let decl = std::str::from_utf8(&head[..end]).ok()?;
    let at = decl.find("encoding")?;
    let rest = decl[at + "encoding".len()..].trim_start().strip_prefix('=')?.trim_start();
    let quote = rest.chars().next().filter(|c| *c == '"' || *c == '\'')?;
    let value = &rest[1..];
    Some(value[..value.find(quote)?].trim().to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encodings_by_bom_and_declaration() {
        // "é" is 0xe9 in ISO-8859-1 and Windows-1252; "Ж" is 0xc6 in Windows-1251.
        let latin = b"<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?><svg id=\"caf\xe9\"/>";
        assert!(decode_xml(latin).unwrap().contains("café"));
        let cyr = b"<?xml version='1.0' encoding='windows-1251'?><svg id=\"\xc6\"/>";
        assert!(decode_xml(cyr).unwrap().contains('Ж'));
        let utf16: Vec<u8> =
            [0xff, 0xfe].into_iter().chain("<svg id=\"é\"/>".encode_utf16().flat_map(u16::to_le_bytes)).collect();
        assert_eq!(decode_xml(&utf16).unwrap(), "<svg id=\"é\"/>");
        let utf16be: Vec<u8> = "<?xml version=\"1.0\"?><svg/>".encode_utf16().flat_map(u16::to_be_bytes).collect();
        assert_eq!(decode_xml(&utf16be).unwrap(), "<?xml version=\"1.0\"?><svg/>");
        let err = decode_xml(b"<svg>\n\xff</svg>").unwrap_err();
        assert!(err.contains("line 2") && err.contains("0xff"), "{err}");
        let err = decode_xml(b"<?xml version=\"1.0\" encoding=\"klingon\"?><svg/>").unwrap_err();
        assert!(err.contains("klingon"), "{err}");
    }

    #[test]
    fn gzip_round_trip_and_limits() {
        use std::io::Write;
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(b"<svg/>").unwrap();
        let gz = enc.finish().unwrap();
        assert!(is_gzip(&gz));
        assert_eq!(gunzip(&gz, MAX_INFLATED_BYTES).unwrap(), b"<svg/>");
        assert!(gunzip(&gz[..gz.len() - 6], MAX_INFLATED_BYTES).unwrap_err().contains("corrupt"));
        // "<svg/>" is 6 bytes: a 5-byte cap refuses it.
        assert_eq!(gunzip(&gz, 5).unwrap_err(), "gzip-compressed data inflates to more than 5 bytes");
    }
}
