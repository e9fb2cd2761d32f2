//! The whole geometric calibration: per-pose observations in, an
//! [`fsm_geometry::Calibration`] and a [`CalibrationReport`] out.
//!
//! 1. Camera: Zhang's closed form ([`crate::zhang`]) then Levenberg–Marquardt on `K`, the
//!    distortion and the board poses ([`crate::refine`]).
//! 2. Projector columns of the corners: a local projective map from the decoded column map
//!    around each corner (Moreno & Taubin 2012, column row only; [`crate::homography`]).
//! 3. Projector: linear initialisation of the column planes, then Levenberg–Marquardt with
//!    the corners' positions fixed ([`crate::projector`]).
//! 4. Joint refinement (optional, default): camera, board poses and projector together, each
//!    residual divided by its stage's RMS so pixels and columns weigh by their precision. With
//!    [`CalibrationSettings::dense`] (default) and a checkerboard's corner list, the projector
//!    residuals are the dense column samples of every light square ([`crate::dense`]) instead
//!    of the corners' columns, in two passes (weights from the starting model's spread, then
//!    from the first fit's; outliers dropped each time).

use core::fmt;

use nalgebra::{DVector, Point2, Point3};
use serde::Serialize;

use fsm_geometry::{Calibration, Intrinsics, MeasurementVolume, ModelError, Pinhole};

use crate::board::Checkerboard;
use crate::dense::{self, DenseSample, DenseSettings};
use crate::homography::{local_column, LocalColumnSettings};
use crate::projector::{
    calibrate_projector, column_residuals, model_from_params, model_params, projector_free_mask,
    unflatten, ColumnModel, ProjectorError, ProjectorSettings, PROJECTOR_PARAMS,
};
use crate::refine::{
    camera_from_params, camera_residuals, camera_to_params, levenberg_marquardt, pose_from_params,
    pose_to_params, refine_camera, CameraRefineSettings, LmError, LmSettings, Stop,
    CAMERA_INTRINSIC_PARAMS,
};
use crate::zhang::{initial_estimate, BoardPose, CameraMatrix, ZhangError, MIN_POSES};

/// A decoded column map: `columns[y·width + x]` is the projector column pixel `(x, y)` sees,
/// NaN where it has none.
#[derive(Clone, Debug, PartialEq)]
pub struct ColumnMap {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Row-major columns.
    pub columns: Vec<f32>,
}

/// What one board pose gives: the corners in the camera image (in the board's corner order)
/// and the column map of its scan.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseObservation {
    /// A name for the report (e.g. the pose's folder).
    pub label: String,
    /// Sub-pixel corners, in the order of the board points given to [`calibrate`].
    pub corners_px: Vec<Point2<f64>>,
    /// The scan's column map.
    pub columns: ColumnMap,
}

/// Device sizes, assumptions and solver settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CalibrationSettings {
    /// Camera image width, pixels.
    pub camera_width: u32,
    /// Camera image height, pixels.
    pub camera_height: u32,
    /// Projector columns `cmax`.
    pub projector_columns: u32,
    /// Projector rows (not identifiable from columns; stored in the file as given).
    pub projector_rows: u32,
    /// Projector `cy` (not identifiable; `None` = `(rows − 1)/2`).
    pub projector_cy_px: Option<f64>,
    /// Measurement volume (`None` = from the board's depths: 0.75 × nearest to 1.35 × farthest).
    pub volume: Option<MeasurementVolume>,
    /// Camera refinement.
    pub camera: CameraRefineSettings,
    /// Projector refinement.
    pub projector: ProjectorSettings,
    /// Refine camera, poses and projector together at the end.
    pub joint: bool,
    /// Local column fits around the corners.
    pub local: LocalColumnSettings,
    /// Dense column samples in the joint refinement ([`crate::dense`]); used by [`calibrate`],
    /// which has the column maps, when the board points are a checkerboard's corner list in
    /// its order (`Checkerboard::corners_mm`). `None` = the corners' columns only.
    pub dense: Option<DenseSettings>,
}

