//! fsm-firmware's host-side tests, one file per concern, in one test harness (each test binary
//! linked its own copy of the firmware, the protocol and the decoder). Run one file with
//! `cargo test -p fsm-firmware --test suite link_faults::`.

mod device_input;
mod emulator;
mod link_faults;
mod qemu_crosscheck;
