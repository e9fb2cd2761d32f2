//! `fsm calibrate`: from captures of a printed target to a calibration file (`target`), the
//! projector's intensity response (`response`), and the calibration files other tools write
//! (`import`, `export`).

pub mod files;
pub mod response;
pub mod target;

use fsm_io::Result;

/// `fsm calibrate`'s subcommands.
#[derive(clap::Subcommand, Debug)]
pub enum Command {
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
pub fn run(command: Command) -> Result<()> {
    match command {
        Command::Target(args) => target::run(args),
        Command::Response(args) => response::run(args),
        Command::Import(args) => files::import(args),
        Command::Export(args) => files::export(args),
    }
}
