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
    /// `M112` was received; the next [`HeaterUnit::service`] returns its alarm.
    estop_pending: bool,
}

impl<T: Heaters> HeaterUnit<T> {
    /// The heaters of `cfg` on `io`, started at `now`.
    pub(crate) fn new(io: T, cfg: ThermalConfig, now: u64) -> Self {
        HeaterUnit { io, thermal: Thermal::new(cfg, now), estop: EmergencyParser::new(), estop_pending: false }
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

    /// Feed one received byte to the `M112` spotter: when it completes an emergency stop, everything is switched
    /// off at once, the alarm is left for [`HeaterUnit::service`] to raise, and `true` tells the machine to stop
    /// motion.
    pub(crate) fn spot_emergency_stop(&mut self, b: u8) -> bool {
        let fired = self.estop.feed(b);
        if fired {
            self.shutdown();
            self.estop_pending = true;
        }
        fired
    }

    /// An emergency stop waits for its alarm.
    pub(crate) fn emergency_pending(&self) -> bool {
        self.estop_pending
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

    /// The alarm of an emergency stop received since the last call, else run the control periods due at `now`
    /// (reports to `out`): the alarm of a tripped safety check.
    pub(crate) fn service<W: Write>(&mut self, now: u64, out: &mut W) -> Option<AlarmCode> {
        if core::mem::take(&mut self.estop_pending) {
            return Some(AlarmCode::EmergencyStop);
        }
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
