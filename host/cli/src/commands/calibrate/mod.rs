//! `fsm calibrate`: from captures of a printed target to a calibration file (`target`), the
//! projector's intensity response (`response`), and the calibration files other tools write
//! (`import`, `export`).

pub mod files;
pub mod response;
pub mod target;

use fsm_io::Result;

/// Calibration of the camera–projector pair.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand, Debug)]
enum Command {
    /// Camera and projector geometry from scans of a planar checkerboard at ≥ 3 poses.
    Target(target::Args),
    /// The projector's intensity response (gamma) from captures of uniform grey levels.
    Response(response::Args),
    /// Reads an OpenCV FileStorage calibration (SLStudio, scan3d-capture, procam-calibration)
    /// and writes our calibration file.
    Import(files::ImportArgs),
    /// Writes our calibration file as an OpenCV FileStorage file another tool reads.
    Export(files::ExportArgs),
}

/// Runs `fsm calibrate …`.
pub fn run(args: Args) -> Result<()> {
    match args.command {
        Command::Target(args) => target::run(args),
        Command::Response(args) => response::run(args),
        Command::Import(args) => files::import(args),
        Command::Export(args) => files::export(args),
    }
}
