//! `fsm patterns`: write the projector images of a plan's whole sequence.

use std::path::PathBuf;

use fsm_io::image_files::ImageFormat;
use fsm_io::patterns::{self, PatternOptions};
use fsm_io::progress::Progress;
use fsm_io::Result;

/// Write the projector images of the plan's whole sequence, in projection order.
///
/// Images are numbered 0000.png, 0001.png, … (dark and white references first, then each
/// group's fringes and masks; a baseline's frames in its own order), with manifest.json saying
/// what each image is. Every image is one projector row repeated down the height: patterns
/// vary along columns only.
///
/// Example: fsm patterns --plan plan.toml --height 768 --out patterns/
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    plan: super::PlanFile,
    #[command(flatten)]
    output: super::OutDir,
    /// Projector height in pixels.
    #[arg(long, value_name = "ROWS")]
    height: u32,
    /// Projector width in pixels (default: the plan's projector columns; extra columns are
    /// dark).
    #[arg(long, value_name = "COLUMNS")]
    width: Option<u32>,
    /// Write 16-bit images (default 8-bit).
    #[arg(long)]
    sixteen_bit: bool,
    /// Write TIFF instead of PNG.
    #[arg(long)]
    tiff: bool,
    /// Pre-correct the codes with the projector's measured response (gamma or table; see
    /// the README, "Projector response files") so that the emitted light follows the cosine.
    #[arg(long, value_name = "FILE")]
    gamma: Option<PathBuf>,
    /// Pre-correct with the response stored in this calibration file (its
    /// [projector_response] section, from `fsm calibrate response --calibration`).
    #[arg(long, value_name = "FILE", conflicts_with = "gamma")]
    calibration: Option<PathBuf>,
}

pub fn run(args: Args) -> Result<()> {
    let plan = args.plan.read()?;
    let (gamma, calibration) = (args.gamma.as_deref(), args.calibration.as_deref());
    let response = fsm_calibrate::response::read_response(gamma, calibration)?;
    let options = PatternOptions {
        width: args.width,
        height: args.height,
        sixteen_bit: args.sixteen_bit,
        format: ImageFormat::png_or_tiff(args.tiff),
        response,
    };
    let out = &args.output.out;
    let manifest = patterns::write_method_pattern_set(
        &plan,
        &options,
        gamma.or(calibration),
        out,
        args.output.force,
        &Progress::stderr(),
    )?;
    eprintln!("{}", manifest.written_to(out));
    Ok(())
}
