//! The internal DTD subset, read the way roxmltree reads it, and a bound on what its entities expand to.
//!
//! roxmltree (with `allow_dtd`) expands internal entities itself. It stops reference loops and limits one
//! reference to ten levels and 255 nested references, but it does not bound the total: a large entity referenced
//! many times at the top level multiplies the document's size until memory runs out. So before roxmltree sees the
//! text, [`Dtd::read`] finds the entity declarations exactly where roxmltree will find them — a real reading of the
//! prolog (XML declaration, comments, processing instructions), the `<!DOCTYPE`, its external identifier and the
//! internal subset (entity declarations with their quoted values, comments, processing instructions, other
//! declarations), not a text search that a `]>` inside a comment or a `<!DOCTYPE` inside a comment would fool —
//! and [`Dtd::check_expansion`] adds up the expanded size of every reference in the document (recursively, cycles
//! and nesting deeper than [`MAX_DEPTH`] refused) and refuses more than [`MAX_EXPANDED_BYTES`].
//!
//! The reader follows roxmltree 0.21's grammar: a DOCTYPE only counts right after the XML declaration and the
//! comments, processing instructions and white space that may follow it; a declaration's name is any run of
//! characters up to white space; parameter entities (`<!ENTITY % name …>`) are stored like general ones (roxmltree
//! resolves `&name;` against both); the first declaration of a name wins; external entities are not read
//! (roxmltree has no resolver here), so they expand to nothing. Where the text does not follow that grammar the
//! reader refuses it with the line — roxmltree would refuse it too. A reference is counted wherever `&name;` is
//! written after the DOCTYPE (also in comments and CDATA, which only over-counts), whatever characters its name
//! uses.

use std::collections::HashMap;

/// Largest total text that entity references may expand to.
pub const MAX_EXPANDED_BYTES: u64 = 64 << 20;

/// Deepest nesting of entity references followed (roxmltree itself stops at 10).
pub const MAX_DEPTH: usize = 16;

/// The internal subset of a document's DOCTYPE.
#[derive(Debug, Default)]
pub struct Dtd<'a> {
    /// Entity name → replacement text, first declaration of each name.
    pub entities: HashMap<&'a str, &'a str>,
    /// Byte offset just after the DOCTYPE (0 when there is none): where element content may begin.
    pub end: usize,
}

/// Is `c` XML white space?
fn is_space(c: u8) -> bool {
    matches!(c, b' ' | b'\t' | b'\n' | b'\r')
}

/// 1-based line of byte offset `at`.
pub fn line_of(text: &str, at: usize) -> usize {
    text.as_bytes()[..at.min(text.len())].iter().filter(|b| **b == b'\n').count() + 1
}

struct Reader<'a> {
    text: &'a str,
    pos: usize,
}

