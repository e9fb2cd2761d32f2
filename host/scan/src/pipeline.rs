//! The whole scan as `fsm scan` runs it: the candidates (decoded from a capture, or read from
//! a candidate file), checked against the calibration, reconstructed into a surface and
//! written into a folder with its summary. The command only turns arguments into these calls.

use std::path::{Path, PathBuf};
use std::time::Instant;

use fsm_geometry::{Calibration, Pinhole};
use fsm_io::capture::Capture;
use fsm_io::decode::{DecodeOptions, DecodeSummary};
use fsm_io::image_files::read_tiff_f32;
use fsm_io::plan_file::{read_method_plan, MethodPlan};
use fsm_io::progress::Progress;
use fsm_io::{Error, Result};

use crate::decoded::DecodedImage;
use crate::metrics::point_errors_from_depth;
use crate::output::{write_scan, ScanSummary, StageSeconds, TruthSummary};
use crate::{SelectionParams, Surface};

/// A scan's candidates and where they came from.
pub struct ScanCandidates {
    /// Every pixel's candidates.
    pub image: DecodedImage,
    /// What they came from, for messages (`dump scan.dump`, `candidate file …`).
    pub source: String,
    /// The decode's summary, when they were decoded here.
    pub decode: Option<DecodeSummary>,
    /// Seconds spent decoding or reading.
    pub seconds: f64,
}

impl ScanCandidates {
    /// Decodes `capture` with the host's pipeline, after checking its size against the
    /// calibrated camera's (before any work).
    pub fn decode(
        plan: MethodPlan,
        capture: &Capture,
        calibration: &ScanCalibration,
        options: &DecodeOptions,
        progress: &Progress,
    ) -> Result<Self> {
        let source = capture.describe();
        calibration.check_camera_size(&source, (capture.width(), capture.height()))?;
        let started = Instant::now();
        let (image, summary) = DecodedImage::decode_capture(plan, capture, options, progress)?;
        Ok(ScanCandidates {
            image,
            source,
            decode: Some(summary),
            seconds: started.elapsed().as_secs_f64(),
        })
    }

    /// Reads the candidate file `path` (`fsm decode`'s, or a camera's) decoded with `plan`,
    /// and checks its size against the calibrated camera's. A candidate file does not record
    /// the sensor's bit depth, which a point's quality is measured in: `bit_depth` is required.
    pub fn read(
        plan: &MethodPlan,
        path: &Path,
        bit_depth: Option<u8>,
        calibration: &ScanCalibration,
    ) -> Result<Self> {
        let started = Instant::now();
        let bit_depth = match bit_depth {
            Some(bits) => bits,
            None => {
                return Err(Error::Usage(format!(
                    "--candidates {}: a candidate file does not record the sensor's bit depth, \
                     which a point's quality is measured in; give the capture's with \
                     --bit-depth (e.g. 12)",
                    path.display()
                )))
            }
        };
        let image = DecodedImage::read_candidates(plan, path, bit_depth)?;
        let source = format!("candidate file {}", path.display());
        let size = (image.candidates.width(), image.candidates.height());
        calibration.check_camera_size(&source, (size.0 as u32, size.1 as u32))?;
        Ok(ScanCandidates {
            image,
            source,
            decode: None,
            seconds: started.elapsed().as_secs_f64(),
        })
    }
}

/// What `fsm scan` reads before any work, each checked against the others: the plan, the
/// calibration of the plan's projector ([`ScanCalibration::read_for`]) and, for a simulated
/// capture, the truth of the calibrated camera's size ([`Truth::read`]). A bad truth folder
/// fails before anything is decoded.
pub struct ScanInputs {
    /// The plan, of any method.
    pub plan: MethodPlan,
    /// The calibration and its file.
    pub calibration: ScanCalibration,
    /// The true surface to score the points against, if given.
    pub truth: Option<Truth>,
}

impl ScanInputs {
    /// Reads the plan file `plan`, the calibration file `calibration` and the truth folder
    /// `truth` (if given), and checks them against one another.
    pub fn read(plan: &Path, calibration: &Path, truth: Option<&Path>) -> Result<Self> {
        let plan_path = plan;
        let plan = read_method_plan(plan_path)?;
        let calibration = ScanCalibration::read_for(calibration, &plan, plan_path)?;
        let camera = &calibration.calibration.camera;
        let truth = truth.map(|dir| Truth::read(dir, camera)).transpose()?;
        Ok(ScanInputs {
            plan,
            calibration,
            truth,
        })
    }

    /// [`scan_into`] `dir` with these inputs.
    pub fn scan_into(
        &self,
        dir: &Path,
        candidates: &ScanCandidates,
        params: &SelectionParams,
    ) -> Result<Scanned> {
        let (plan, calibration) = (&self.plan, &self.calibration.calibration);
        scan_into(
            dir,
            plan,
            candidates,
            calibration,
            params,
            self.truth.as_ref(),
        )
    }
}

/// The calibration a scan uses and the file it came from, for the checks that name the file.
pub struct ScanCalibration {
    /// The file.
    pub path: PathBuf,
    /// Its calibration.
    pub calibration: Calibration,
}

