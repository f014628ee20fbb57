//! Layer groups without an `id`. usvg keeps every `<g>` but tells them apart only by their `id`, so an Inkscape
//! layer (`inkscape:groupmode="layer"`) or a top-level group without one could not be found again in its tree
//! and its shapes would fall into the `root` layer. Before usvg sees the document, each such group gets a
//! synthetic `id` written into the source text (after its tag name, on the same line, so every line number in
//! later messages stays right), and the text is parsed again. The synthetic ids share a prefix that occurs
//! nowhere in the original text, so they cannot meet a real id or any reference to one.

use usvg::roxmltree;

/// The Inkscape namespace.
pub(super) const INKSCAPE: &str = "http://www.inkscape.org/namespaces/inkscape";

/// The `<g>` elements that make layers: Inkscape layers anywhere, and top-level groups.
pub(super) fn is_layer_group(node: roxmltree::Node<'_, '_>) -> bool {
    node.is_element()
        && node.tag_name().name() == "g"
        && (node.attribute((INKSCAPE, "groupmode")) == Some("layer")
            || node.parent_element() == Some(node.document().root_element()))
}

/// A prefix for synthetic ids that occurs nowhere in `text`.
pub(super) fn synthetic_prefix(text: &str) -> String {
    let mut prefix = String::from("plotter-layer-");
    while text.contains(&prefix) {
        prefix.insert(0, 'x');
    }
    prefix
}

/// `text` with an `id="{prefix}{n}"` added to every layer group ([`is_layer_group`]) that has none, or `None`
/// when every layer group has an id. A group whose start tag is not literally in the text (it came from an
/// entity) is left as it is.
pub(super) fn name_layer_groups(text: &str, xml: &roxmltree::Document<'_>, prefix: &str) -> Option<String> {
    let mut at = Vec::new();
    for node in xml.descendants().filter(|n| is_layer_group(*n) && n.attribute("id").is_none()) {
        let start = node.range().start;
        let Some(tag) = text.get(start..).and_then(|t| t.strip_prefix('<')) else { continue };
        let name_len = tag.find(|c: char| c.is_whitespace() || c == '/' || c == '>').unwrap_or(tag.len());
        let name = &tag[..name_len];
        if name == "g" || name.ends_with(":g") {
            at.push(start + 1 + name_len);
        }
    }
    if at.is_empty() {
        return None;
    }
    let mut out = String::with_capacity(text.len() + at.len() * (prefix.len() + 12));
    let mut from = 0;
    for (n, pos) in at.into_iter().enumerate() {
        out.push_str(&text[from..pos]);
        out.push_str(&format!(" id=\"{prefix}{}\"", n + 1));
        from = pos;
    }
    out.push_str(&text[from..]);
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layer_groups_without_ids_get_unique_ones_on_the_same_line() {
        let text = "<svg xmlns=\"http://www.w3.org/2000/svg\" xmlns:i=\"http://www.inkscape.org/namespaces/inkscape\">\n\
                    <g i:groupmode=\"layer\"><g><g i:groupmode=\"layer\"/></g></g>\n<g id=\"a\"/><g>\n</g></svg>";
        let xml = roxmltree::Document::parse(text).unwrap();
        let prefix = synthetic_prefix(text);
        assert_eq!(prefix, "plotter-layer-");
        let named = name_layer_groups(text, &xml, &prefix).unwrap();
        // The outer layer, the nested layer and the last top-level group; not the plain inner group nor "a".
        assert_eq!(
            named,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" xmlns:i=\"http://www.inkscape.org/namespaces/inkscape\">\n\
             <g id=\"plotter-layer-1\" i:groupmode=\"layer\"><g><g id=\"plotter-layer-2\" i:groupmode=\"layer\"/>\
             </g></g>\n<g id=\"a\"/><g id=\"plotter-layer-3\">\n</g></svg>"
        );
        // A document that already uses the prefix gets a longer one.
        assert_eq!(synthetic_prefix("<g id=\"plotter-layer-1\"/>"), "xplotter-layer-");
        // Nothing to name: None.
        let plain = "<svg xmlns=\"http://www.w3.org/2000/svg\"><g id=\"a\"/><rect/></svg>";
        assert!(name_layer_groups(plain, &roxmltree::Document::parse(plain).unwrap(), "p").is_none());
    }
}
