//! The `fsm` binary's tests, one file per command family, in one test harness (one build and
//! one link for all of them): `cargo test -p fsm-cli --test fsm [module::test]`.

// A flat white wall in front of the projector, shared with fsm-io's tests.
#[path = "../../../io/tests/suite/support/mod.rs"]
mod flat_wall;
// The demo's report.html checked strictly and read back beside report.md, shared with fsm-sim's
// tests.
#[path = "../../../sim/tests/suite/support/mod.rs"]
mod report_pages;
mod run;

mod calibrate_files;
mod calibrate_response;
mod calibrate_target;
mod camera;
mod commands;
mod methods;
mod scan;
