//! Geometry in millimetres: the [`crate::Drawing`] model, curve flattening, filled regions (clip, occlusion)
//! and their hatching, page layout and pen-up travel.

pub mod drawing;
pub mod flatten;
pub mod hatch;
pub mod layout;
pub mod region;
pub mod travel;
