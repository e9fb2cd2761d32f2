//! `fsm calibrate target`: geometric calibration from checkerboard scans.

use fsm_host::{Error, Result};

/// Arguments of `fsm calibrate target`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs `fsm calibrate target`.
pub fn run(_args: Args) -> Result<()> {
    Err(Error::Usage("fsm calibrate target is not built yet".into()))
}
