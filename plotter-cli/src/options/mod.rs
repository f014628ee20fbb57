//! Options shared by every front end, as `clap` flag groups: the machine, page layout, path optimization, raster
//! tracing.

pub mod layout;
pub mod machine;
pub mod optimize;
pub mod trace;
pub mod workflow;
