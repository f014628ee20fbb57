//! Motion: machine profiles, the host motion plan (the firmware's own planner over the whole drawing) and
//! drift-free step conversion.

pub mod bound;
pub mod heaters;
pub mod hop;
pub mod pens;
pub mod plan;
pub mod print_plan;
pub mod profile;
pub mod steps;
