//! `fsm calibrate import|export`: OpenCV FileStorage calibrations of other tools.

use fsm_host::{Error, Result};

/// Arguments of `fsm calibrate import`.
#[derive(clap::Args, Debug)]
pub struct ImportArgs {}

/// Arguments of `fsm calibrate export`.
#[derive(clap::Args, Debug)]
pub struct ExportArgs {}

/// Runs `fsm calibrate import`.
pub fn import(_args: ImportArgs) -> Result<()> {
    Err(Error::Usage("fsm calibrate import is not built yet".into()))
}

/// Runs `fsm calibrate export`.
pub fn export(_args: ExportArgs) -> Result<()> {
    Err(Error::Usage("fsm calibrate export is not built yet".into()))
}
