//! Which machine a command plans for or drives: the `clap` flags that choose its profile, shared by every command
//! that needs one (`plot`, `stats`, `optimize`, `sim`, `home`, `jog`, ...).

use std::path::PathBuf;

use plotter_path::MachineProfile;

use crate::input::load_profile;

/// The machine-choosing flags.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct MachineArgs {
    /// Machine profile (TOML) [default: the built-in XY plotter kit].
    #[arg(long, help_heading = "Machine")]
    pub profile: Option<PathBuf>,
}

impl MachineArgs {
    /// Whether any flag chose a machine other than the built-in default.
    pub fn chosen(&self) -> bool {
        self.profile.is_some()
    }

    /// The machine profile these flags name (a bad file is [`crate::Error::BadInput`]).
    pub fn load(&self) -> crate::Result<MachineProfile> {
        load_profile(self.profile.as_deref())
    }
}
