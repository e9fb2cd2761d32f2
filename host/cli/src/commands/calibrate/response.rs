//! `fsm calibrate response`: the projector's intensity response from uniform grey captures.

use fsm_host::{Error, Result};

/// Arguments of `fsm calibrate response`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs `fsm calibrate response`.
pub fn run(_args: Args) -> Result<()> {
    Err(Error::Usage(
        "fsm calibrate response is not built yet".into(),
    ))
}