impl CalibrationSettings {
    /// Defaults for the given device sizes.
    pub fn new(
        camera_width: u32,
        camera_height: u32,
        projector_columns: u32,
        projector_rows: u32,
    ) -> Self {
        CalibrationSettings {
            camera_width,
            camera_height,
            projector_columns,
            projector_rows,
            projector_cy_px: None,
            volume: None,
            camera: CameraRefineSettings::default(),
            projector: ProjectorSettings::default(),
            joint: true,
            local: LocalColumnSettings::default(),
            dense: Some(DenseSettings::default()),
        }
    }
}

/// Why a calibration failed.
#[derive(Debug)]
pub enum CalibrateError {
    /// Fewer than [`MIN_POSES`] poses.
    TooFewPoses {
        /// Poses given.
        given: usize,
    },
    /// The board has too few corners.
    TooFewCorners {
        /// Corners of the board.
        given: usize,
        /// Needed.
        needed: usize,
    },
    /// A pose's corner list does not match the board.
    CornerCount {
        /// Pose label.
        pose: String,
        /// Corners given.
        given: usize,
        /// Board corners.
        expected: usize,
    },
    /// A pose's column map does not match the camera.
    ColumnMapSize {
        /// Pose label.
        pose: String,
        /// Its size.
        given: (usize, usize),
        /// The camera's.
        expected: (usize, usize),
    },
    /// Zhang's initialisation failed.
    Camera(ZhangError),
    /// A refinement failed.
    Solver {
        /// Which stage.
        stage: &'static str,
        /// Why.
        error: LmError,
    },
    /// The projector could not be calibrated.
    Projector(ProjectorError),
    /// The result is not a valid model (e.g. a distortion that folds the image).
    Model(ModelError),
}

impl fmt::Display for CalibrateError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CalibrateError::TooFewPoses { given } => write!(
                f,
                "{given} board poses given; at least {MIN_POSES} are needed, tilted in different directions"
            ),
            CalibrateError::TooFewCorners { given, needed } => write!(
                f,
                "the board has {given} corners; at least {needed} are needed"
            ),
            CalibrateError::CornerCount {
                pose,
                given,
                expected,
            } => write!(
                f,
                "pose {pose}: {given} corners but the board has {expected}"
            ),
            CalibrateError::ColumnMapSize {
                pose,
                given,
                expected,
            } => write!(
                f,
                "pose {pose}: the column map is {}x{} but the camera is {}x{}",
                given.0, given.1, expected.0, expected.1
            ),
            CalibrateError::Camera(e) => write!(f, "camera: {e}"),
            CalibrateError::Solver { stage, error } => write!(f, "{stage}: {error}"),
            CalibrateError::Projector(e) => write!(f, "projector: {e}"),
            CalibrateError::Model(e) => write!(f, "the calibrated model is not valid: {e}"),
        }
    }
}

impl std::error::Error for CalibrateError {}

/// A failed calibration as the host's error (`fsm calibrate target`'s `calibration failed:
/// …`), as `fsm_sim`'s errors convert, so that callers need no wrapper of their own.
impl From<CalibrateError> for fsm_io::Error {
    fn from(e: CalibrateError) -> Self {
        fsm_io::Error::Usage(format!("calibration failed: {e}"))
    }
}

/// Fewest board corners accepted (a homography needs 4; the refinement more).
pub const MIN_CORNERS: usize = 6;

/// Fewest dense samples per pose, on average, for the joint refinement to use them rather than
/// the corners' columns.
pub const MIN_DENSE_SAMPLES_PER_POSE: usize = 20;

/// One estimated parameter.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Parameter {
    /// Name (`fx_px`, `k1`, …).
    pub name: String,
    /// Value.
    pub value: f64,
    /// Standard deviation from `σ²(JᵀJ)⁻¹` of the last refinement (`null` when fixed or not
    /// available).
    pub std_dev: Option<f64>,
    /// Held fixed (not identifiable, or chosen so).
    pub fixed: bool,
}