impl ScanCalibration {
    /// Reads the calibration file `path` and checks that its projector is the one `plan`
    /// (read from `plan_path`) addresses.
    pub fn read_for(path: &Path, plan: &MethodPlan, plan_path: &Path) -> Result<Self> {
        let calibration = Calibration::read(path)?;
        let plan_columns = plan.patterns().projector_columns();
        if calibration.projector_columns() != plan_columns as u32 {
            return Err(Error::Usage(format!(
                "{}: the projector has {} columns, the plan {} addresses {plan_columns}",
                path.display(),
                calibration.projector_columns(),
                plan_path.display(),
            )));
        }
        Ok(ScanCalibration {
            path: path.to_path_buf(),
            calibration,
        })
    }

    /// Refuses candidates of `source` whose size is not the calibrated camera's.
    pub fn check_camera_size(&self, source: &str, (width, height): (u32, u32)) -> Result<()> {
        let camera = &self.calibration.camera;
        if (camera.width_px(), camera.height_px()) == (width, height) {
            return Ok(());
        }
        Err(Error::Usage(format!(
            "{}: the calibrated camera is {}x{} pixels, the capture {source} is {width}x{height}",
            self.path.display(),
            camera.width_px(),
            camera.height_px(),
        )))
    }
}

/// The true surface of a simulated capture (`fsm simulate`'s `truth/`), to score the points.
pub struct Truth {
    /// The truth folder, for the summary.
    pub folder: PathBuf,
    /// True depth per pixel, mm (NaN: background).
    pub depth_mm: Vec<f32>,
    /// Whether each pixel is lit directly.
    pub lit: Vec<bool>,
}

impl Truth {
    /// Reads the truth folder `dir` as `fsm_sim::folder::write_truth` writes it: the true depth
    /// (`depth.tiff`, mm) and whether each pixel is lit directly (a finite true column in
    /// `column.tiff`), each checked to be the calibrated `camera`'s size.
    pub fn read(dir: &Path, camera: &Pinhole) -> Result<Truth> {
        let (width, height) = (camera.width_px(), camera.height_px());
        let read = |name: &str| {
            let path = dir.join(name);
            let (w, h, values) = read_tiff_f32(&path)
                .map_err(|e| Error::Usage(format!("{}: {e}", path.display())))?;
            if (w, h) != (width, height) {
                return Err(Error::Usage(format!(
                    "{}: the truth is {w}x{h} pixels, the capture {width}x{height}",
                    path.display()
                )));
            }
            Ok(values)
        };
        Ok(Truth {
            folder: dir.to_path_buf(),
            depth_mm: read("depth.tiff")?,
            lit: read("column.tiff")?.iter().map(|c| c.is_finite()).collect(),
        })
    }
}

/// A scan made and written.
pub struct Scanned {
    /// The surface.
    pub surface: Surface,
    /// What `summary.json` holds.
    pub summary: ScanSummary,
}

impl Scanned {
    /// The scan of `candidates` written into `out`, as `fsm scan` reports it: the points of
    /// the pixels, the candidates, each stage's seconds, then what the decode skipped.
    pub fn report(&self, candidates: &ScanCandidates, out: &Path) -> String {
        let (surface, summary) = (&self.surface, &self.summary);
        format!(
            "scanned {} ({}x{}): {} points of {} pixels from {} candidates ({} in the volume); \
             {} {:.2} s, triangulation {:.2} s, selection {:.2} s -> {}{}",
            candidates.source,
            surface.width,
            surface.height,
            summary.points,
            surface.width * surface.height,
            summary.candidates,
            summary.candidates_in_volume,
            if candidates.decode.is_some() {
                "decode"
            } else {
                "reading"
            },
            candidates.seconds,
            summary.triangulate_seconds,
            summary.select_seconds,
            out.display(),
            candidates
                .decode
                .as_ref()
                .map_or(String::new(), |d| d.skipped_lines())
        )
    }
}

/// Reconstructs the surface of `candidates` (triangulation, selection with `params`,
/// visibility) and writes it into `dir` (`output::write_scan`), scored against `truth` if
/// given.
pub fn scan_into(
    dir: &Path,
    plan: &MethodPlan,
    candidates: &ScanCandidates,
    calibration: &Calibration,
    params: &SelectionParams,
    truth: Option<&Truth>,
) -> Result<Scanned> {
    let (surface, times) = Surface::reconstruct(&candidates.image, calibration, params);
    let seconds = StageSeconds {
        decode: candidates.seconds,
        triangulate: times.triangulate_seconds,
        select: times.select_seconds,
    };
    let mut summary = ScanSummary::new(
        plan.name(),
        plan.fingerprint(),
        &candidates.image,
        &surface,
        params,
        calibration,
        seconds,
    );
    summary.rows_without_data = candidates.image.candidates.rows_without_data();
    if let Some(d) = &candidates.decode {
        summary.bad_records = d.bad_records.iter().map(|b| b.error.clone()).collect();
    }
    summary.truth = truth.map(|truth| {
        let errors = point_errors_from_depth(&surface.point_mm, &truth.depth_mm, &truth.lit, 1.0);
        TruthSummary {
            folder: truth.folder.display().to_string(),
            errors,
            wrong_share: errors.wrong_share(),
            completeness: errors.completeness(),
        }
    });
    write_scan(dir, &surface, &summary)?;
    Ok(Scanned { surface, summary })
}
