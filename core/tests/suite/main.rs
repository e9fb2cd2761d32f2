//! fsm-core's tests, one file per concern, in one test harness: the decoder is generic over its
//! lanes and the plan's sizes, so every test binary compiled its own copy of it (fourteen
//! binaries took 13 minutes to build on the 2-core machine after a change to the core). Run one
//! file with `cargo test -p fsm-core --test suite cosine::`.

mod support;

mod accuracy;
mod baseline;
mod cosine;
mod cosine_transform;
mod estimators;
mod kernel;
mod layers;
mod local_maxima;
mod methods;
mod noise;
mod plan;
mod properties;
mod robustness;
mod wire;
mod worked_example;