/// Per-pose figures and residuals.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PoseReport {
    /// The pose's label.
    pub label: String,
    /// Corners.
    pub corners: usize,
    /// Corners with a projector column.
    pub corners_with_column: usize,
    /// Camera reprojection RMS, pixels: `sqrt(Σ(du² + dv²)/N)` (OpenCV's figure).
    pub camera_rms_px: f64,
    /// Projector reprojection RMS, columns.
    pub projector_rms_columns: f64,
    /// Distance of the board origin from the camera, mm.
    pub distance_mm: f64,
    /// Angle between the board normal and the camera's axis, degrees.
    pub tilt_deg: f64,
    /// Detected corner positions, pixels.
    pub corners_px: Vec<[f64; 2]>,
    /// Camera residuals (observed − predicted) per corner, pixels.
    pub camera_residuals_px: Vec<[f64; 2]>,
    /// Projector residuals per corner, columns (`null` where the corner had no column).
    pub projector_residuals_columns: Vec<Option<f64>>,
    /// Dense column samples of this pose used by the joint refinement ([`crate::dense`]).
    pub dense_samples: usize,
    /// Their RMS residual, columns (`null` without dense samples).
    pub dense_rms_columns: Option<f64>,
}

/// Solver iterations per stage.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Iterations {
    /// Camera LM.
    pub camera: usize,
    /// Projector LM.
    pub projector: usize,
    /// Joint LM (0 when not run).
    pub joint: usize,
    /// Why the last stage stopped.
    pub last_stop: Stop,
}

/// What the calibration found and how well it fits.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CalibrationReport {
    /// Camera reprojection RMS over all poses, pixels.
    pub camera_rms_px: f64,
    /// Projector reprojection RMS over all poses, columns.
    pub projector_rms_columns: f64,
    /// RMS residual of the dense column samples over all poses, columns (`null` without them).
    pub dense_rms_columns: Option<f64>,
    /// Per pose.
    pub poses: Vec<PoseReport>,
    /// Camera parameters.
    pub camera: Vec<Parameter>,
    /// Projector parameters (column model; `fy`, `cy` are assumptions).
    pub projector: Vec<Parameter>,
    /// Distance between the centres, mm.
    pub baseline_mm: f64,
    /// Solver iterations.
    pub iterations: Iterations,
    /// What was assumed rather than measured.
    pub assumptions: Vec<String>,
}

impl CalibrationReport {
    /// As pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("the report serialises")
    }
}

/// Calibrates from per-pose observations: corners in the camera image plus the column map of
/// each pose's scan. `board_mm` are the board's corners (plane `z = 0`), in the order of every
/// pose's `corners_px`.
pub fn calibrate(
    board_mm: &[Point2<f64>],
    poses: &[PoseObservation],
    settings: &CalibrationSettings,
) -> Result<(Calibration, CalibrationReport), CalibrateError> {
    check_counts(
        board_mm,
        poses.len(),
        poses.iter().map(|p| (&p.label, p.corners_px.len())),
    )?;
    let expected = (
        settings.camera_width as usize,
        settings.camera_height as usize,
    );
    let mut columns = Vec::with_capacity(poses.len());
    for pose in poses {
        let map = &pose.columns;
        if (map.width, map.height) != expected || map.columns.len() != map.width * map.height {
            return Err(CalibrateError::ColumnMapSize {
                pose: pose.label.clone(),
                given: (map.width, map.height),
                expected,
            });
        }
        columns.push(
            pose.corners_px
                .iter()
                .map(|&c| {
                    local_column(&map.columns, map.width, map.height, c, &settings.local).ok()
                })
                .collect::<Vec<_>>(),
        );
    }
    let labels: Vec<String> = poses.iter().map(|p| p.label.clone()).collect();
    let corners: Vec<Vec<Point2<f64>>> = poses.iter().map(|p| p.corners_px.clone()).collect();
    // The local maps are evaluated where the calibrated camera puts each corner (see
    // `LocalColumn::at`).
    let source = |pose: usize, corner: usize, predicted: Option<Point2<f64>>| {
        let fit = columns[pose][corner].as_ref()?;
        Some(predicted.map_or(fit.column, |p| fit.at(p)))
    };
    let maps: Vec<&ColumnMap> = poses.iter().map(|p| &p.columns).collect();
    calibrate_inner(board_mm, &labels, &corners, &source, &maps, settings)
}

