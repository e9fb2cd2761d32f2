//! fsm-firmware: the bare-metal program for the camera's Zynq-7000 Cortex-A9.
//!
//! On `armv7a-none-eabihf` (`target_os = "none"`) this crate is `no_std` and provides the
//! start-up code, exception vectors, semihosting, panic handler and (feature `defmt`) the defmt
//! global logger in [`arm`]; the binary (src/main.rs) supplies `fw_main`.
//! On the host it is an ordinary crate: [`demo`] and [`layout`] hold everything that does not
//! touch the hardware, and are unit-tested there.
#![cfg_attr(target_os = "none", no_std)]

pub mod demo;
pub mod icount;
pub mod layout;

#[cfg(target_os = "none")]
pub mod arm;
