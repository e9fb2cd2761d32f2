//! `fsm`: the command-line tool of the Frequency Shift Method scanner. A thin layer over the
//! host libraries (`fsm-io`, `fsm-scan`, `fsm-calibrate`, `fsm-sim`): each subcommand parses
//! its arguments and calls them.
// The arguments' doc comments are clap's `--help` text, written for a terminal: `<method>/`
// and `[section]` there are words, not HTML or links.
#![allow(rustdoc::invalid_html_tags, rustdoc::broken_intra_doc_links)]

/// `print!` to standard output, through [`fsm_io::outputs::write_stdout`]: a reader that went
/// away ends the run quietly instead of a panic.
macro_rules! say {
    ($($arg:tt)*) => {
        fsm_io::outputs::write_stdout(format_args!($($arg)*))
    };
}

/// `println!` to standard output, through [`fsm_io::outputs::write_stdout`].
macro_rules! sayln {
    ($($arg:tt)*) => {
        fsm_io::outputs::write_stdout(format_args!("{}\n", format_args!($($arg)*)))
    };
}

mod commands;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Structured-light scanning through interreflections with the Frequency Shift Method.
///
/// A scan follows a plan file (`fsm plan`): the projector shows its patterns (`fsm patterns`),
/// the camera captures one image per pattern (or dumps raw rows), `fsm decode` finds every
/// projector column that lights each camera pixel, directly or through reflections, and
/// `fsm scan` turns the capture into a surface. `fsm simulate` and `fsm demo` need no camera.
#[derive(Parser)]
#[command(name = "fsm", version, propagate_version = true, max_term_width = 100)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Plan(commands::plan::Args),
    Patterns(commands::patterns::Args),
    Convert(commands::convert::Args),
    Decode(commands::decode::Args),
    Inspect(commands::inspect::Args),
    Scan(commands::scan::Args),
    Simulate(commands::simulate::Args),
    Demo(commands::demo::Args),
    Upload(commands::camera::UploadArgs),
    /// Talk to a camera: its limits, or a scan whose rows it decodes.
    #[command(subcommand)]
    Camera(commands::camera::CameraCommand),
    /// Calibration of the camera–projector pair.
    #[command(subcommand)]
    Calibrate(commands::calibrate::Command),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Err(e) = fsm_io::outputs::remove_unfinished_on_signal() {
        eprintln!("fsm: warning: interrupted runs may leave hidden .partial- outputs: {e}");
    }
    let result = match cli.command {
        Command::Plan(args) => commands::plan::run(args),
        Command::Patterns(args) => commands::patterns::run(args),
        Command::Convert(args) => commands::convert::run(args),
        Command::Decode(args) => commands::decode::run(args),
        Command::Inspect(args) => commands::inspect::run(args),
        Command::Scan(args) => commands::scan::run(args),
        Command::Simulate(args) => commands::simulate::run(args),
        Command::Demo(args) => commands::demo::run(args),
        Command::Upload(args) => commands::camera::upload(args),
        Command::Camera(args) => commands::camera::camera(args),
        Command::Calibrate(args) => commands::calibrate::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fsm: error: {e}");
            ExitCode::FAILURE
        }
    }
}
