//! `fsm calibrate target`: geometric calibration from checkerboard scans (fsm-calibrate:
//! Zhang's method for the camera, the projector as a column-only inverse camera from local
//! homographies of the decoded columns, after Moreno & Taubin).

use std::path::{Path, PathBuf};

use fsm_calibrate::board::Checkerboard;
use fsm_calibrate::calibrate::CalibrationReport;
use fsm_calibrate::{calibrate, corners, CalibrationSettings, ColumnMap, PoseObservation};
use fsm_core::ScanPlan;
use fsm_geometry::MeasurementVolume;
use fsm_host::capture::Capture;
use fsm_host::column_map::COLUMN_TIFF_NAME;
use fsm_host::decode::{decode_capture, DecodeOptions};
use fsm_host::image_files;
use fsm_host::outputs::write_file;
use fsm_host::progress::Progress;
use fsm_host::{Error, Result};

/// The layout of the pose folders, the method and the outputs (shown after the options).
const TARGET_HELP: &str = "\
Calibrate the camera and the projector from scans of a planar checkerboard.

Hold the board still at 3 or more poses (10-15 is better), tilted 10-45 degrees in
different directions, filling much of the camera's view and lit by the projector, and
scan each pose with the plan. Each --poses folder is one pose, either

  a captured stack   the scan's images as `fsm scan` reads them (0000.png, 0001.png, …,
                     the plan's sequence: frame 0 dark, frame 1 white, then the fringes);
                     decoded here, the corners found in its white − dark frame; or
  decoded            column.tiff (as `fsm decode` writes it) plus white.png / white.tif /
                     white.tiff (the board under a full-on frame; a dark.png / dark.tif /
                     dark.tiff beside it is subtracted).

The camera: Zhang's closed form, then Levenberg-Marquardt on K, distortion (k1 k2 p1 p2;
k3 with --camera-k3) and the poses. The projector: each corner's column from a local
projective fit of the decoded columns around it, then the projector as an inverse camera
seen through its columns; finally everything refined together. Columns alone do not fix
the projector's fy, cy, rows or its offset along its vertical axis: fy = fx, cy and rows
are taken from the options (triangulation uses columns only).

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
    /// Calibration file to write.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// JSON report to write.
    #[arg(long, value_name = "FILE")]
    report: Option<PathBuf>,
    /// Folder for one residual picture per pose (created if missing).
    #[arg(long, value_name = "DIR")]
    residuals: Option<PathBuf>,
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
    /// Sensor bit depth of the captured stacks (see `fsm decode --help`).
    #[arg(long, value_name = "BITS", value_parser = clap::value_parser!(u8).range(1..=16))]
    bit_depth: Option<u8>,
    /// Decoding threads (default: one per core).
    #[arg(long, value_name = "N", default_value_t = 0)]
    threads: usize,
    /// Most captured samples held in memory at once, MiB.
    #[arg(long, value_name = "MiB", default_value_t = 2048)]
    memory_budget: u64,
}

const WHITE_NAMES: [&str; 3] = ["white.png", "white.tif", "white.tiff"];
const DARK_NAMES: [&str; 3] = ["dark.png", "dark.tif", "dark.tiff"];

fn read_grey(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    let (info, data) = image_files::read_image(path)
        .map_err(|e| Error::Usage(format!("{}: {}", path.display(), e.0)))?;
    Ok((
        info.width,
        info.height,
        data.into_iter().map(f32::from).collect(),
    ))
}

/// A pose folder's white − dark image and column map.
struct PoseData {
    width: u32,
    height: u32,
    white: Vec<f32>,
    columns: Vec<f32>,
}

