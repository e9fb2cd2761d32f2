//! The workspace-level tests in one harness (one build and one link): the core's decoders and
//! the host's scan against the simulator's ground truth, and the crates' layering. Run one file
//! with `cargo test -p fsm-tests --test workspace scan::`.

mod support;

mod decoders;
mod end_to_end;
mod gamma;
mod layers;
mod methods;
mod scan;
mod wrong_points;
