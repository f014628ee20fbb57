//! Warning bookkeeping shared by the G-code and HP-GL importers: every warning is counted in constant time, and
//! the distinct messages kept are bounded, so a file of 200,000 lines that each warn differently (`M5000 P1`,
//! `M5000 P2`, …) costs neither quadratic time nor a list of 200,000 messages.
//!
//! A warning has a *kind* (a fixed text chosen where it is raised, such as "unsupported M code") and a *message*
//! (what the user reads, often naming the input: `M5000: not supported, ignored (M5000 P17)`). Repeats of one
//! message are counted against its first place (a hash map, not a search of the list). Each kind keeps its first
//! [`KEPT_PER_KIND`] distinct messages; later new messages of that kind are only counted, and [`Tally::finish`]
//! adds one line per such kind: "… and N more like it", placed at the first one left out.
//!
//! (Declared from [`super::gcode_in`] with a `#[path]`, since `input/mod.rs` belongs to another part of the tree.)

use std::collections::HashMap;

/// Distinct messages kept per kind; further ones are counted in one summary line.
pub(crate) const KEPT_PER_KIND: usize = 20;

/// One warning as reported: where it first happened, a tag (HP-GL's mnemonic, empty for G-code), how often, and
/// the message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Noted {
    /// First line (G-code) or command index (HP-GL); 0 for the whole file.
    pub(crate) at: usize,
    /// The HP-GL mnemonic, or empty.
    pub(crate) tag: String,
    /// Occurrences.
    pub(crate) count: usize,
    /// The text.
    pub(crate) message: String,
}

/// The messages of one kind beyond [`KEPT_PER_KIND`].
#[derive(Debug, Clone)]
struct Overflow {
    at: usize,
    tag: String,
    count: usize,
}

/// Warnings counted by kind and message (see the module docs).
#[derive(Debug, Default)]
pub(crate) struct Tally {
    kept: Vec<Noted>,
    /// (tag, message) → index in `kept`.
    index: HashMap<(String, String), usize>,
    /// kind → distinct messages kept.
    distinct: HashMap<&'static str, usize>,
    /// Kinds over their cap, in order of their first message left out.
    overflow: Vec<(&'static str, Overflow)>,
}

impl Tally {
    /// Count one warning of `kind` at `at` with `tag` and `message`.
    pub(crate) fn note(&mut self, at: usize, kind: &'static str, tag: &str, message: String) {
        let key = (tag.to_string(), message);
        if let Some(&i) = self.index.get(&key) {
            self.kept[i].count += 1;
            return;
        }
        let n = self.distinct.entry(kind).or_insert(0);
        if *n < KEPT_PER_KIND {
            *n += 1;
            self.index.insert(key.clone(), self.kept.len());
            self.kept.push(Noted { at, tag: key.0, count: 1, message: key.1 });
            return;
        }
        match self.overflow.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, o)) => o.count += 1,
            None => self.overflow.push((kind, Overflow { at, tag: key.0, count: 1 })),
        }
    }

    /// The warnings: those kept in order of first occurrence, then one "… more like it" line per kind that had
    /// more distinct messages than [`KEPT_PER_KIND`].
    pub(crate) fn finish(mut self) -> Vec<Noted> {
        for (kind, o) in self.overflow {
            self.kept.push(Noted {
                at: o.at,
                tag: o.tag,
                count: 1,
                message: format!(
                    "and {} more like it ({kind}; only the first {KEPT_PER_KIND} different ones are listed)",
                    o.count
                ),
            });
        }
        self.kept
    }

    /// Warnings noted so far, summary lines excluded (for tests).
    #[cfg(test)]
    pub(crate) fn kept(&self) -> usize {
        self.kept.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeats_are_counted_and_distinct_messages_capped_per_kind() {
        let mut t = Tally::default();
        for n in 0..1000 {
            t.note(n + 1, "unsupported M code", "", format!("M5000 P{n}: ignored"));
            t.note(n + 1, "tool change", "", "tool change ignored".to_string());
        }
        t.note(5000, "unsupported M code", "", "M5000 P3: ignored".to_string());
        assert_eq!(t.kept(), KEPT_PER_KIND + 1);
        let out = t.finish();
        assert_eq!(out.len(), KEPT_PER_KIND + 2);
        // M5000 P3 came again: counted with its first line.
        assert_eq!(out[4], Noted { at: 4, tag: String::new(), count: 2, message: "M5000 P3: ignored".into() });
        // The tool change: one message, 1000 times, from line 1.
        assert_eq!((out[1].at, out[1].count), (1, 1000));
        let last = out.last().unwrap();
        assert_eq!(last.at, KEPT_PER_KIND + 1);
        assert_eq!(
            last.message,
            "and 980 more like it (unsupported M code; only the first 20 different ones are listed)"
        );
    }

    #[test]
    fn tags_keep_equal_messages_apart() {
        let mut t = Tally::default();
        t.note(1, "k", "LB", "x".into());
        t.note(2, "k", "CI", "x".into());
        t.note(3, "k", "LB", "x".into());
        let out = t.finish();
        assert_eq!(out.iter().map(|n| (n.tag.as_str(), n.count)).collect::<Vec<_>>(), [("LB", 2), ("CI", 1)]);
    }
}
