//! The machine's heaters: the board's heater I/O with the heater driver that runs it ([`crate::heater_driver`]),
//! and the byte spotter of `M112` ([`crate::estop`]). The machine asks it to run the temperature commands of a
//! line, to service the control period, and to switch everything off.

use core::fmt::Write;

use crate::errors::AlarmCode;
use crate::estop::EmergencyParser;
use crate::gcode::Words;
use crate::hal::Heaters;
use crate::heater_driver::{Cmd, Thermal, TooCold};
use crate::thermal::ThermalConfig;
use crate::thermal_gcode::{self, ThermalLine};

/// What a temperature, fan or emergency-stop line asks of the machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Reply {
    /// Answer as the driver says (or as the parser refused).
    Driver(Cmd),
    /// `M112`: stop everything.
    EmergencyStop,
}

/// The heater I/O `T`, its driver and the `M112` spotter.
pub(crate) struct HeaterUnit<T: Heaters> {
    io: T,
    thermal: Thermal,
    estop: EmergencyParser,
}

impl<T: Heaters> HeaterUnit<T> {
    /// The heaters of `cfg` on `io`, started at `now`.
    pub(crate) fn new(io: T, cfg: ThermalConfig, now: u64) -> Self {
        HeaterUnit { io, thermal: Thermal::new(cfg, now), estop: EmergencyParser::new() }
    }

    /// The heater I/O.
    pub(crate) fn io(&self) -> &T {
        &self.io
    }

    /// The heater I/O, mutably.
    pub(crate) fn io_mut(&mut self) -> &mut T {
        &mut self.io
    }

    /// The driver.
    pub(crate) fn thermal(&self) -> &Thermal {
        &self.thermal
    }

    /// Feed one received byte to the `M112` spotter: `true` when it completed an emergency stop.
    pub(crate) fn spots_emergency_stop(&mut self, b: u8) -> bool {
        self.estop.feed(b)
    }

    /// All heaters and the fan off.
    pub(crate) fn shutdown(&mut self) {
        self.thermal.shutdown(&mut self.io);
    }

    /// A reset: the profile's cold-extrusion setting again.
    pub(crate) fn reset(&mut self) {
        self.thermal.restore_cold_extrusion();
    }

    /// `Some` when a move with extrusion must be refused now.
    pub(crate) fn cold_extrusion(&self) -> Option<TooCold> {
        self.thermal.cold_extrusion()
    }

    /// Run the control periods due at `now` (reports to `out`); the alarm of a tripped safety check.
    pub(crate) fn service<W: Write>(&mut self, now: u64, out: &mut W) -> Option<AlarmCode> {
        self.thermal.tick(&mut self.io, now, out).map(AlarmCode::Thermal)
    }

    /// Run the temperature, fan or emergency-stop command of `w` at `now` (`alarm`: the machine is in alarm;
    /// reports to `out`); `None` when `w` is none of these.
    pub(crate) fn command<W: Write>(&mut self, w: &Words, now: u64, out: &mut W, alarm: bool) -> Option<Reply> {
        let reply = match thermal_gcode::parse(w, self.thermal.config())? {
            Ok(ThermalLine::Heaters(cmd)) => Reply::Driver(self.thermal.command(cmd, now, &mut self.io, out, alarm)),
            Ok(ThermalLine::EmergencyStop) => Reply::EmergencyStop,
            Err((code, detail)) => Reply::Driver(Cmd::Error(code, detail)),
        };
        Some(reply)
    }
}
