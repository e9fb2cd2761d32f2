//! `fsm decode`: every candidate of every pixel, from a stack or a dump.

use std::path::PathBuf;

use fsm_io::candidate_file::CANDIDATE_FILE_NAME;
use fsm_io::column_map::{COLUMN_PREVIEW_NAME, COLUMN_TIFF_NAME};
use fsm_io::decode;
use fsm_io::progress::Progress;
use fsm_io::Result;

use super::{report_bad_rows, BadRowsArg, BitDepth, CaptureSource, DecodeArgs};

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
    /// Plan file the capture was made with: FSM's, or a method FSM is compared with
    /// (`fsm plan --method`).
    #[arg(long, value_name = "FILE")]
    plan: PathBuf,
    #[command(flatten)]
    source: CaptureSource,
    #[command(flatten)]
    bit_depth: BitDepth,
    #[command(flatten)]
    bad_rows: BadRowsArg,
    /// Output folder (created; must not exist or be empty, unless --force).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    #[command(flatten)]
    decode: DecodeArgs,
    /// Replace the output folder if it exists and is not empty.
    #[arg(long)]
    force: bool,
}

pub fn run(args: Args) -> Result<()> {
    let plan = fsm_io::plan_file::read_method_plan(&args.plan)?;
    let capture = args
        .source
        .open(plan, &args.bit_depth, args.bad_rows.policy())?;
    let options = args.decode.options();
    let summary = decode::decode_to_dir(
        plan,
        &capture,
        &args.out,
        args.force,
        &options,
        &Progress::stderr(),
    )?;
    eprintln!(
        "decoded {} ({}x{}) in {:.2} s: {:.3} Mpx/s\n  {}",
        capture.describe(),
        summary.width,
        summary.height,
        summary.seconds,
        summary.megapixels_per_second(),
        summary.counts()
    );
    report_bad_rows(&summary);
    eprintln!(
        "  wrote {}/{{{CANDIDATE_FILE_NAME}, {COLUMN_TIFF_NAME}, {COLUMN_PREVIEW_NAME}}}",
        args.out.display()
    );
    Ok(())
}