fn load_pose(dir: &Path, plan: &ScanPlan, args: &Args) -> Result<PoseData> {
    let column_tiff = dir.join(COLUMN_TIFF_NAME);
    if column_tiff.is_file() {
        let (w, h, columns) = image_files::read_tiff_f32(&column_tiff)
            .map_err(|e| Error::Usage(format!("{}: {}", column_tiff.display(), e.0)))?;
        let white_path = WHITE_NAMES
            .iter()
            .map(|n| dir.join(n))
            .find(|p| p.is_file())
            .ok_or_else(|| {
                Error::Usage(format!(
                    "{}: has {COLUMN_TIFF_NAME} but no white.png / white.tif / white.tiff (the board under a full-on frame) to find the corners in",
                    dir.display()
                ))
            })?;
        let (ww, wh, mut white) = read_grey(&white_path)?;
        if (ww, wh) != (w, h) {
            return Err(Error::Usage(format!(
                "{}: {ww}x{wh}, but {COLUMN_TIFF_NAME} is {w}x{h}",
                white_path.display()
            )));
        }
        if let Some(dark_path) = DARK_NAMES.iter().map(|n| dir.join(n)).find(|p| p.is_file()) {
            let (dw, dh, dark) = read_grey(&dark_path)?;
            if (dw, dh) != (w, h) {
                return Err(Error::Usage(format!(
                    "{}: {dw}x{dh}, but {COLUMN_TIFF_NAME} is {w}x{h}",
                    dark_path.display()
                )));
            }
            for (v, d) in white.iter_mut().zip(dark) {
                *v -= d;
            }
        }
        return Ok(PoseData {
            width: w,
            height: h,
            white,
            columns,
        });
    }
    // A captured stack: decode it, and take its dark and white frames.
    let capture = Capture::open_stack(dir, plan, args.bit_depth)?;
    let Capture::Stack(stack) = &capture else {
        unreachable!("open_stack opens a stack");
    };
    let (w, h) = (stack.width(), stack.height());
    let (_, _, dark) = read_grey(stack.frame_path(0))?;
    let (_, _, mut white) = read_grey(stack.frame_path(1))?;
    for (v, d) in white.iter_mut().zip(dark) {
        *v -= d;
    }
    let mut columns = vec![f32::NAN; w as usize * h as usize];
    let options = DecodeOptions {
        memory_budget_bytes: super::super::mebibytes(args.memory_budget),
        threads: args.threads,
    };
    decode_capture(plan, &capture, &options, &Progress::stderr(), |row| {
        let y = row.row as usize * w as usize;
        columns[y..y + w as usize].copy_from_slice(&row.strongest);
        Ok(())
    })?;
    Ok(PoseData {
        width: w,
        height: h,
        white,
        columns,
    })
}

/// Runs `fsm calibrate target`.
pub fn run(args: Args) -> Result<()> {
    let board = Checkerboard::read(&args.board).map_err(|e| Error::Usage(e.to_string()))?;
    let plan = super::super::load_plan(&args.plan)?;
    if args.poses.len() < fsm_calibrate::zhang::MIN_POSES {
        return Err(Error::Usage(format!(
            "{} pose folders given; at least {} are needed (tilted in different directions)",
            args.poses.len(),
            fsm_calibrate::zhang::MIN_POSES
        )));
    }
    let volume = match (args.near, args.far) {
        (Some(near), Some(far)) => Some(
            MeasurementVolume::new(near, far)
                .map_err(|e| Error::Usage(format!("--near/--far: {e}")))?,
        ),
        _ => None,
    };
    let mut observations = Vec::with_capacity(args.poses.len());
    let mut whites = Vec::with_capacity(args.poses.len());
    let mut size: Option<(u32, u32)> = None;
    for dir in &args.poses {
        let pose = load_pose(dir, &plan, &args)?;
        match size {
            None => size = Some((pose.width, pose.height)),
            Some(s) if s != (pose.width, pose.height) => {
                return Err(Error::Usage(format!(
                    "{}: images are {}x{}, the first pose's are {}x{}",
                    dir.display(),
                    pose.width,
                    pose.height,
                    s.0,
                    s.1
                )))
            }
            Some(_) => {}
        }
        let (w, h) = (pose.width as usize, pose.height as usize);
        let corners = corners::detect(&pose.white, w, h, &board)
            .map_err(|e| Error::Usage(format!("{}: corners: {e}", dir.display())))?;
        let lit = pose.columns.iter().filter(|c| c.is_finite()).count();
        eprintln!(
            "{}: {} corners, {:.1}% of pixels decoded",
            dir.display(),
            corners.len(),
            100.0 * lit as f64 / (w * h).max(1) as f64
        );
        observations.push(PoseObservation {
            label: dir.display().to_string(),
            corners_px: corners,
            columns: ColumnMap {
                width: w,
                height: h,
                columns: pose.columns,
            },
        });
        whites.push(pose.white);
    }
    let (w, h) = size.expect("at least 3 poses");
    let mut settings =
        CalibrationSettings::new(w, h, plan.projector_columns as u32, args.projector_rows);
    settings.projector_cy_px = args.projector_cy;
    settings.volume = volume;
    settings.camera.fix_k3 = !args.camera_k3;
    settings.projector.refine_tangential = args.projector_tangential;
    settings.joint = !args.no_joint;
    if args.no_dense {
        settings.dense = None;
    }
    settings.local.half_window_px = args.window;
    let (calibration, report) = calibrate(&board.corners_mm(), &observations, &settings)
        .map_err(|e| Error::Usage(format!("calibration failed: {e}")))?;

    print_report(&report);
    write_file(&args.out, calibration.to_toml().as_bytes())?;
    eprintln!("wrote {}", args.out.display());
    if let Some(path) = &args.report {
        write_file(path, report.to_json().as_bytes())?;
        eprintln!("wrote {}", path.display());
    }
    if let Some(dir) = &args.residuals {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        for (i, (pose, white)) in report.poses.iter().zip(&whites).enumerate() {
            let path = dir.join(format!("pose{i:02}.png"));
            let rgb = residual_picture(pose, white, w as usize, h as usize);
            let mut bytes = Vec::new();
            image_files::write_png_rgb8(&mut bytes, w, h, &rgb)
                .map_err(|e| Error::Usage(format!("{}: {}", path.display(), e.0)))?;
            write_file(&path, &bytes)?;
        }
        eprintln!(
            "wrote {} residual pictures to {}",
            report.poses.len(),
            dir.display()
        );
    }
    Ok(())
}

