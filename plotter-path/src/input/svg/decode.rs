//! From file bytes to XML text a browser would read: gzip (`.svgz`, or gzip bytes under any name), the byte
//! order mark or the declared `encoding` (ISO-8859-x, Windows-125x, UTF-16, … through encoding_rs, the decoder of
//! the WHATWG Encoding Standard that browsers follow), and a bound on internal DTD entity expansion.
//!
//! **Entities.** roxmltree expands internal entities itself (with `allow_dtd`) and stops loops and deeply nested
//! references, but a large entity referenced many times at the top level can still multiply the document's size.
//! Before parsing, [`check_entities`] computes the expanded size of every `<!ENTITY name "value">` of the internal
//! subset (recursively, cycles reported) and the total the document's references would expand to; over
//! [`MAX_EXPANDED_BYTES`] is an error naming the entity, so a "billion laughs" file fails fast in bounded memory.

use std::collections::HashMap;
use std::io::Read;

/// Largest decompressed size accepted from a gzip-compressed SVG.
pub const MAX_INFLATED_BYTES: u64 = 256 << 20;

/// Largest total text that entity references may expand to.
pub const MAX_EXPANDED_BYTES: u64 = 64 << 20;

/// Most XML nodes accepted (bounds the parser's memory on huge or hostile files).
pub const MAX_NODES: u32 = 5_000_000;

/// True when `data` starts with the gzip magic number.
pub fn is_gzip(data: &[u8]) -> bool {
    data.starts_with(&[0x1f, 0x8b])
}

/// Inflate gzip data, refusing more than [`MAX_INFLATED_BYTES`].
pub fn gunzip(data: &[u8]) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    let mut reader = flate2::read::GzDecoder::new(data).take(MAX_INFLATED_BYTES + 1);
    reader.read_to_end(&mut out).map_err(|e| format!("gzip-compressed data is corrupt ({e})"))?;
    if out.len() as u64 > MAX_INFLATED_BYTES {
        return Err(format!("gzip-compressed data inflates to more than {} MiB", MAX_INFLATED_BYTES >> 20));
    }
    Ok(out)
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

/// Refuse documents whose internal entities would expand past [`MAX_EXPANDED_BYTES`] (see the module docs).
pub fn check_entities(text: &str) -> Result<(), String> {
    let Some(start) = text.find("<!DOCTYPE") else { return Ok(()) };
    let Some(open) = text[start..].find('[').map(|i| start + i) else { return Ok(()) };
    // The internal subset ends at the first "]>" (entity values containing "]>" are not worth supporting here).
    let Some(close) = text[open..].find("]>").map(|i| open + i) else { return Ok(()) };
    let subset = &text[open + 1..close];
    let mut values: HashMap<&str, &str> = HashMap::new();
    let mut rest = subset;
    while let Some(i) = rest.find("<!ENTITY") {
        rest = &rest[i + "<!ENTITY".len()..];
        let decl = rest.trim_start();
        if decl.starts_with('%') {
            continue; // parameter entities are not expanded by the parser
        }
        let name_end = decl.find(|c: char| c.is_whitespace()).unwrap_or(decl.len());
        let name = &decl[..name_end];
        let after = decl[name_end..].trim_start();
        if let Some(q) = after.chars().next().filter(|c| *c == '"' || *c == '\'')
            && let Some(len) = after[1..].find(q)
        {
            values.entry(name).or_insert(&after[1..1 + len]);
        }
    }
    if values.is_empty() {
        return Ok(());
    }
    let mut sizes: HashMap<&str, u64> = HashMap::new();
    for name in values.keys() {
        expanded_size(name, &values, &mut sizes, &mut Vec::new())?;
    }
    let mut total: u64 = 0;
    for (name, _) in references(&text[close..]) {
        total = total.saturating_add(sizes.get(name).copied().unwrap_or(0));
        if total > MAX_EXPANDED_BYTES {
            return Err(format!(
                "entity references expand to more than {} MiB (at &{name};): refusing a possible \"billion laughs\" \
                 document",
                MAX_EXPANDED_BYTES >> 20
            ));
        }
    }
    Ok(())
}

/// `(name, byte offset)` of every general entity reference `&name;` (character references excluded).
fn references(text: &str) -> impl Iterator<Item = (&str, usize)> {
    text.match_indices('&').filter_map(move |(i, _)| {
        let rest = &text[i + 1..];
        let end = rest.find(';')?;
        let name = &rest[..end];
        let ok = !name.is_empty()
            && !name.starts_with('#')
            && name.chars().all(|c| c.is_alphanumeric() || matches!(c, '_' | '-' | '.' | ':'));
        ok.then_some((name, i))
    })
}

fn expanded_size<'a>(
    name: &'a str,
    values: &HashMap<&'a str, &'a str>,
    sizes: &mut HashMap<&'a str, u64>,
    stack: &mut Vec<&'a str>,
) -> Result<u64, String> {
    if let Some(s) = sizes.get(name) {
        return Ok(*s);
    }
    let Some(value) = values.get(name) else { return Ok(0) };
    if stack.contains(&name) {
        return Err(format!("entity &{name}; refers to itself (through {})", stack.join(" → ")));
    }
    stack.push(name);
    let mut size = value.len() as u64;
    for (inner, _) in references(value) {
        let s = expanded_size(inner, values, sizes, stack)?;
        size = size.saturating_add(s);
    }
    stack.pop();
    if size > MAX_EXPANDED_BYTES {
        return Err(format!(
            "entity &{name}; expands to more than {} MiB: refusing a possible \"billion laughs\" document",
            MAX_EXPANDED_BYTES >> 20
        ));
    }
    sizes.insert(name, size);
    Ok(size)
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
        assert_eq!(gunzip(&gz).unwrap(), b"<svg/>");
        assert!(gunzip(&gz[..gz.len() - 6]).unwrap_err().contains("corrupt"));
    }

    #[test]
    fn billion_laughs_is_refused_and_small_entities_pass() {
        let mut doc = String::from("<?xml version=\"1.0\"?><!DOCTYPE svg [<!ENTITY lol \"lol\">");
        let mut prev = "lol".to_string();
        for i in 1..10 {
            let refs = format!("&{prev};").repeat(10);
            doc.push_str(&format!("<!ENTITY lol{i} \"{refs}\">"));
            prev = format!("lol{i}");
        }
        doc.push_str(&format!("]><svg><text>&{prev};</text></svg>"));
        // lol9 expands to 3 × 10⁹ bytes.
        let err = check_entities(&doc).unwrap_err();
        assert!(err.contains("billion laughs"), "{err}");
        let ok = "<!DOCTYPE svg [<!ENTITY ns \"http://www.w3.org/2000/svg\">]><svg xmlns=\"&ns;\"/>";
        assert!(check_entities(ok).is_ok());
        let cyc = "<!DOCTYPE svg [<!ENTITY a \"&b;\"><!ENTITY b \"&a;\">]><svg>&a;</svg>";
        assert!(check_entities(cyc).unwrap_err().contains("refers to itself"));
        // Many top-level references to a large entity.
        let big = format!("<!DOCTYPE svg [<!ENTITY b \"{}\">]><svg>{}</svg>", "x".repeat(1 << 20), "&b;".repeat(100));
        assert!(check_entities(&big).unwrap_err().contains("more than 64 MiB"));
    }
}
