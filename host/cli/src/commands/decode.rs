//! `fsm decode`: every candidate of every pixel, from a stack or a dump.

use fsm_io::decode;
use fsm_io::progress::Progress;
use fsm_io::Result;

use super::{CaptureArgs, DecodeArgs, OutDir, PlanFile};

/// Decode a scan: every projector column that lights each camera pixel.
///
/// Writes into the output folder:
///   candidates.fsmc  every candidate of every pixel (column, amplitude, EFSM block and group),
///                    one CRC-protected record per camera row (format: README, "Candidate files")
///   column.tiff      32-bit float: each pixel's strongest candidate column, NaN where none
///   column.png       colour preview of column.tiff (black: no candidate), with its colour bar
///
/// The capture is checked against the plan before any work; the folder appears whole or not
/// at all.
///
/// Examples:
///   fsm decode --plan plan.toml --images captures/ --bit-depth 12 --out decoded/
///   fsm decode --plan plan.toml --dump scan.dump --out decoded/
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    plan: PlanFile,
    #[command(flatten)]
    capture: CaptureArgs,
    #[command(flatten)]
    output: OutDir,
    #[command(flatten)]
    decode: DecodeArgs,
}

pub fn run(args: Args) -> Result<()> {
    let plan = args.plan.read()?;
    let capture = args.capture.open(plan)?;
    let out = &args.output.out;
    let summary = decode::decode_to_dir(
        plan,
        &capture,
        out,
        args.output.force,
        &args.decode.options(),
        &Progress::stderr(),
    )?;
    eprintln!("{}", summary.report(&capture.describe()));
    eprintln!("  {}", decode::files_written(out));
    Ok(())
}
