//! Layer 0, leaf types: what every other layer speaks in, importing nothing but itself. Axes, the fixed-point and
//! floating-point helpers ([`fmath`], [`decimal`], [`range`]), the machine configuration, the step-block contract
//! ([`step_block`]: the blocks the stepper executes and their exact timing, which the host reproduces), the heater
//! identities ([`heater`]) and the error and alarm codes ([`errors`]).

pub mod axis;
pub mod config;
pub mod decimal;
pub mod errors;
pub mod fmath;
pub mod heater;
pub mod range;
pub mod step_block;
