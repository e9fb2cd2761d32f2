//! fsm-sim's tests, one file per concern, in one test harness (one build and one
//! link). Run one file with `cargo test -p fsm-sim --test suite glossy::`.

mod glossy;
mod report;
mod simulator;

// The demo's reports read back, shared with the CLI's demo test.
mod support;