fn print_report(report: &CalibrationReport) {
    println!(
        "pose                          camera RMS px   projector RMS col   corners (with column)   dense RMS col (samples)"
    );
    let dense = |rms: Option<f64>| rms.map_or("-".to_string(), |r| format!("{r:.4}"));
    for p in &report.poses {
        println!(
            "{:<30} {:>12.4} {:>19.4}   {:>9} ({:>2})           {:>7} ({})",
            p.label,
            p.camera_rms_px,
            p.projector_rms_columns,
            p.corners,
            p.corners_with_column,
            dense(p.dense_rms_columns),
            p.dense_samples
        );
    }
    println!(
        "{:<30} {:>12.4} {:>19.4}                           {:>7}",
        "all",
        report.camera_rms_px,
        report.projector_rms_columns,
        dense(report.dense_rms_columns)
    );
    let show = |name: &str, params: &[fsm_calibrate::calibrate::Parameter]| {
        let list: Vec<String> = params
            .iter()
            .map(|p| match p.std_dev {
                Some(s) => format!("{} {:.6} ± {:.2e}", p.name, p.value, s),
                None => format!("{} {:.6} (fixed)", p.name, p.value),
            })
            .collect();
        println!("{name}: {}", list.join(", "));
    };
    show("camera", &report.camera);
    show("projector", &report.projector);
    println!("baseline {:.3} mm", report.baseline_mm);
    for a in &report.assumptions {
        println!("assumed: {a}");
    }
}

/// The white frame in grey, each corner's camera residual as a red line (× 200) and its
/// projector residual as a dot coloured by sign and size (full colour at 0.1 column).
fn residual_picture(
    pose: &fsm_calibrate::calibrate::PoseReport,
    white: &[f32],
    w: usize,
    h: usize,
) -> Vec<u8> {
    let max = white.iter().copied().fold(0.0f32, f32::max).max(1.0);
    let mut rgb: Vec<u8> = white
        .iter()
        .flat_map(|&v| {
            let g = (60.0 + 120.0 * (v / max).clamp(0.0, 1.0)) as u8;
            [g, g, g]
        })
        .collect();
    let put = |x: i64, y: i64, c: [u8; 3], rgb: &mut Vec<u8>| {
        if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h {
            let i = 3 * (y as usize * w + x as usize);
            rgb[i..i + 3].copy_from_slice(&c);
        }
    };
    for ((c, r), pr) in pose
        .corners_px
        .iter()
        .zip(&pose.camera_residuals_px)
        .zip(&pose.projector_residuals_columns)
    {
        let (x0, y0) = (c[0], c[1]);
        let (x1, y1) = (x0 + 200.0 * r[0], y0 + 200.0 * r[1]);
        let steps = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
        for s in 0..=steps {
            let t = s as f64 / steps as f64;
            put(
                (x0 + t * (x1 - x0)).round() as i64,
                (y0 + t * (y1 - y0)).round() as i64,
                [230, 40, 40],
                &mut rgb,
            );
        }
        let colour = match pr {
            None => [0, 0, 0],
            Some(v) => {
                let a = (v.abs() / 0.1).clamp(0.15, 1.0);
                if *v < 0.0 {
                    [0, (120.0 * a) as u8, (255.0 * a) as u8]
                } else {
                    [(255.0 * a) as u8, (220.0 * a) as u8, 0]
                }
            }
        };
        for dy in -1..=1 {
            for dx in -1..=1 {
                put(
                    x0.round() as i64 + dx,
                    y0.round() as i64 + dy,
                    colour,
                    &mut rgb,
                );
            }
        }
    }
    rgb
}