impl<'a> Reader<'a> {
    fn rest(&self) -> &'a str {
        &self.text[self.pos..]
    }

    fn starts_with(&self, s: &str) -> bool {
        self.rest().starts_with(s)
    }

    fn skip_spaces(&mut self) {
        while self.text.as_bytes().get(self.pos).copied().is_some_and(is_space) {
            self.pos += 1;
        }
    }

    fn error(&self, what: &str) -> String {
        format!("cannot read the DOCTYPE: {what} at line {}", line_of(self.text, self.pos))
    }

    /// Move past the next `end` (after `skip` bytes), or fail naming `what`.
    fn skip_past(&mut self, skip: usize, end: &str, what: &str) -> Result<(), String> {
        let from = self.pos + skip;
        match self.text.get(from..).and_then(|t| t.find(end)) {
            Some(i) => {
                self.pos = from + i + end.len();
                Ok(())
            }
            None => Err(self.error(&format!("unterminated {what}"))),
        }
    }

    /// A quoted literal; returns its content.
    fn quoted(&mut self) -> Result<&'a str, String> {
        let q = match self.text.as_bytes().get(self.pos) {
            Some(q @ (b'"' | b'\'')) => *q as char,
            _ => return Err(self.error("expected a quoted value")),
        };
        let start = self.pos + 1;
        let Some(len) = self.text[start..].find(q) else { return Err(self.error("unterminated quoted value")) };
        self.pos = start + len + 1;
        Ok(&self.text[start..start + len])
    }

    /// A name: any characters up to white space, a quote, `[` or `>`.
    fn name(&mut self) -> Result<&'a str, String> {
        let start = self.pos;
        let len = self.rest().find(|c: char| c.is_ascii_whitespace() || matches!(c, '"' | '\'' | '[' | '>'));
        self.pos += len.unwrap_or(self.rest().len());
        if self.pos == start {
            return Err(self.error("expected a name"));
        }
        Ok(&self.text[start..self.pos])
    }

    /// `SYSTEM "uri"` or `PUBLIC "id" "uri"`, if present.
    fn external_id(&mut self) -> Result<bool, String> {
        let public = self.starts_with("PUBLIC");
        if !public && !self.starts_with("SYSTEM") {
            return Ok(false);
        }
        self.pos += 6;
        self.skip_spaces();
        self.quoted()?;
        if public {
            self.skip_spaces();
            self.quoted()?;
        }
        Ok(true)
    }

    /// Comments, processing instructions and white space.
    fn misc(&mut self) -> Result<(), String> {
        loop {
            self.skip_spaces();
            if self.starts_with("<!--") {
                self.skip_past(4, "-->", "comment")?;
            } else if self.starts_with("<?") {
                self.skip_past(2, "?>", "processing instruction")?;
            } else {
                return Ok(());
            }
        }
    }

    /// `<?xml … ?>` at the very start (quoted values may hold `?>`).
    fn declaration(&mut self) -> Result<(), String> {
        if !self.starts_with("<?xml ") {
            return Ok(());
        }
        self.pos += 5;
        loop {
            self.skip_spaces();
            if self.starts_with("?>") {
                self.pos += 2;
                return Ok(());
            }
            match self.text.as_bytes().get(self.pos) {
                None => return Err(self.error("unterminated XML declaration")),
                Some(b'"' | b'\'') => {
                    self.quoted()?;
                }
                Some(_) => self.pos += 1,
            }
        }
    }

    /// `<!ENTITY [%] name "value" >` or with an external identifier; the reader stands on `<!ENTITY`.
    fn entity(&mut self, entities: &mut HashMap<&'a str, &'a str>) -> Result<(), String> {
        self.pos += "<!ENTITY".len();
        self.skip_spaces();
        if self.starts_with("%") {
            self.pos += 1;
            self.skip_spaces();
        }
        let name = self.name()?;
        self.skip_spaces();
        if matches!(self.text.as_bytes().get(self.pos), Some(b'"' | b'\'')) {
            let value = self.quoted()?;
            entities.entry(name).or_insert(value);
        } else if self.external_id()? {
            // Not read: roxmltree discards external entities without a resolver.
            self.skip_spaces();
            if self.starts_with("NDATA") {
                self.pos += 5;
                self.skip_spaces();
                self.name()?;
            }
        } else {
            return Err(self.error(&format!("entity {name} has neither a quoted value nor SYSTEM/PUBLIC")));
        }
        self.skip_spaces();
        if !self.starts_with(">") {
            return Err(self.error(&format!("expected '>' after entity {name}")));
        }
        self.pos += 1;
        Ok(())
    }
}

