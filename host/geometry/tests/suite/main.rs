//! fsm-geometry's tests, one file per concern, in one test harness (one build and one
//! link). Run one file with `cargo test -p fsm-geometry --test suite models::`.

mod models;
mod opencv;
mod properties;
