//! What an import left out of the drawing, and why: a count per reason, so a front end (`plotter stats`, the web
//! app) can show that nothing the user gave disappeared silently. Each counted item also has a warning naming the
//! element; this is the summary beside those warnings.

use std::collections::BTreeMap;
use std::fmt;

/// Why an element of the input is not (or not wholly) in the drawing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SkipReason {
    /// Neither fill nor stroke, `display:none` or `visibility:hidden`.
    Invisible,
    /// Opacity 0 (the element or a group around it).
    Transparent,
    /// A subpath of a single point: nothing to draw.
    SinglePoint,
    /// A fill-only shape whose colour is that of what lies beneath it (e.g. white on the paper): no visible edge
    /// to outline; it still hides what lies under it.
    SameColourFill,
    /// An embedded raster image not traced (tracing is off, or the image kind cannot be traced).
    ImageNotTraced,
    /// An embedded raster image that cannot be decoded.
    ImageUndecodable,
    /// An element no plotter can draw (`foreignObject`, `video`, `canvas`…).
    UnsupportedElement,
    /// A shape of zero or negative size.
    DegenerateShape,
    /// A pattern fill whose tiles are finer than the pen.
    PatternTooFine,
    /// A pattern fill that would paint more shapes than the import allows.
    PatternTooLarge,
    /// A filled area not hatched: too many lines at the requested spacing.
    HatchRefused,
    /// An element cut at the page edge (`--crop`): the part outside the page is not drawn.
    CroppedAtPage,
}

impl SkipReason {
    /// Every reason, in the order reports list them.
    pub const ALL: [SkipReason; 12] = [
        SkipReason::Invisible,
        SkipReason::Transparent,
        SkipReason::SinglePoint,
        SkipReason::SameColourFill,
        SkipReason::ImageNotTraced,
        SkipReason::ImageUndecodable,
        SkipReason::UnsupportedElement,
        SkipReason::DegenerateShape,
        SkipReason::PatternTooFine,
        SkipReason::PatternTooLarge,
        SkipReason::HatchRefused,
        SkipReason::CroppedAtPage,
    ];

    /// A stable snake_case key for machine-readable output (JSON).
    pub fn key(self) -> &'static str {
        match self {
            SkipReason::Invisible => "invisible",
            SkipReason::Transparent => "transparent",
            SkipReason::SinglePoint => "single_point",
            SkipReason::SameColourFill => "same_colour_fill",
            SkipReason::ImageNotTraced => "image_not_traced",
            SkipReason::ImageUndecodable => "image_undecodable",
            SkipReason::UnsupportedElement => "unsupported_element",
            SkipReason::DegenerateShape => "degenerate_shape",
            SkipReason::PatternTooFine => "pattern_too_fine",
            SkipReason::PatternTooLarge => "pattern_too_large",
            SkipReason::HatchRefused => "hatch_refused",
            SkipReason::CroppedAtPage => "cropped_at_page",
        }
    }

    /// What was skipped and why, in words, for a count of items.
    pub fn describe(self) -> &'static str {
        match self {
            SkipReason::Invisible => "invisible shape(s) (no fill and no stroke, or hidden)",
            SkipReason::Transparent => "fully transparent shape(s)",
            SkipReason::SinglePoint => "single-point subpath(s)",
            SkipReason::SameColourFill => {
                "fill-only shape(s) not outlined: the colour of what lies beneath (e.g. white on white)"
            }
            SkipReason::ImageNotTraced => "raster image(s) not traced",
            SkipReason::ImageUndecodable => "raster image(s) that cannot be decoded",
            SkipReason::UnsupportedElement => "unsupported element(s)",
            SkipReason::DegenerateShape => "shape(s) of zero or negative size",
            SkipReason::PatternTooFine => "pattern fill(s) finer than the pen",
            SkipReason::PatternTooLarge => "pattern fill(s) with too many tiles",
            SkipReason::HatchRefused => "area(s) not hatched (too many lines)",
            SkipReason::CroppedAtPage => "element(s) cut at the page edge",
        }
    }
}

/// How many items of an input were skipped, per [`SkipReason`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Skipped {
    counts: BTreeMap<SkipReason, usize>,
}

impl Skipped {
    /// Count `n` more items skipped for `reason` (zero adds nothing).
    pub fn add(&mut self, reason: SkipReason, n: usize) {
        if n > 0 {
            *self.counts.entry(reason).or_insert(0) += n;
        }
    }

    /// Items skipped for `reason`.
    pub fn count(&self, reason: SkipReason) -> usize {
        self.counts.get(&reason).copied().unwrap_or(0)
    }

    /// Items skipped for any reason.
    pub fn total(&self) -> usize {
        self.counts.values().sum()
    }

    /// Whether nothing was skipped.
    pub fn is_empty(&self) -> bool {
        self.counts.is_empty()
    }

    /// The reasons with a count, in [`SkipReason::ALL`] order.
    pub fn iter(&self) -> impl Iterator<Item = (SkipReason, usize)> + '_ {
        self.counts.iter().map(|(r, n)| (*r, *n))
    }
}

/// `3 invisible shape(s) (…); 1 raster image(s) not traced`, or `nothing`.
impl fmt::Display for Skipped {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.is_empty() {
            return f.write_str("nothing");
        }
        for (i, (reason, n)) in self.iter().enumerate() {
            if i > 0 {
                f.write_str("; ")?;
            }
            write!(f, "{n} {}", reason.describe())?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_add_up_per_reason_and_zero_adds_nothing() {
        let mut s = Skipped::default();
        assert!(s.is_empty());
        assert_eq!(s.to_string(), "nothing");
        s.add(SkipReason::ImageNotTraced, 1);
        s.add(SkipReason::Invisible, 2);
        s.add(SkipReason::Invisible, 3);
        s.add(SkipReason::PatternTooFine, 0);
        assert_eq!(s.count(SkipReason::Invisible), 5);
        assert_eq!(s.count(SkipReason::PatternTooFine), 0);
        assert_eq!(s.total(), 6);
        // Listed in the order of ALL, whatever the order they were added in.
        assert_eq!(
            s.to_string(),
            "5 invisible shape(s) (no fill and no stroke, or hidden); 1 raster image(s) not traced"
        );
    }

    #[test]
    fn keys_are_distinct_and_all_is_in_declaration_order() {
        let keys: std::collections::HashSet<&str> = SkipReason::ALL.iter().map(|r| r.key()).collect();
        assert_eq!(keys.len(), SkipReason::ALL.len());
        assert!(SkipReason::ALL.windows(2).all(|w| w[0] < w[1]));
    }
}
