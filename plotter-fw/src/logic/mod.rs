//! Layer 1, pure algorithms and codecs shared with the host: the G-code words ([`gcode`]) and the typed
//! temperature commands parsed from them ([`thermal_gcode`]), the wire protocol and its framing ([`protocol`],
//! [`framing`], [`line_buffer`], [`realtime`], [`report`]), the motion planner ([`planner`]), soft [`limits`], the
//! homing state machine ([`homing`]) and the heaters' mathematics ([`thermal`]: thermistor, PID, autotune, runaway
//! checks). No hardware, no state beyond their own values; they import only layer 0 and each other (without
//! cycles).

pub mod estop;
pub mod framing;
pub mod gcode;
pub mod homing;
pub mod limits;
pub mod line_buffer;
pub mod planner;
pub mod protocol;
pub mod realtime;
pub mod report;
pub mod thermal;
pub mod thermal_gcode;