fn check_counts<'a>(
    board_mm: &[Point2<f64>],
    poses: usize,
    counts: impl Iterator<Item = (&'a String, usize)>,
) -> Result<(), CalibrateError> {
    if poses < MIN_POSES {
        return Err(CalibrateError::TooFewPoses { given: poses });
    }
    if board_mm.len() < MIN_CORNERS {
        return Err(CalibrateError::TooFewCorners {
            given: board_mm.len(),
            needed: MIN_CORNERS,
        });
    }
    for (label, n) in counts {
        if n != board_mm.len() {
            return Err(CalibrateError::CornerCount {
                pose: label.clone(),
                given: n,
                expected: board_mm.len(),
            });
        }
    }
    Ok(())
}

/// [`calibrate`] once every corner's projector column is known (`None` = no column):
/// `corners_px[pose][corner]`, `columns[pose][corner]`, `labels[pose]`.
pub fn calibrate_from_columns(
    board_mm: &[Point2<f64>],
    labels: &[String],
    corners_px: &[Vec<Point2<f64>>],
    columns: &[Vec<Option<f64>>],
    settings: &CalibrationSettings,
) -> Result<(Calibration, CalibrationReport), CalibrateError> {
    for (i, cols) in columns.iter().enumerate() {
        if cols.len() != board_mm.len() {
            return Err(CalibrateError::CornerCount {
                pose: labels.get(i).cloned().unwrap_or_else(|| format!("{i}")),
                given: cols.len(),
                expected: board_mm.len(),
            });
        }
    }
    if columns.len() != corners_px.len() {
        return Err(CalibrateError::TooFewPoses {
            given: columns.len().min(corners_px.len()),
        });
    }
    let source = |pose: usize, corner: usize, _: Option<Point2<f64>>| columns[pose][corner];
    calibrate_inner(board_mm, labels, corners_px, &source, &[], settings)
}

/// Column of corner `corner` of pose `pose`, given where the calibrated camera puts it.
type ColumnSource<'a> = dyn Fn(usize, usize, Option<Point2<f64>>) -> Option<f64> + 'a;

