//! One module per subcommand of `plotter`: its `clap` arguments and a `run` that calls the library and displays.

pub(crate) mod bench;
pub(crate) mod console;
pub(crate) mod convert;
pub(crate) mod generate;
pub(crate) mod home;
pub(crate) mod jog;
pub(crate) mod manual;
pub(crate) mod models;
pub(crate) mod optimize;
pub(crate) mod plot;
pub(crate) mod plot_as_written;
pub(crate) mod preview;
pub(crate) mod print;
pub(crate) mod queue;
pub(crate) mod resume;
pub(crate) mod serve;
pub(crate) mod sim;
pub(crate) mod stats;
pub(crate) mod trace;
