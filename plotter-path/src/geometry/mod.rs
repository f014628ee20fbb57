//! Geometry in millimetres: the [`crate::Drawing`] model, curve flattening, filled regions (clip, occlusion)
//! and their hatching, page layout, size limits and pen-up travel.

pub mod drawing;
pub mod flatten;
pub mod hatch;
pub mod layout;
pub mod limits;
pub mod region;
pub mod travel;
