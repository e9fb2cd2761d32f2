//! `fsm calibrate response`: the projector's intensity response from uniform grey captures.

use std::path::{Path, PathBuf};

use fsm_calibrate::response::{self, ResponseModel, ResponseOutputs};
use fsm_io::image_files::ImageFormat;
use fsm_io::projector_response;
use fsm_io::Result;

use crate::commands::BitDepth;

/// How to measure, shown by `fsm calibrate response --help`.
const LONG_HELP: &str = "\
A projector whose light is not proportional to its code (gamma) distorts the fringes into
ghost columns (how it is measured: docs/calibration.md). Two steps:

1. Write the grey-level images (code 0 to full, ascending) and levels.json:
     fsm calibrate response --write-patterns levels/ --levels 17 --width 1024 --height 768
   Project each in turn onto a flat, matte, light surface filling the camera's view and
   capture it with a fixed exposure (no auto-gain), bright but not saturated at full code.
   Number the captures like the images (0000.png, 0001.png, ...).
2. Estimate the response and write it:
     fsm calibrate response --images captures/ --manifest levels/levels.json \\
         --bit-depth 12 --out response.toml --calibration calibration.toml
   Prints the best-fit gamma, its RMS residual and every level (pixels saturated or dim in
   the dark or full capture are left out and counted); writes a response file for
   `fsm patterns --gamma`, and with --calibration stores it for `fsm patterns --calibration`.";

/// Arguments of `fsm calibrate response` (see [`LONG_HELP`]).
#[derive(clap::Args, Debug)]
#[command(after_long_help = LONG_HELP)]
#[command(group(clap::ArgGroup::new("mode").required(true).args(["write_patterns", "images"])))]
pub struct Args {
    /// Write the grey-level projector images and levels.json into this folder (created; must
    /// not exist or be empty, unless --force).
    #[arg(long, value_name = "DIR", requires_all = ["width", "height"])]
    write_patterns: Option<PathBuf>,
    /// Number of grey levels, evenly spaced from code 0 to full (at least 3).
    #[arg(long, value_name = "N", default_value_t = 17)]
    levels: usize,
    /// Projector width in pixels (--write-patterns).
    #[arg(long, value_name = "COLUMNS")]
    width: Option<u32>,
    /// Projector height in pixels (--write-patterns).
    #[arg(long, value_name = "ROWS")]
    height: Option<u32>,
    /// 16-bit projector images (default 8-bit). With --images and without --manifest: the
    /// levels were 16-bit codes.
    #[arg(long)]
    sixteen_bit: bool,
    /// Write TIFF instead of PNG (--write-patterns).
    #[arg(long)]
    tiff: bool,
    /// Replace the --write-patterns folder or the --out file if it exists.
    #[arg(long)]
    force: bool,
    /// Folder of the captures, numbered like the grey-level images (PNG or TIFF, 8- or 16-bit
    /// grey).
    #[arg(long, value_name = "DIR")]
    images: Option<PathBuf>,
    /// The levels.json written with the grey-level images: the code of every capture.
    /// Default: the codes of --levels (and --sixteen-bit), as --write-patterns makes them.
    #[arg(long, value_name = "FILE")]
    manifest: Option<PathBuf>,
    #[command(flatten)]
    bit_depth: BitDepth,
    /// Response file to write (for `fsm patterns --gamma`).
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Which response to write: the power law, the measured table, or (auto) the power law if
    /// its RMS residual is at most 0.5% of full light, the table otherwise.
    #[arg(long, default_value = "auto", value_parser = crate::commands::named(ResponseModel::ALL))]
    model: ResponseModel,
    /// Also store the response in this calibration file (its [projector_response] section,
    /// replacing any; the file is rewritten whole).
    #[arg(long, value_name = "FILE")]
    calibration: Option<PathBuf>,
    /// Write the report as JSON to this file.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

/// Runs `fsm calibrate response`.
pub fn run(args: Args) -> Result<()> {
    fsm_io::outputs::check_file_targets(args.out.as_deref(), args.force)?;
    if let Some(out) = &args.write_patterns {
        return write_patterns(&args, out);
    }
    let images = args.images.as_deref().expect("clap requires a mode");
    let (manifest, levels) = (args.manifest.as_deref(), args.levels);
    let codes = projector_response::capture_fractions(manifest, levels, args.sixteen_bit)?;
    let estimate =
        projector_response::estimate_from_folder(images, &codes, args.bit_depth.bit_depth)?;
    let chosen = response::choose(&estimate, args.model);
    say!("{}", estimate.table(images));
    let outputs = ResponseOutputs {
        file: args.out.as_deref(),
        calibration: args.calibration.as_deref(),
        json: args.json.as_deref(),
    };
    outputs.write(images, &estimate, &chosen, |line| sayln!("{line}"))
}

fn write_patterns(args: &Args, out: &Path) -> Result<()> {
    let (width, height) = (
        args.width.expect("clap requires --width"),
        args.height.expect("clap requires --height"),
    );
    let format = ImageFormat::png_or_tiff(args.tiff);
    let manifest = projector_response::write_grey_level_set(
        out,
        args.levels,
        width,
        height,
        args.sixteen_bit,
        format,
        args.force,
    )?;
    eprintln!("{}", manifest.written_to(out));
    Ok(())
}
