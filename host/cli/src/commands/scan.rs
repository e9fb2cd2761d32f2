//! `fsm scan`: a surface from a capture — decode, triangulate every candidate, select the
//! direct one of every pixel, drop what the projector cannot light directly.

use std::path::PathBuf;
use std::time::Instant;

use fsm_geometry::Calibration;
use fsm_io::decode::DecodeSummary;
use fsm_io::outputs::StagedDir;
use fsm_io::plan_file::MethodPlan;
use fsm_io::progress::Progress;
use fsm_io::{Error, Result};
use fsm_scan::decoded::DecodedImage;
use fsm_scan::metrics::point_errors_from_depth;
use fsm_scan::output::{write_scan, ScanSummary, StageSeconds, TruthSummary};
use fsm_scan::{Paths, SelectionParams, Surface};

use super::{report_bad_rows, BadRowsArg, BitDepth, CaptureSource, DecodeArgs};

/// Scan a surface: decode the capture, triangulate every candidate, select the direct one.
///
/// The capture is an image stack (--images) or a row dump (--dump), decoded here; or the
/// candidates are already decoded (--candidates: `fsm decode`'s candidates.fsmc, or the file
/// a camera streamed with `fsm camera scan`), and the scan starts from them.
///
/// Every candidate column of a pixel (direct light and reflections) is triangulated with the
/// calibration; candidates outside its measurement volume are dropped; the direct candidate
/// of every pixel is chosen by semi-global selection (the surface is continuous, the
/// fictitious surfaces made by reflections are not: SPEC §4); a chosen point the projector
/// cannot light directly (behind or hiding another surface on its projector ray, on a surface
/// the projector sees from behind, outside its image) gets no point. summary.json counts the
/// pixels without a point by reason.
///
/// Writes into the output folder:
///   points.ply                 binary PLY: x y z (mm, camera frame), intensity, quality, pixel x y
///   depth.tiff, column.tiff    32-bit float per pixel, NaN where none
///   quality.tiff               32-bit float per pixel: the point's signal-to-noise ratio
///   direct.png, indirect.png   direct and indirect light (paper eqs. 12-13), one scale (DN bar)
///   depth.png                  coloured depth, 1st-99th percentile (mm bar; black: no point)
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
    /// Plan file the capture was made with: FSM's, or a method FSM is compared with
    /// (`fsm plan --method`).
    #[arg(long, value_name = "FILE")]
    plan: PathBuf,
    /// Calibration file of the camera-projector pair (TOML).
    #[arg(long, value_name = "FILE")]
    calibration: PathBuf,
    #[command(flatten)]
    source: CaptureSource,
    /// Candidate file of the capture (`fsm decode`'s candidates.fsmc, or a camera's), decoded
    /// with this plan: the scan starts from its candidates. FSM plans need --bit-depth with it
    /// (the file does not record the sensor's, and a point's quality is measured in it).
    #[arg(long, value_name = "FILE", group = "CaptureSource")]
    candidates: Option<PathBuf>,
    #[command(flatten)]
    bit_depth: BitDepth,
    #[command(flatten)]
    bad_rows: BadRowsArg,
    /// Output folder (created; must not exist or be empty, unless --force).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    #[command(flatten)]
    selection: SelectionArgs,
    #[command(flatten)]
    decode: DecodeArgs,
    /// Replace the output folder if it exists and is not empty.
    #[arg(long)]
    force: bool,
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
    #[arg(long, default_value_t = 16, value_parser = parse_paths)]
    paths: u8,
    /// Neighbours closer than this (mm) cost nothing (default: 4 pixel footprints at the
    /// middle of the measurement volume).
    #[arg(long, value_name = "MM")]
    epsilon_mm: Option<f32>,
    /// Cost per millimetre beyond epsilon, in units of a pixel's strongest data term
    /// (default: 1 per pixel footprint).
    #[arg(long, value_name = "PER_MM")]
    beta_per_mm: Option<f32>,
    /// Keep the points of pixels whose candidates may be mixtures of two lights: EFSM lights
    /// unresolved modulo the block width (flagged aliased), or two touching lights the
    /// decoder could not split (flagged unresolved); their columns are off by up to a column.
    /// By default they get no point.
    #[arg(long)]
    keep_aliased: bool,
    /// Keep the chosen points the projector cannot light directly (reflections' fictitious
    /// surfaces, virtual images); by default they get no point.
    #[arg(long)]
    keep_fictitious: bool,
    /// Give no point to a pixel whose light is weaker than this many times the noise RMS of
    /// one column of a dark pixel's light profile (the point's quality, a signal-to-noise
    /// ratio; written to points.ply and quality.tiff). 0 keeps every point. Plans decoded by a
    /// DFT search have no quality and are not filtered.
    #[arg(long, value_name = "SNR", default_value_t = fsm_scan::selection::DEFAULT_MIN_QUALITY)]
    min_quality: f32,
}

