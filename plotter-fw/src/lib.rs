//! # plotter-fw — the firmware core shared by the pen plotter and a 3D printer
//!
//! `#![no_std]`, no allocation. The `std` feature adds the host simulator.
#![cfg_attr(not(feature = "std"), no_std)]
