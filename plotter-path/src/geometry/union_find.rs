//! Disjoint sets of items numbered `0..n` (union–find with path halving): which paths or tour pieces are
//! already joined, for the optimizer's spanning trees and the tone hatch's joining of spans.

/// Disjoint sets of items, each pointing towards its set's root (path halving). `UnionFind((0..n).collect())`
/// starts every item in a set of its own; `uf.0[root] = other_root` joins two sets.
pub(crate) struct UnionFind(pub(crate) Vec<u32>);

impl UnionFind {
    /// The root of `x`'s set.
    pub(crate) fn find(&mut self, mut x: u32) -> u32 {
        while self.0[x as usize] != x {
            let up = self.0[self.0[x as usize] as usize];
            self.0[x as usize] = up;
            x = up;
        }
        x
    }
}