impl SelectionArgs {
    /// The selection's parameters for `calibration`: its defaults, overridden by the options
    /// given.
    pub fn params(&self, calibration: &Calibration) -> SelectionParams {
        let mut params = SelectionParams::for_calibration(calibration);
        params.paths = if self.paths == 16 {
            Paths::Sixteen
        } else {
            Paths::Eight
        };
        params.epsilon_mm = self.epsilon_mm.unwrap_or(params.epsilon_mm);
        params.beta_per_mm = self.beta_per_mm.unwrap_or(params.beta_per_mm);
        params.drop_aliased = !self.keep_aliased;
        params.drop_fictitious = !self.keep_fictitious;
        params.min_quality = self.min_quality;
        params
    }
}

fn parse_paths(s: &str) -> std::result::Result<u8, String> {
    match s {
        "8" => Ok(8),
        "16" => Ok(16),
        _ => Err(format!(
            "`{s}`: the selection aggregates along 8 or 16 paths"
        )),
    }
}

/// Reads a calibration file, its errors as host errors.
pub fn load_calibration(path: &std::path::Path) -> Result<Calibration> {
    Calibration::read(path).map_err(|e| Error::Usage(e.to_string()))
}

/// The scan's candidates and where they came from.
struct Decoded {
    image: DecodedImage,
    /// What the candidates came from, for messages.
    source: String,
    /// The decode's summary, when this command decoded.
    summary: Option<DecodeSummary>,
    seconds: f64,
}

impl Args {
    /// Decodes the capture, or reads the candidate file; checks the size against the camera's.
    fn decoded(&self, plan: &MethodPlan, calibration: &Calibration) -> Result<Decoded> {
        let started = Instant::now();
        let decoded = match &self.candidates {
            Some(path) => {
                let depth = self.bit_depth.bit_depth;
                // Any depth tells whether the method measures quality in the sensor's noise.
                let bit_depth = match depth {
                    Some(bits) => bits,
                    None if plan.dark_column_noise_dn(16).is_none() => 16,
                    None => {
                        return Err(Error::Usage(format!(
                            "--candidates {}: a candidate file does not record the sensor's bit \
                             depth, which a point's quality is measured in; give the capture's \
                             with --bit-depth (e.g. 12)",
                            path.display()
                        )))
                    }
                };
                Decoded {
                    image: DecodedImage::read_candidates(plan, path, bit_depth)?,
                    source: format!("candidate file {}", path.display()),
                    summary: None,
                    seconds: 0.0,
                }
            }
            None => {
                let capture = self
                    .source
                    .open(*plan, &self.bit_depth, self.bad_rows.policy())?;
                check_camera_size(
                    &self.calibration,
                    calibration,
                    &capture.describe(),
                    (capture.width(), capture.height()),
                )?;
                let (image, summary) = DecodedImage::decode_capture(
                    *plan,
                    &capture,
                    &self.decode.options(),
                    &Progress::stderr(),
                )?;
                Decoded {
                    image,
                    source: capture.describe(),
                    summary: Some(summary),
                    seconds: 0.0,
                }
            }
        };
        let candidates = &decoded.image.candidates;
        check_camera_size(
            &self.calibration,
            calibration,
            &decoded.source,
            (candidates.width() as u32, candidates.height() as u32),
        )?;
        Ok(Decoded {
            seconds: started.elapsed().as_secs_f64(),
            ..decoded
        })
    }
}

