//! fsm-firmware: the camera's program for its Zynq-7000 Cortex-A9, and the same loop on the host.
//!
//! The loop is target-independent and allocation-free; only `arm` (start-up code, vectors,
//! semihosting, panic handler, defmt logger) is bare-metal, behind `cfg(target_os = "none")`.
//! On the host the crate also carries the camera emulator and the cross-check tools.
//!
//! | layer | module |
//! |---|---|
//! | largest plan and row, memory they take | [`limits`] |
//! | the buffers: one static block on the target | [`memory`] |
//! | one row-dump record → one candidate record (`fsm_core`) | [`scan`] |
//! | a whole row dump in memory → a candidate file (replay; the QEMU cross-check) | [`batch`] |
//! | the host ⇄ camera protocol, camera side (`fsm-protocol`) | [`device`] |
//! | exact instruction counts under QEMU | [`icount`] |
//! | mailbox addresses of inputs placed by QEMU | [`layout`] |
//! | host only: a scene with interreflections as a row dump | `scene` |
//! | host only: the host's decode of a dump, candidate-file comparison | `reference` |
//! | host only: the camera emulator on TCP | `emulator` |
//! | host only: a recorded session (requests, expected answers) for replay under QEMU | `session` |
#![cfg_attr(target_os = "none", no_std)]

pub mod batch;
pub mod device;
pub mod icount;
pub mod layout;
pub mod limits;
pub mod memory;
pub mod scan;

#[cfg(not(target_os = "none"))]
pub mod emulator;
#[cfg(not(target_os = "none"))]
pub mod reference;
#[cfg(not(target_os = "none"))]
pub mod scene;
#[cfg(not(target_os = "none"))]
pub mod session;

#[cfg(target_os = "none")]
pub mod arm;