fn calibrate_inner(
    board_mm: &[Point2<f64>],
    labels: &[String],
    corners_px: &[Vec<Point2<f64>>],
    source: &ColumnSource<'_>,
    maps: &[&ColumnMap],
    settings: &CalibrationSettings,
) -> Result<(Calibration, CalibrationReport), CalibrateError> {
    let fallback: Vec<String>;
    let labels = if labels.len() == corners_px.len() {
        labels
    } else {
        fallback = (0..corners_px.len()).map(|i| format!("{i}")).collect();
        &fallback
    };
    check_counts(
        board_mm,
        corners_px.len(),
        labels.iter().zip(corners_px).map(|(l, c)| (l, c.len())),
    )?;
    // 1. Camera.
    let zhang = initial_estimate(board_mm, corners_px).map_err(CalibrateError::Camera)?;
    let cam = refine_camera(
        board_mm,
        corners_px,
        &zhang.camera,
        &fsm_geometry::BrownConrady::NONE,
        &zhang.poses,
        &settings.camera,
    )
    .map_err(|error| CalibrateError::Solver {
        stage: "camera refinement",
        error,
    })?;

    // 2. Each corner's column, where the camera model puts the corner.
    let points = corner_points(board_mm, &cam.poses);
    let columns: Vec<Vec<Option<f64>>> = points
        .iter()
        .enumerate()
        .map(|(i, pts)| {
            pts.iter()
                .enumerate()
                .map(|(j, x)| {
                    let predicted = crate::refine::project(&cam.camera, &cam.distortion, &x.coords);
                    source(i, j, predicted).filter(|c| c.is_finite())
                })
                .collect()
        })
        .collect();

    // 3. Projector from the corners' camera-frame positions.
    let proj = calibrate_projector(&points, &columns, &settings.projector)
        .map_err(CalibrateError::Projector)?;

    let mut camera_k = cam.camera;
    let mut camera_d = cam.distortion;
    let mut board_poses = cam.poses.clone();
    let mut model = proj.model;
    let mut camera_std = cam.std_dev.to_vec();
    let mut projector_std = proj.std_dev.to_vec();
    let mut joint_iterations = 0;
    let mut last_stop = proj.stop;

    // Dense samples, located with the camera stage's model.
    let board = Checkerboard::from_corners_mm(board_mm);
    let mut samples: Vec<Vec<DenseSample>> = match (settings.dense, board) {
        (Some(ds), Some(board)) if maps.len() == cam.poses.len() => maps
            .iter()
            .zip(&cam.poses)
            .map(|(map, pose)| dense::select(map, &board, &camera_k, &camera_d, pose, &ds))
            .collect(),
        _ => Vec::new(),
    };
    // Too few (boards mostly dark or undecoded): the corners' columns instead.
    if samples.iter().map(Vec::len).sum::<usize>() < MIN_DENSE_SAMPLES_PER_POSE * samples.len() {
        samples.clear();
    }

    // 4. Joint refinement.
    if settings.joint {
        let sigma_c = (cam.rms_total_px / std::f64::consts::SQRT_2).max(1e-6);
        let sigma_p = proj.rms_total_columns.max(1e-6);
        let outlier_sigmas = settings.dense.map_or(f64::INFINITY, |d| d.outlier_sigmas);
        let mut start = (camera_k, camera_d, board_poses.clone(), model);
        let mut joint: Option<JointFit> = None;
        // With dense samples, two passes: the first weighs them by their spread about the
        // starting model (mostly that model's error), the second by their spread about the
        // first fit (their noise); each drops the samples beyond `outlier_sigmas`.
        for _ in 0..if samples.is_empty() { 1 } else { 2 } {
            if let Some(j) = &joint {
                start = (j.camera, j.distortion, j.poses.clone(), j.model);
            }
            let sigma_d = if samples.is_empty() {
                1.0
            } else {
                dense::weigh_and_prune(
                    (&start.0, &start.1, &start.2, &start.3),
                    &mut samples,
                    outlier_sigmas,
                )
                .ok_or(CalibrateError::Solver {
                    stage: "dense column residuals",
                    error: LmError::InvalidStart,
                })?
            };
            joint = Some(
                refine_joint(
                    board_mm,
                    corners_px,
                    &columns,
                    (&start.0, &start.1, &start.2, &start.3),
                    (sigma_c, sigma_p, sigma_d),
                    &samples,
                    settings,
                )
                .map_err(|error| CalibrateError::Solver {
                    stage: "joint refinement",
                    error,
                })?,
            );
        }
        let joint = joint.expect("at least one pass ran");
        camera_k = joint.camera;
        camera_d = joint.distortion;
        board_poses = joint.poses;
        model = joint.model;
        camera_std = joint.camera_std;
        projector_std = joint.projector_std;
        joint_iterations = joint.iterations;
        last_stop = joint.stop;
    }

    // Final residuals.
    let mut flat = Vec::new();
    camera_residuals(
        &camera_k,
        &camera_d,
        &board_poses,
        board_mm,
        corners_px,
        &mut flat,
    )
    .ok_or(CalibrateError::Solver {
        stage: "final residuals",
        error: LmError::InvalidStart,
    })?;
    let points = corner_points(board_mm, &board_poses);
    let mut flat_p = Vec::new();
    column_residuals(&model, &points, &columns, &mut flat_p).ok_or(CalibrateError::Solver {
        stage: "final residuals",
        error: LmError::InvalidStart,
    })?;
    let (proj_res, proj_rms, proj_total) = unflatten(&flat_p, &columns);
    let mut dense_flat = Vec::new();
    if !samples.is_empty() {
        dense::rays(&camera_k, &camera_d, &samples)
            .and_then(|rays| {
                dense::residuals(&rays, &board_poses, &model, &samples, &mut dense_flat)
            })
            .ok_or(CalibrateError::Solver {
                stage: "final residuals",
                error: LmError::InvalidStart,
            })?;
    }
    let rms_of = |r: &[f64]| {
        (!r.is_empty()).then(|| (r.iter().map(|e| e * e).sum::<f64>() / r.len() as f64).sqrt())
    };
    let mut dense_rest = dense_flat.as_slice();
    let n = board_mm.len();
    let mut pose_reports = Vec::with_capacity(corners_px.len());
    let mut sum_c = 0.0;
    for (i, pose) in board_poses.iter().enumerate() {
        let res: Vec<[f64; 2]> = (0..n)
            .map(|j| [flat[2 * (i * n + j)], flat[2 * (i * n + j) + 1]])
            .collect();
        let s: f64 = res.iter().map(|r| r[0] * r[0] + r[1] * r[1]).sum();
        sum_c += s;
        let normal = pose.normal();
        pose_reports.push(PoseReport {
            label: labels[i].clone(),
            corners: n,
            corners_with_column: columns[i].iter().filter(|c| c.is_some()).count(),
            camera_rms_px: (s / n as f64).sqrt(),
            projector_rms_columns: proj_rms[i],
            distance_mm: pose.translation_mm.norm(),
            tilt_deg: normal.z.abs().clamp(0.0, 1.0).acos().to_degrees(),
            corners_px: corners_px[i].iter().map(|p| [p.x, p.y]).collect(),
            camera_residuals_px: res,
            projector_residuals_columns: proj_res[i].clone(),
            dense_samples: samples.get(i).map_or(0, Vec::len),
            dense_rms_columns: {
                let (r, rest) = dense_rest.split_at(samples.get(i).map_or(0, Vec::len));
                dense_rest = rest;
                rms_of(r)
            },
        });
    }
    let camera_rms_px = (sum_c / (n * corners_px.len()) as f64).sqrt();

    // The calibration.
    let camera = Pinhole::new(
        "camera",
        settings.camera_width,
        settings.camera_height,
        Intrinsics {
            fx_px: camera_k.fx,
            fy_px: camera_k.fy,
            cx_px: camera_k.cx,
            cy_px: camera_k.cy,
        },
        camera_d,
    )
    .map_err(CalibrateError::Model)?;
    let cy = settings
        .projector_cy_px
        .unwrap_or((settings.projector_rows as f64 - 1.0) / 2.0);
    let projector = Pinhole::new(
        "projector",
        settings.projector_columns,
        settings.projector_rows,
        Intrinsics {
            fx_px: model.fx,
            fy_px: model.fx,
            cx_px: model.cx,
            cy_px: cy,
        },
        model.distortion,
    )
    .map_err(CalibrateError::Model)?;
    let volume = match settings.volume {
        Some(v) => v,
        None => {
            let depths = points.iter().flatten().map(|p| p.z);
            let (lo, hi) = depths.fold((f64::INFINITY, 0.0f64), |(lo, hi), z| {
                (lo.min(z), hi.max(z))
            });
            MeasurementVolume::new(0.75 * lo, 1.35 * hi).map_err(CalibrateError::Model)?
        }
    };
    let calibration = Calibration {
        camera,
        projector,
        pose: model.pose(),
        volume,
    };

    let cam_free = {
        let mut f = [true; CAMERA_INTRINSIC_PARAMS];
        f[8] = !settings.camera.fix_k3;
        f[6] = !settings.camera.fix_tangential;
        f[7] = !settings.camera.fix_tangential;
        f
    };
    let cam_names = [
        "fx_px", "fy_px", "cx_px", "cy_px", "k1", "k2", "p1", "p2", "k3",
    ];
    let cam_values = camera_to_params(&camera_k, &camera_d);
    let camera_params = (0..CAMERA_INTRINSIC_PARAMS)
        .map(|i| Parameter {
            name: cam_names[i].into(),
            value: cam_values[i],
            std_dev: if cam_free[i] {
                Some(camera_std[i]).filter(|s| s.is_finite())
            } else {
                None
            },
            fixed: !cam_free[i],
        })
        .collect();
    let proj_free = projector_free_mask(&settings.projector);
    let proj_names = [
        "fx_px", "cx_px", "k1", "k2", "p1", "p2", "k3", "rx_rad", "ry_rad", "rz_rad", "tx_mm",
        "ty_mm", "tz_mm",
    ];
    let proj_values = model_params(&model);
    let mut projector_params: Vec<Parameter> = (0..PROJECTOR_PARAMS)
        .map(|i| Parameter {
            name: proj_names[i].into(),
            value: proj_values[i],
            std_dev: if proj_free[i] {
                Some(projector_std[i]).filter(|s| s.is_finite())
            } else {
                None
            },
            fixed: !proj_free[i],
        })
        .collect();
    projector_params.push(Parameter {
        name: "fy_px".into(),
        value: model.fx,
        std_dev: None,
        fixed: true,
    });
    projector_params.push(Parameter {
        name: "cy_px".into(),
        value: cy,
        std_dev: None,
        fixed: true,
    });
    let mut assumptions = vec![
        "camera skew is 0 (the calibration file has none)".to_string(),
        "projector fy = fx and cy, rows as given: a column-only observation does not fix them, and triangulation uses columns only".to_string(),
    ];
    if !settings.projector.refine_vertical_offset {
        assumptions.push("projector t.y = 0: its centre is the point of its vertical axis nearest the camera centre (not observable from columns without distortion)".into());
    }
    if settings.camera.fix_k3 {
        assumptions.push("camera k3 = 0".into());
    }
    if !settings.projector.refine_k3 {
        assumptions.push("projector k3 = 0".into());
    }
    if !settings.projector.refine_tangential {
        assumptions.push("projector p1 = p2 = 0 (weakly identifiable from columns)".into());
    }
    if settings.volume.is_none() {
        assumptions.push(format!(
            "measurement volume {:.0}-{:.0} mm from the board's depths (0.75x nearest, 1.35x farthest)",
            volume.near_mm(),
            volume.far_mm()
        ));
    }
    let report = CalibrationReport {
        camera_rms_px,
        projector_rms_columns: proj_total,
        dense_rms_columns: rms_of(&dense_flat),
        poses: pose_reports,
        camera: camera_params,
        projector: projector_params,
        baseline_mm: model.translation_mm.norm(),
        iterations: Iterations {
            camera: cam.iterations,
            projector: proj.iterations,
            joint: joint_iterations,
            last_stop,
        },
        assumptions,
    };
    Ok((calibration, report))
}