/// Refuses a capture whose size is not the calibrated camera's.
fn check_camera_size(
    calibration_path: &std::path::Path,
    calibration: &Calibration,
    source: &str,
    (width, height): (u32, u32),
) -> Result<()> {
    let camera = &calibration.camera;
    if (camera.width_px(), camera.height_px()) == (width, height) {
        return Ok(());
    }
    Err(Error::Usage(format!(
        "{}: the calibrated camera is {}x{} pixels, the capture {source} is {width}x{height}",
        calibration_path.display(),
        camera.width_px(),
        camera.height_px(),
    )))
}

pub fn run(args: Args) -> Result<()> {
    let plan = fsm_io::plan_file::read_method_plan(&args.plan)?;
    let calibration = load_calibration(&args.calibration)?;
    let plan_columns = plan.patterns().projector_columns();
    if calibration.projector_columns() != plan_columns as u32 {
        return Err(Error::Usage(format!(
            "{}: the projector has {} columns, the plan {} addresses {plan_columns}",
            args.calibration.display(),
            calibration.projector_columns(),
            args.plan.display(),
        )));
    }
    let camera = &calibration.camera;
    // Read before any work: a bad truth folder fails fast.
    let truth = match &args.truth {
        Some(dir) => Some((
            dir,
            fsm_sim::folder::read_truth(dir, camera.width_px(), camera.height_px())?,
        )),
        None => None,
    };
    let staged = StagedDir::create(&args.out, args.force)?;
    let decoded = args.decoded(&plan, &calibration)?;
    let params = args.selection.params(&calibration);
    let (surface, times) = Surface::reconstruct(&decoded.image, &calibration, &params);
    let method = plan.name();
    let seconds = StageSeconds {
        decode: decoded.seconds,
        triangulate: times.triangulate_seconds,
        select: times.select_seconds,
    };
    let mut summary = ScanSummary::new(
        method,
        plan.fingerprint(),
        &decoded.image,
        &surface,
        &params,
        &calibration,
        seconds,
    );
    summary.rows_without_data = decoded.image.candidates.rows_without_data();
    if let Some(d) = &decoded.summary {
        summary.bad_records = d.bad_records.iter().map(|b| b.error.clone()).collect();
    }
    summary.truth = truth.map(|(dir, (depth, lit))| {
        let errors = point_errors_from_depth(&surface.point_mm, &depth, &lit, 1.0);
        TruthSummary {
            folder: dir.display().to_string(),
            errors,
            wrong_share: errors.wrong_share(),
            completeness: errors.completeness(),
        }
    });
    write_scan(staged.path(), &surface, &summary)?;
    let out = staged.commit()?;
    eprintln!(
        "scanned {} ({}x{}): {} points of {} pixels from {} candidates ({} in the volume); {} {:.2} s, \
         triangulation {:.2} s, selection {:.2} s -> {}",
        decoded.source,
        surface.width,
        surface.height,
        summary.points,
        surface.width * surface.height,
        summary.candidates,
        summary.candidates_in_volume,
        if decoded.summary.is_some() { "decode" } else { "reading" },
        decoded.seconds,
        times.triangulate_seconds,
        times.select_seconds,
        out.display()
    );
    if let Some(d) = &decoded.summary {
        report_bad_rows(d);
    }
    Ok(())
}
