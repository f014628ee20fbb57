//! Geometry in millimetres: the [`crate::Drawing`] model, curve flattening, page layout and pen-up travel.

pub mod drawing;
pub mod flatten;
pub mod layout;
pub mod travel;
