//! `fsm calibrate target`: geometric calibration from checkerboard scans (fsm-calibrate;
//! the method: docs/calibration.md).

use std::path::PathBuf;

use fsm_calibrate::board::Checkerboard;
use fsm_calibrate::pose_folder::observe_poses;
use fsm_calibrate::report::TargetOutputs;
use fsm_calibrate::{calibrate, CalibrationSettings};
use fsm_geometry::MeasurementVolume;
use fsm_io::outputs::check_file_targets;
use fsm_io::{Error, Result};

use crate::commands::{BitDepth, DecodeArgs, OutFile};

/// The layout of the pose folders, the method and the outputs (shown after the options).
const TARGET_HELP: &str = "\
Hold the board still at 3 or more poses (10-15 is better), tilted 10-45 degrees in
different directions, filling much of the camera's view and lit by the projector, and
scan each pose with the plan. Each --poses folder is one pose, either

  a captured stack   the scan's images as `fsm scan` reads them (0000.png, 0001.png, …,
                     the plan's sequence: frame 0 dark, frame 1 white, then the fringes);
                     decoded here, the corners found in its white − dark frame; or
  decoded            column.tiff (as `fsm decode` writes it) plus white.png / white.tif /
                     white.tiff (the board under a full-on frame; a dark.png / dark.tif /
                     dark.tiff beside it is subtracted).

The method (Zhang's for the camera, the projector as an inverse camera seen through its
columns; fy = fx, and cy and rows, which columns cannot fix, from the options): docs/calibration.md.

Writes the calibration file (--out) and a JSON report (--report): reprojection RMS of the
camera (px) and the projector (columns) per pose, every parameter with its standard
deviation, every corner's residuals. --residuals DIR adds one picture per pose: the white
frame with each corner's camera residual as a red line (x 200) and its projector residual
as a dot (blue: observed column left of the model, yellow: right; brighter = larger).
Every file appears whole or not at all.

Examples:
  fsm calibrate target --board calibration/targets/checkerboard-9x6-20mm.toml \\
      --plan plan.toml --poses pose1/ pose2/ pose3/ pose4/ \\
      --out calibration.toml --report report.json --residuals residuals/";

/// Arguments of `fsm calibrate target`.
#[derive(clap::Args, Debug)]
#[command(after_help = TARGET_HELP)]
#[command(mut_arg("force", |a| a.help("Replace the --out and --report files if they exist")))]
pub struct Args {
    /// Target definition file (calibration/targets/*.toml).
    #[arg(long, value_name = "FILE")]
    board: PathBuf,
    /// Scan-plan file the poses were scanned with (sets the projector's columns).
    #[arg(long, value_name = "FILE")]
    plan: PathBuf,
    /// One folder per pose (at least 3): a captured stack, or column.tiff + white.png.
    #[arg(long, value_name = "DIR", num_args = 1.., required = true)]
    poses: Vec<PathBuf>,
    #[command(flatten)]
    output: OutFile,
    /// JSON report to write.
    #[arg(long, value_name = "FILE")]
    report: Option<PathBuf>,
    /// Folder for one residual picture per pose (created if missing).
    #[arg(long, value_name = "DIR")]
    residuals: Option<PathBuf>,
    #[command(flatten)]
    settings: SettingsArgs,
    #[command(flatten)]
    bit_depth: BitDepth,
    #[command(flatten)]
    decode: DecodeArgs,
}

/// The calibration's settings (`fsm_calibrate::CalibrationSettings`).
#[derive(clap::Args, Debug)]
struct SettingsArgs {
    /// Projector rows (not measurable from columns; stored in the file).
    #[arg(long, value_name = "ROWS", default_value_t = 1024)]
    projector_rows: u32,
    /// Projector principal point row, px (not measurable from columns; default (rows − 1)/2).
    #[arg(long, value_name = "PX")]
    projector_cy: Option<f64>,
    /// Nearest depth of the measurement volume, mm (default: 0.75 × the nearest corner).
    #[arg(long, value_name = "MM", requires = "far")]
    near: Option<f64>,
    /// Farthest depth of the measurement volume, mm (default: 1.35 × the farthest corner).
    #[arg(long, value_name = "MM", requires = "near")]
    far: Option<f64>,
    /// Estimate the camera's k3 too (wide-angle lenses; otherwise k3 = 0).
    #[arg(long)]
    camera_k3: bool,
    /// Estimate the projector's tangential distortion p1, p2 (weakly determined by columns).
    #[arg(long)]
    projector_tangential: bool,
    /// Skip the final joint refinement of camera and projector.
    #[arg(long)]
    no_joint: bool,
    /// Joint refinement from the corners' columns only, without the dense column samples of
    /// every light square (faster, less precise).
    #[arg(long)]
    no_dense: bool,
    /// Half-width of the window of decoded pixels fitted around each corner, px.
    #[arg(long, value_name = "PX", default_value_t = 12)]
    window: usize,
}

impl SettingsArgs {
    /// The settings for a camera of `camera` pixels and a projector of `columns` columns:
    /// the library's defaults, overridden by the options given.
    fn settings(&self, camera: (u32, u32), columns: u32) -> Result<CalibrationSettings> {
        let mut settings =
            CalibrationSettings::new(camera.0, camera.1, columns, self.projector_rows);
        settings.projector_cy_px = self.projector_cy;
        if let (Some(near), Some(far)) = (self.near, self.far) {
            let volume = MeasurementVolume::new(near, far);
            settings.volume = Some(volume.map_err(|e| Error::Usage(format!("--near/--far: {e}")))?);
        }
        settings.camera.fix_k3 = !self.camera_k3;
        settings.projector.refine_tangential = self.projector_tangential;
        settings.joint = !self.no_joint;
        if self.no_dense {
            settings.dense = None;
        }
        settings.local.half_window_px = self.window;
        Ok(settings)
    }
}

/// Runs `fsm calibrate target`.
pub fn run(args: Args) -> Result<()> {
    let out = args.output.check()?;
    check_file_targets(args.report.as_deref(), args.output.force)?;
    let board = Checkerboard::read(&args.board)?;
    let plan = fsm_io::plan_file::read_plan(&args.plan)?;
    let (bits, options) = (args.bit_depth.bit_depth, args.decode.options());
    let poses = observe_poses(&args.poses, &plan, bits, &options, &board, |p| {
        eprintln!("{p}")
    })?;
    let camera = (poses.width, poses.height);
    let settings = args
        .settings
        .settings(camera, plan.projector_columns as u32)?;
    let (calibration, report) = calibrate(&board.corners_mm(), &poses.observations, &settings)?;
    say!("{}", report.table());
    let outputs = TargetOutputs {
        calibration: out,
        report: args.report.as_deref(),
        residuals: args.residuals.as_deref(),
    };
    outputs.write(&calibration, &report, &poses, |line| eprintln!("{line}"))
}
