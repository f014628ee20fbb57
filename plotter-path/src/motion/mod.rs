//! Motion: the host motion plan (the firmware's own planner over the whole drawing), pen-up hops, the time
//! bound, and the print plan of slicer G-code.

pub mod bound;
pub mod gap;
pub mod hop;
pub mod hop_time;
pub(crate) mod piece_time;
pub mod plan;
pub mod print_plan;
pub mod servo;
