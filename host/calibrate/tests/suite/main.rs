//! fsm-calibrate's tests, one file per concern, in one test harness (one build and one
//! link). Run one file with `cargo test -p fsm-calibrate --test suite corners::`.

mod support;

mod corners;
mod dense;
mod end_to_end;
mod math;
mod outputs;
