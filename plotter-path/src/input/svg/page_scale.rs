//! The layout factors an import holds for. Some of the import's choices compare a size in the document with a size
//! on the plotted page: an opaque stroke hides what lies under it when it is wider than four pen widths on the page
//! ([`super::walk`]), and a pattern fill is drawn when its tiles are wider than the pen on the page
//! (`walk::pattern`). The import makes them at [`super::SvgOptions::hatch_scale`], and records here the range of
//! factors that would make every one of them the same way; a front end that lays the drawing out by a factor outside
//! it decodes the drawing again at that factor.

/// The layout factors (page size over document size) for which every page-size choice of an import comes out as it
/// did: those above `above` and at most `up_to`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScaleRange {
    /// The factors must be more than this.
    pub above: f64,
    /// The factors must be at most this.
    pub up_to: f64,
}

impl Default for ScaleRange {
    /// Every factor: an import that made no page-size choice.
    fn default() -> Self {
        ScaleRange { above: 0.0, up_to: f64::INFINITY }
    }
}

impl ScaleRange {
    /// Whether the import at factor `factor` would come out the same.
    pub fn holds_for(&self, factor: f64) -> bool {
        factor > self.above && factor <= self.up_to
    }

    /// Whether any factor would change the import.
    pub fn is_everything(&self) -> bool {
        *self == ScaleRange::default()
    }

    /// Records a choice "`size × factor` is more than `limit`" made for `size` at the factor `used`: it holds
    /// while the factor stays on the same side of `limit / size`.
    pub(super) fn wider_than(&mut self, size: f64, limit: f64, used: f64) {
        if !(size > 0.0 && limit > 0.0) {
            return;
        }
        let flip = limit / size;
        if used > flip {
            self.above = self.above.max(flip);
        } else {
            self.up_to = self.up_to.min(flip);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_choice_holds_while_the_factor_stays_on_its_side() {
        // A 0.5 mm stroke against a 1.2 mm limit flips at 2.4×.
        let mut r = ScaleRange::default();
        r.wider_than(0.5, 1.2, 1.0);
        assert_eq!(r, ScaleRange { above: 0.0, up_to: 2.4 });
        assert!(r.holds_for(2.4) && !r.holds_for(2.41) && r.holds_for(0.1));
        // A 2 mm stroke wider than the limit at 1× holds down to 0.6×, exclusive.
        r.wider_than(2.0, 1.2, 1.0);
        assert!((r.above - 0.6).abs() < 1e-12 && r.up_to == 2.4, "{r:?}");
        assert!(!r.holds_for(0.6) && r.holds_for(0.61));
        assert!(!r.is_everything() && ScaleRange::default().is_everything());
    }
}
