//! Geometry in millimetres: the [`crate::Drawing`] model, curve flattening, filled regions (clip, occlusion)
//! and their hatching, page layout, size limits, pen-up travel, the sheets HP-GL plotters address, the flag
//! that cancels long work, disjoint sets for joining paths, and the drift-free conversion of millimetres to whole motor steps.

pub mod bed;
pub mod cancel;
pub mod drawing;
pub mod flatten;
pub mod hatch;
pub mod hpgl_devices;
pub mod layout;
pub mod limits;
pub mod parallel;
pub mod region;
pub mod split;
pub mod steps;
pub mod tone_hatch;
pub mod travel;
pub(crate) mod union_find;
