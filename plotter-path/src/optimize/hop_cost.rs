//! What the travel bound charges a hop: a cost from the hop's distances along X and Y, which may depend on its
//! direction (a machine whose axes each have their own limits, [`crate::motion::hop_time`]) or only on its length
//! (pen-up distance, or a time per length).

/// The least cost of a pen-up hop, for the travel bound ([`super::bound`]).
///
/// Both methods must be non-decreasing (in each of `|dx|` and `|dy|`, and in `d`) and ≥ 0, and
/// [`along`](Self::along) must be at most [`cost`](Self::cost) of every hop of that length or longer. The cost
/// depends on `|dx|` and `|dy|` only, so it is symmetric: a hop from `a` to `b` costs what the hop back does.
pub trait HopCost {
    /// The least cost of a hop of `|dx|` × `|dy|` mm.
    fn cost(&self, dx: f64, dy: f64) -> f64;

    /// The least cost of any hop at least `d` mm long, in any direction.
    fn along(&self, d: f64) -> f64;
}

/// A cost that depends only on a hop's length: `f(√(dx² + dy²))` for a non-decreasing `f ≥ 0`.
pub struct ByLength<'a>(pub &'a dyn Fn(f64) -> f64);

impl HopCost for ByLength<'_> {
    fn cost(&self, dx: f64, dy: f64) -> f64 {
        (self.0)(dx.hypot(dy))
    }

    fn along(&self, d: f64) -> f64 {
        (self.0)(d)
    }
}
