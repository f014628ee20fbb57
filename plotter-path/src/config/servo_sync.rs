//! How the firmware a plan is made for runs a servo pen's command among the moves (a setting of the profile the
//! host fills in from the firmware it talks to; the plan, `crate::motion::plan`, reads it).

/// How the firmware a plan is made for runs a servo pen's command among the moves: whether the drop can be
/// commanded while the carriage travels. The plan (`crate::motion::plan`) reads it from the profile
/// ([`crate::MachineProfile::servo_sync`]), which the host sets from the firmware it talks to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ServoSync {
    /// The command is a queue entry between two moves that does not stop the motors: our firmware's servo step
    /// block (the stepper sets the servo and goes on with the next block at the rate the last one left off) and
    /// the EiBotBoard's `SP`. The drop is commanded on the way and the carriage keeps moving.
    #[default]
    InMotion,
    /// The motion stops for the command: GRBL runs `M3 S<angle>` only once its planner queue has run empty (its
    /// spindle sync; laser mode, which does not wait, switches the output off at every stop and lets a servo go
    /// limp). The travel stops where the drop is commanded and the rest follows from rest.
    AtRest,
}