impl<'a> Dtd<'a> {
    /// Read the DOCTYPE of `text`, if it has one where roxmltree looks for it (see the module docs).
    pub fn read(text: &'a str) -> Result<Dtd<'a>, String> {
        let mut r = Reader { text, pos: 0 };
        if r.starts_with("\u{feff}") {
            r.pos += "\u{feff}".len();
        }
        r.declaration()?;
        r.misc()?;
        r.skip_spaces();
        if !r.starts_with("<!DOCTYPE") {
            return Ok(Dtd::default());
        }
        r.pos += "<!DOCTYPE".len();
        r.skip_spaces();
        r.name()?;
        r.skip_spaces();
        r.external_id()?;
        r.skip_spaces();
        let mut entities = HashMap::new();
        if r.starts_with(">") {
            return Ok(Dtd { entities, end: r.pos + 1 });
        }
        if !r.starts_with("[") {
            return Err(r.error("expected '[' or '>'"));
        }
        r.pos += 1;
        loop {
            r.skip_spaces();
            if r.starts_with("<!ENTITY") {
                r.entity(&mut entities)?;
            } else if r.starts_with("<!--") {
                r.skip_past(4, "-->", "comment")?;
            } else if r.starts_with("<?") {
                r.skip_past(2, "?>", "processing instruction")?;
            } else if r.starts_with("]") {
                r.pos += 1;
                r.skip_spaces();
                if !r.starts_with(">") {
                    return Err(r.error("expected '>' after ']'"));
                }
                return Ok(Dtd { entities, end: r.pos + 1 });
            } else if r.starts_with("<!ELEMENT") || r.starts_with("<!ATTLIST") || r.starts_with("<!NOTATION") {
                // roxmltree skips these to the first '>', quotes or not.
                r.skip_past(2, ">", "declaration")?;
            } else if r.pos >= text.len() {
                return Err(r.error("unterminated internal subset"));
            } else {
                return Err(r.error("unexpected text in the internal subset"));
            }
        }
    }

    /// Refuse `text` (whose DOCTYPE this is) when its entity references expand past [`MAX_EXPANDED_BYTES`].
    pub fn check_expansion(&self, text: &str) -> Result<(), String> {
        if self.entities.is_empty() {
            return Ok(());
        }
        let body = &text[self.end..];
        let mut sizes: HashMap<&str, u64> = HashMap::new();
        let mut total: u64 = 0;
        for (name, at) in references(body) {
            total = total.saturating_add(self.expanded_size(name, &mut sizes, &mut Vec::new())?);
            if total > MAX_EXPANDED_BYTES {
                return Err(format!(
                    "entity references expand to more than {} MiB (at &{name}; on line {}): refusing a possible \
                     \"billion laughs\" document",
                    MAX_EXPANDED_BYTES >> 20,
                    line_of(text, self.end + at)
                ));
            }
        }
        Ok(())
    }

    fn expanded_size(
        &self,
        name: &'a str,
        sizes: &mut HashMap<&'a str, u64>,
        stack: &mut Vec<&'a str>,
    ) -> Result<u64, String> {
        if let Some(s) = sizes.get(name) {
            return Ok(*s);
        }
        let Some(value) = self.entities.get(name) else { return Ok(0) };
        if stack.contains(&name) {
            return Err(format!("entity &{name}; refers to itself (through {})", stack.join(" → ")));
        }
        if stack.len() >= MAX_DEPTH {
            return Err(format!("entity references nested more than {MAX_DEPTH} deep (at &{name};)"));
        }
        stack.push(name);
        // The value's text with each reference to a declared entity replaced by that entity's expansion.
        let mut size = value.len() as u64;
        for (inner, _) in references(value) {
            if self.entities.contains_key(inner) {
                size = size.saturating_sub(inner.len() as u64 + 2);
                size = size.saturating_add(self.expanded_size(inner, sizes, stack)?);
            }
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
}

/// `(name, byte offset)` of every `&name;` in `text` that is not a character reference. The name is whatever
/// lies between `&` and `;` without white space, markup or quotes, so no spelling of a name escapes the count.
fn references(text: &str) -> impl Iterator<Item = (&str, usize)> {
    text.match_indices('&').filter_map(move |(i, _)| {
        let rest = &text[i + 1..];
        let end = rest.find(|c: char| c.is_whitespace() || matches!(c, ';' | '&' | '<' | '>' | '"' | '\''))?;
        let name = &rest[..end];
        (rest[end..].starts_with(';') && !name.is_empty() && !name.starts_with('#')).then_some((name, i))
    })
}

/// Refuse documents whose internal entities would expand past [`MAX_EXPANDED_BYTES`] (see the module docs);
/// returns the DOCTYPE read.
pub fn check_entities(text: &str) -> Result<Dtd<'_>, String> {
    let dtd = Dtd::read(text)?;
    dtd.check_expansion(text)?;
    Ok(dtd)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn laughs(levels: usize) -> String {
        let mut doc = String::from("<!ENTITY lol \"lol\">");
        let mut prev = "lol".to_string();
        for i in 1..levels {
            doc.push_str(&format!("<!ENTITY lol{i} \"{}\">", format!("&{prev};").repeat(10)));
            prev = format!("lol{i}");
        }
        format!("<?xml version=\"1.0\"?><!DOCTYPE svg [{doc}]><svg><text>&{prev};</text></svg>")
    }

    #[test]
    fn billion_laughs_is_refused_and_small_entities_pass() {
        // lol9 expands to 3 × 10⁹ bytes; lol7 to 3 × 10⁷ (28.6 MiB) passes, lol8 (286 MiB) is the first too large.
        let err = check_entities(&laughs(10)).unwrap_err();
        assert_eq!(err, "entity &lol8; expands to more than 64 MiB: refusing a possible \"billion laughs\" document");
        assert!(check_entities(&laughs(8)).is_ok());
        // lol5 expands to 3 × 10⁵ bytes: fine.
        assert!(check_entities(&laughs(6)).is_ok());
        let ok = "<!DOCTYPE svg [<!ENTITY ns \"http://www.w3.org/2000/svg\">]><svg xmlns=\"&ns;\"/>";
        let dtd = check_entities(ok).unwrap();
        assert_eq!(dtd.entities.get("ns"), Some(&"http://www.w3.org/2000/svg"));
        assert_eq!(&ok[dtd.end..dtd.end + 4], "<svg");
        let cyc = "<!DOCTYPE svg [<!ENTITY a \"&b;\"><!ENTITY b \"&a;\">]><svg>&a;</svg>";
        assert!(check_entities(cyc).unwrap_err().contains("refers to itself"));
        // Many top-level references to a large entity: 100 × 1 MiB.
        let big = format!("<!DOCTYPE svg [<!ENTITY b \"{}\">]><svg>{}</svg>", "x".repeat(1 << 20), "&b;".repeat(100));
        let err = check_entities(&big).unwrap_err();
        assert!(err.contains("more than 64 MiB") && err.contains("line 1"), "{err}");
    }

    /// The three ways round the old text search (issue 22, item 2), each on a document that expands to
    /// 65 × 1 MiB.
    #[test]
    fn the_three_bypasses_are_read_as_roxmltree_reads_them() {
        let value = "x".repeat(1 << 20);
        let refs = |name: &str| format!("&{name};").repeat(65);
        // 1. A "]>" inside a comment of the internal subset ended the old scan before the entity.
        let comment_end = format!("<!DOCTYPE svg [<!-- ]> --><!ENTITY b \"{value}\">]><svg>{}</svg>", refs("b"));
        // 2. A DOCTYPE inside a comment before the real one was taken for the real one.
        let decoy = format!("<!-- <!DOCTYPE x []> --><!DOCTYPE svg [<!ENTITY b \"{value}\">]><svg>{}</svg>", refs("b"));
        // 3. A name with a middle dot (a valid XML name character) was not counted as a reference.
        let dot = format!("<!DOCTYPE svg [<!ENTITY b·c \"{value}\">]><svg>{}</svg>", refs("b·c"));
        for (what, doc) in [("comment", comment_end), ("decoy", decoy), ("middle dot", dot)] {
            let err = check_entities(&doc).unwrap_err();
            assert!(err.contains("more than 64 MiB"), "{what}: {err}");
            // And roxmltree agrees these are entities that expand: with 64 references they parse.
            let small = doc.replacen(&"&b;".repeat(65), "&b;", 1).replacen(&"&b·c;".repeat(65), "&b·c;", 1);
            let opts = usvg::roxmltree::ParsingOptions { allow_dtd: true, ..Default::default() };
            let parsed = usvg::roxmltree::Document::parse_with_options(&small, opts).unwrap();
            assert_eq!(parsed.root_element().text().map(str::len), Some(1 << 20), "{what}");
        }
    }

    #[test]
    fn quoted_values_declarations_and_external_entities() {
        // "]>" and ">" inside a quoted entity value do not end anything; ATTLIST and PIs are skipped.
        let doc = "<?xml version=\"1.0\" encoding='utf-8'?>\n<!-- c --><?pi x?>\n<!DOCTYPE svg PUBLIC \"-//W3C//DTD SVG \
                   1.1//EN\" \"http://www.w3.org/Graphics/SVG/1.1/DTD/svg11.dtd\" [\n<!ATTLIST svg a CDATA #IMPLIED>\n\
                   <?p ]> ?><!ENTITY % pe \"p\"><!ENTITY q ']>'><!ENTITY q \"second\"><!ENTITY ext SYSTEM \"/etc/x\">\n]>\n<svg/>";
        let dtd = check_entities(doc).unwrap();
        assert_eq!(dtd.entities.get("q"), Some(&"]>"));
        assert_eq!(dtd.entities.get("pe"), Some(&"p"));
        assert!(!dtd.entities.contains_key("ext"));
        assert_eq!(&doc[dtd.end..], "\n<svg/>");
        // No DOCTYPE before the root: nothing to read.
        assert_eq!(Dtd::read("<svg><!DOCTYPE x [<!ENTITY a \"b\">]></svg>").unwrap().end, 0);
        // Malformed: refused with the line.
        let err = Dtd::read("<!DOCTYPE svg [\n<!ENTITY a b>]><svg/>").unwrap_err();
        assert!(err.contains("line 2"), "{err}");
        assert!(Dtd::read("<!DOCTYPE svg [<!ENTITY a \"b\">").unwrap_err().contains("unterminated"));
        // A deep chain is refused without deep recursion.
        let mut chain = String::from("<!DOCTYPE svg [");
        for i in 0..5000 {
            chain.push_str(&format!("<!ENTITY e{i} \"&e{};\">", i + 1));
        }
        chain.push_str("]><svg>&e0;</svg>");
        assert!(check_entities(&chain).unwrap_err().contains("nested more than 16 deep"));
    }
}
