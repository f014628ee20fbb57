//! A bound on the number of attributes of one element, checked on the text before any parser builds a tree.
//!
//! roxmltree looks for a duplicate among the attributes already read each time it reads one, so an element with n
//! attributes costs n²/2 comparisons (200 000 attributes in a 2.3 MB file ran over a minute). No SVG element
//! needs more than a few dozen attributes (the SVG 1.1 presentation attributes number about 60, and editors add
//! a handful of their own), so [`MAX_ATTRIBUTES`] is far above any real file and keeps that cost to about 33 000
//! comparisons per element, linear in the file's size.
//!
//! [`check_attributes`] scans start tags: it skips comments, CDATA sections, processing instructions, end tags
//! and declarations, and counts the `=` signs outside quoted values of each start tag (one per attribute in
//! well-formed XML). Entity values are markup too (an entity may hold an element), so the caller checks each of
//! them as well.

use super::dtd::line_of;

/// Most attributes accepted on one element.
pub const MAX_ATTRIBUTES: usize = 256;

/// Refuse `text` when one of its start tags has more than [`MAX_ATTRIBUTES`] attributes; `describe` turns the
/// tag's line within `text` into where it is for the message (e.g. "line 12", or "line 2 of entity &e;").
pub fn check_attributes(text: &str, describe: impl Fn(usize) -> String) -> Result<(), String> {
    let bytes = text.as_bytes();
    let mut pos = 0;
    while let Some(i) = text[pos..].find('<') {
        let start = pos + i;
        let rest = &text[start..];
        let (skip, end) = if rest.starts_with("<!--") {
            (4, "-->")
        } else if rest.starts_with("<![CDATA[") {
            (9, "]]>")
        } else if rest.starts_with("<?") {
            (2, "?>")
        } else if rest.starts_with("</") || rest.starts_with("<!") {
            (2, ">")
        } else {
            // A start tag: count '=' outside quotes up to its '>'.
            let mut count = 0usize;
            let mut quote: Option<u8> = None;
            let mut j = start + 1;
            while j < bytes.len() {
                let c = bytes[j];
                match quote {
                    Some(q) if c == q => quote = None,
                    Some(_) => {}
                    None if c == b'"' || c == b'\'' => quote = Some(c),
                    None if c == b'=' => count += 1,
                    None if c == b'>' => break,
                    None => {}
                }
                j += 1;
            }
            if count > MAX_ATTRIBUTES {
                let name_len = rest[1..].find(|c: char| c.is_whitespace() || c == '>' || c == '/').unwrap_or(0);
                return Err(format!(
                    "<{}> at {} has more than {MAX_ATTRIBUTES} attributes ({count})",
                    &rest[1..1 + name_len],
                    describe(line_of(text, start))
                ));
            }
            pos = j;
            continue;
        };
        match text[start + skip..].find(end) {
            Some(k) => pos = start + skip + k + end.len(),
            None => return Ok(()), // unterminated: the parser reports it
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at_line(l: usize) -> String {
        format!("line {l}")
    }

    #[test]
    fn counts_attributes_outside_quotes_comments_and_cdata() {
        let attrs = |n: usize| (0..n).map(|i| format!(" a{i}=\"x=y>\"")).collect::<String>();
        // Exactly the limit passes; quoted '=' and '>' do not count.
        let ok = format!("<svg>\n<g{}/></svg>", attrs(MAX_ATTRIBUTES));
        check_attributes(&ok, at_line).unwrap();
        let bad = format!("<svg>\n<!-- <x a=1> -->\n<g{}/></svg>", attrs(MAX_ATTRIBUTES + 1));
        let err = check_attributes(&bad, at_line).unwrap_err();
        assert_eq!(err, format!("<g> at line 3 has more than {MAX_ATTRIBUTES} attributes (257)"));
        // Inside comments, CDATA and processing instructions nothing is counted.
        let hidden = format!("<svg><!--<g{0}/>--><![CDATA[<g{0}/>]]><?p <g{0}/> ?></svg>", attrs(300));
        check_attributes(&hidden, at_line).unwrap();
    }
}
