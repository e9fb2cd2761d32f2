//! fsm-io's tests, one file per concern, in one test harness (one build and one
//! link). Run one file with `cargo test -p fsm-io --test suite candidate_file::`.

mod support;

mod candidate_file;
mod dump;
mod outputs;
mod parsers;
mod plan_file;
mod round_trip;