/// Camera-frame positions of every corner of every pose.
pub fn corner_points(board_mm: &[Point2<f64>], poses: &[BoardPose]) -> Vec<Vec<Point3<f64>>> {
    poses
        .iter()
        .map(|p| board_mm.iter().map(|b| p.to_camera(b)).collect())
        .collect()
}

struct JointFit {
    camera: CameraMatrix,
    distortion: fsm_geometry::BrownConrady,
    poses: Vec<BoardPose>,
    model: ColumnModel,
    camera_std: Vec<f64>,
    projector_std: Vec<f64>,
    iterations: usize,
    stop: Stop,
}

/// Camera, board poses and projector together; camera residuals divided by `sigma.0`
/// (pixels per coordinate), projector residuals by `sigma.1` (columns).
fn refine_joint(
    board_mm: &[Point2<f64>],
    corners_px: &[Vec<Point2<f64>>],
    columns: &[Vec<Option<f64>>],
    start: (
        &CameraMatrix,
        &fsm_geometry::BrownConrady,
        &[BoardPose],
        &ColumnModel,
    ),
    sigma: (f64, f64, f64),
    dense: &[Vec<DenseSample>],
    settings: &CalibrationSettings,
) -> Result<JointFit, LmError> {
    let (k, d, poses, model) = start;
    let np = poses.len();
    let off_proj = CAMERA_INTRINSIC_PARAMS + 6 * np;
    let mut p0 = Vec::with_capacity(off_proj + PROJECTOR_PARAMS);
    p0.extend(camera_to_params(k, d));
    for pose in poses {
        p0.extend(pose_to_params(pose));
    }
    p0.extend(model_params(model));
    let mut free = vec![true; p0.len()];
    free[8] = !settings.camera.fix_k3;
    free[6] = !settings.camera.fix_tangential;
    free[7] = !settings.camera.fix_tangential;
    for (i, f) in projector_free_mask(&settings.projector)
        .into_iter()
        .enumerate()
    {
        free[off_proj + i] = f;
    }
    let unpack = |p: &[f64]| {
        let (k, d) = camera_from_params(&p[..CAMERA_INTRINSIC_PARAMS]);
        let poses: Vec<BoardPose> = (0..np)
            .map(|i| pose_from_params(&p[CAMERA_INTRINSIC_PARAMS + 6 * i..]))
            .collect();
        let model = model_from_params(&p[off_proj..]);
        (k, d, poses, model)
    };
    // The dense samples' rays depend on the camera's intrinsics only: kept while a trial (most
    // columns of the numeric Jacobian) moves only poses or the projector.
    type Rays = std::rc::Rc<Vec<Vec<nalgebra::Vector3<f64>>>>;
    let ray_cache: std::cell::RefCell<Option<(Vec<f64>, Rays)>> = Default::default();
    let f = |p: &DVector<f64>| -> Option<DVector<f64>> {
        let (k, d, poses, model) = unpack(p.as_slice());
        let mut out = Vec::new();
        camera_residuals(&k, &d, &poses, board_mm, corners_px, &mut out)?;
        for r in out.iter_mut() {
            *r /= sigma.0;
        }
        let n_cam = out.len();
        if dense.is_empty() {
            let points = corner_points(board_mm, &poses);
            column_residuals(&model, &points, columns, &mut out)?;
            for r in out[n_cam..].iter_mut() {
                *r /= sigma.1;
            }
        }
        let n_before = out.len();
        if !dense.is_empty() {
            let intrinsics = &p.as_slice()[..CAMERA_INTRINSIC_PARAMS];
            let cached = ray_cache
                .borrow()
                .as_ref()
                .filter(|(key, _)| key.as_slice() == intrinsics)
                .map(|(_, rays)| rays.clone());
            let rays = match cached {
                Some(rays) => rays,
                None => {
                    let rays: Rays = std::rc::Rc::new(dense::rays(&k, &d, dense)?);
                    *ray_cache.borrow_mut() = Some((intrinsics.to_vec(), rays.clone()));
                    rays
                }
            };
            dense::residuals(&rays, &poses, &model, dense, &mut out)?;
        }
        for r in out[n_before..].iter_mut() {
            *r /= sigma.2;
        }
        Some(DVector::from_vec(out))
    };
    let lm = LmSettings {
        max_iterations: settings.camera.lm.max_iterations,
        ..settings.camera.lm
    };
    let res = levenberg_marquardt(f, DVector::from_vec(p0), &free, &lm)?;
    let (camera, distortion, poses, model) = unpack(res.params.as_slice());
    // The weights scale the covariance: σ² is estimated from the weighted residuals, so the
    // standard deviations are in the parameters' own units already.
    let std = res.std_dev.as_slice();
    Ok(JointFit {
        camera,
        distortion,
        poses,
        model,
        camera_std: std[..CAMERA_INTRINSIC_PARAMS].to_vec(),
        projector_std: std[off_proj..].to_vec(),
        iterations: res.iterations,
        stop: res.stop,
    })
}
