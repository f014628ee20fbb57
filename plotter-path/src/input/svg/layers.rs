//! Layer groups without an `id`. usvg keeps every `<g>` but tells them apart only by their `id`, so an Inkscape
//! layer (`inkscape:groupmode="layer"`) or a top-level group without one could not be found again in its tree
//! and its shapes would fall into the `root` layer. Before usvg sees the document, each such group gets a
//! synthetic `id` written into the source text (after its tag name, on the same line, so every line number in
//! later messages stays right), and the text is parsed again. The synthetic ids share a prefix that occurs
//! nowhere in the original text, so they cannot meet a real id or any reference to one.

use usvg::roxmltree;

use crate::config::layer_codes::LayerCodes;
use crate::geometry::drawing::Layer;

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

/// Read the layer-name codes of `layers` (see [`crate::config::layer_codes`]): documentation layers (`%`) are
/// taken out, and said once; a code out of range is said for its layer. Returns the warnings, each starting with
/// `file` (the input as messages name it).
pub(super) fn read_codes(layers: &mut Vec<Layer>, file: &str) -> Vec<String> {
    let mut warnings = Vec::new();
    let mut documentation = Vec::new();
    layers.retain(|l| {
        let codes = LayerCodes::parse(&l.name);
        for p in &codes.problems {
            warnings.push(format!("{file}: layer '{}': {p}", l.name));
        }
        if codes.documentation {
            documentation.push(format!("'{}'", l.name));
        }
        !codes.documentation
    });
    if !documentation.is_empty() {
        warnings.push(format!(
            "{file}: {} documentation layer(s) not plotted (a name starting with % marks one): {}",
            documentation.len(),
            documentation.join(", ")
        ));
    }
    warnings
}

/// Whether `--layers` entry `wanted` selects the layer named `name` by its leading number (`--layers 1,3`).
pub(super) fn by_number(name: &str, wanted: &str) -> bool {
    LayerCodes::parse(name).selected_by_number(wanted)
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

#[cfg(test)]
mod code_tests {
    use crate::input::svg::{ResourcePolicy, SvgError, SvgOptions, import_svg};

    /// Four Inkscape layers, one 10 mm line each: "1 outline", "%notes" (documentation), "2+S50 detail",
    /// "!3 fill".
    const FOUR: &str = r#"<svg xmlns="http://www.w3.org/2000/svg" xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape" width="100mm" height="100mm" viewBox="0 0 100 100">
<g inkscape:groupmode="layer" inkscape:label="1 outline"><path d="M10 10 H20" stroke="black"/></g>
<g inkscape:groupmode="layer" inkscape:label="%notes"><path d="M10 20 H20" stroke="black"/></g>
<g inkscape:groupmode="layer" inkscape:label="2+S50 detail"><path d="M10 30 H20" stroke="black"/></g>
<g inkscape:groupmode="layer" inkscape:label="!3 fill"><path d="M10 40 H20" stroke="black"/></g>
</svg>"#;

    fn names(layers: &[&str]) -> Result<(Vec<String>, Vec<String>), SvgError> {
        let options = SvgOptions { layers: layers.iter().map(|s| s.to_string()).collect(), ..SvgOptions::default() };
        let i = import_svg(FOUR.as_bytes(), "four.svg", &ResourcePolicy::DataUrlsOnly, &options)?;
        Ok((i.drawing.layers.iter().map(|l| l.name.clone()).collect(), i.warnings))
    }

    #[test]
    fn documentation_layers_are_left_out_once_said_and_numbers_select() {
        let (all, warnings) = names(&[]).unwrap();
        assert_eq!(all, ["1 outline", "2+S50 detail", "!3 fill"]);
        let said: Vec<&String> = warnings.iter().filter(|w| w.contains("documentation")).collect();
        assert_eq!(
            said,
            ["four.svg: 1 documentation layer(s) not plotted (a name starting with % marks one): '%notes'"]
        );
        // `--layers 1,3`: by number; a full name still works beside it.
        assert_eq!(names(&["1", "3"]).unwrap().0, ["1 outline", "!3 fill"]);
        assert_eq!(names(&["2+S50 detail"]).unwrap().0, ["2+S50 detail"]);
        // A number no layer carries is refused naming the layers.
        let e = names(&["4"]).unwrap_err().to_string();
        assert!(e.contains("no layer named '4'; layers are: 1 outline, 2+S50 detail, !3 fill"), "{e}");
        // The documentation layer cannot be selected: it is never plotted.
        assert!(names(&["%notes"]).is_err());
    }
}
