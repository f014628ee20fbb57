//! Options shared by every front end, as `clap` flag groups: page layout, path optimization, raster tracing.

pub mod layout;
pub mod optimize;
pub mod trace;
