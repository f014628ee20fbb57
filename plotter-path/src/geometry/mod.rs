//! Geometry in millimetres: the [`crate::Drawing`] model, curve flattening, page layout, size limits and pen-up
//! travel.

pub mod drawing;
pub mod flatten;
pub mod layout;
pub mod limits;
pub mod travel;
