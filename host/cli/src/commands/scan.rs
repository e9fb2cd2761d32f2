//! `fsm scan`: a surface from a capture — decode, triangulate every candidate, select the
//! direct one of every pixel, drop what the projector cannot light directly.

use std::path::PathBuf;

use fsm_geometry::Calibration;
use fsm_io::progress::Progress;
use fsm_io::Result;
use fsm_scan::pipeline::{ScanCandidates, ScanInputs};
use fsm_scan::{Paths, SelectionParams};

use super::{CaptureArgs, DecodeArgs, OutDir, PlanFile};

/// Scan a surface: decode the capture, triangulate every candidate, select the direct one.
///
/// Every candidate column of a pixel (direct light and reflections) is triangulated with the
/// calibration, those outside its measurement volume dropped, and the direct one chosen by
/// semi-global selection (SPEC §4); a chosen point the projector cannot light directly gets no
/// point (how: docs/scan.md). summary.json counts the pixels without a point by reason.
///
/// Writes into the output folder:
///   points.ply                 binary PLY: x y z (mm, camera frame), intensity, quality, pixel x y
///   depth.tiff, column.tiff    32-bit float per pixel, NaN where none
///   quality.tiff               32-bit float per pixel: the point's signal-to-noise ratio
///   direct.png, indirect.png   direct and indirect light (paper eqs. 12-13), one scale (DN bar)
///   depth.png                  coloured depth, 1st-99th percentile (mm bar; black: no point)
///   no_point.tiff, no_point.png  why each pixel has no point: 8-bit reason codes (0: it has
///                              one; docs/scan.md lists them), and in colours with a legend
///   summary.json               counts (pixels without a point by reason), timings, parameters
///
/// Examples:
///   fsm scan --plan plan.toml --calibration cal.toml --images captures/ --out scan/
///   fsm scan --plan plan.toml --calibration cal.toml --dump scan.dump --paths 8 --out scan/
///   fsm scan --plan plan.toml --calibration cal.toml --candidates decoded/candidates.fsmc \
///       --bit-depth 12 --out scan/
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    plan: PlanFile,
    /// Calibration file of the camera-projector pair (TOML).
    #[arg(long, value_name = "FILE")]
    calibration: PathBuf,
    #[command(flatten)]
    capture: CaptureArgs,
    /// Candidate file of the capture (`fsm decode`'s candidates.fsmc, or `fsm camera scan`'s),
    /// decoded with this plan: the scan starts from its candidates. It needs --bit-depth (the
    /// file does not record the sensor's, and a point's quality is measured in it).
    #[arg(long, value_name = "FILE", group = "CaptureSource")]
    candidates: Option<PathBuf>,
    #[command(flatten)]
    output: OutDir,
    #[command(flatten)]
    selection: SelectionArgs,
    #[command(flatten)]
    decode: DecodeArgs,
    /// The truth folder of a simulated capture (`fsm simulate`'s truth/: depth.tiff and
    /// column.tiff): summary.json then counts the points more than 1 mm from the true surface
    /// and the directly lit pixels that kept a right point.
    #[arg(long, value_name = "DIR")]
    truth: Option<PathBuf>,
}

/// The selection's settings (SPEC §4).
#[derive(clap::Args, Debug)]
pub struct SelectionArgs {
    /// Aggregation paths of the selection: 8 or 16 (16 choose better where reflections make
    /// large fictitious surfaces, at twice the selection's time).
    #[arg(long, default_value = "16", value_parser = str::parse::<Paths>)]
    paths: Paths,
    /// Neighbours closer than this (mm) cost nothing (default: 4 pixel footprints at the
    /// middle of the measurement volume).
    #[arg(long, value_name = "MM")]
    epsilon_mm: Option<f32>,
    /// Cost per millimetre beyond epsilon, in units of a pixel's strongest data term
    /// (default: 1 per pixel footprint).
    #[arg(long, value_name = "PER_MM")]
    beta_per_mm: Option<f32>,
    /// Keep the points of pixels whose candidates may mix two lights, off by up to a column:
    /// EFSM lights unresolved modulo the block width (flagged aliased), or touching lights the
    /// decoder could not split (flagged unresolved); by default they get no point.
    #[arg(long)]
    keep_aliased: bool,
    /// Keep the chosen points the projector cannot light directly (reflections' fictitious
    /// surfaces, virtual images); by default they get no point.
    #[arg(long)]
    keep_fictitious: bool,
    /// Keep the points of pixels at a depth edge (a neighbour chose a point on another surface
    /// whose light the pixel holds too: its point may be on either side) or a crease (its point
    /// lies on none of its neighbours' surfaces), and the points no neighbourhood confirms
    /// (specks, strips 1-2 pixels wide); by default they get no point.
    #[arg(long)]
    keep_edges: bool,
    /// Give no point to a pixel whose light is weaker than this many times the noise RMS a
    /// dark pixel's light amplitude has (FSM: one column of the light profile, or one bin of
    /// the spectrum; the other methods: their amplitude's; the plan's sensor sets it). That
    /// ratio is the point's quality, written to points.ply and quality.tiff. 0 keeps every
    /// point.
    #[arg(long, value_name = "SNR", default_value_t = fsm_scan::selection::DEFAULT_MIN_QUALITY)]
    min_quality: f32,
}

impl SelectionArgs {
    /// The selection's parameters for `calibration`: its defaults, overridden by the options
    /// given.
    pub fn params(&self, calibration: &Calibration) -> SelectionParams {
        let mut params = SelectionParams::for_calibration(calibration);
        params.paths = self.paths;
        params.epsilon_mm = self.epsilon_mm.unwrap_or(params.epsilon_mm);
        params.beta_per_mm = self.beta_per_mm.unwrap_or(params.beta_per_mm);
        params.drop_aliased = !self.keep_aliased;
        params.drop_fictitious = !self.keep_fictitious;
        params.drop_edges = !self.keep_edges;
        params.min_quality = self.min_quality;
        params
    }
}

pub fn run(args: Args) -> Result<()> {
    let truth = args.truth.as_deref();
    let inputs = ScanInputs::read(&args.plan.plan, &args.calibration, truth)?;
    let (plan, calibration) = (inputs.plan, &inputs.calibration);
    let staged = args.output.stage()?;
    let candidates = match &args.candidates {
        Some(path) => {
            let bits = args.capture.bit_depth.bit_depth;
            ScanCandidates::read(&plan, path, bits, calibration)?
        }
        None => {
            let capture = args.capture.open(plan)?;
            let options = args.decode.options();
            ScanCandidates::decode(plan, &capture, calibration, &options, &Progress::stderr())?
        }
    };
    let params = args.selection.params(&calibration.calibration);
    let scanned = inputs.scan_into(staged.path(), &candidates, &params)?;
    let out = staged.commit()?;
    eprintln!("{}", scanned.report(&candidates, &out));
    Ok(())
}
