//! `fsm simulate`: the captures a scanner would record of a simulated scene, with the plan,
//! the calibration and the ground truth, ready for `fsm decode` and `fsm scan` — or, with
//! `--scene checkerboard`, scans of a calibration target ready for `fsm calibrate target`.

use std::path::{Path, PathBuf};

use fsm_calibrate::board::Checkerboard;
use fsm_core::ScanPlan;
use fsm_host::image_files::{write_png_gray16, write_png_gray8, write_tiff_f32};
use fsm_host::outputs::{write_file, StagedDir};
use fsm_host::plan_file::{write_plan, Preset};
use fsm_host::{Error, Result};
use fsm_sim::scene::presets::NAMES;
use fsm_sim::target::{self, BoardPose};
use fsm_sim::{Capture, Scene, Sensor, System, TransportSettings};

/// The scene name of the calibration target (not a preset: it takes a board and a pose).
pub const CHECKERBOARD: &str = "checkerboard";

/// The plan of board scans when neither --plan nor --preset is given: EFSM, one group, 76
/// patterns (what the calibration's end-to-end test uses).
const BOARD_PRESET: &str = "paper-efsm-1";

/// Simulate a scan: the camera's captures of a scene under a plan's patterns.
///
/// The bench scanner (SPEC §5; baseline 200 mm, standoff 500 mm, 768-column projector with
/// a 0.7-column defocus blur, 12-bit camera) looks at a preset scene; light reaches the
/// camera directly and through mirrors and diffuse and glossy interreflection, and the sensor
/// adds shot and read noise. Scenes: plane, plane_mirror, plane_mirror_covered, vgroove,
/// sphere_mirror, vgroove_glossy (rough metal), and checkerboard (a calibration target, below).
///
/// Writes into the output folder:
///   plan.toml            the plan the patterns follow (a preset states the simulated sensor)
///   calibration.toml     the simulated scanner's calibration (the true one)
///   scan.dump            the captures as a row dump (or images/0000.png… with --images)
///   truth/depth.tiff     ground-truth depth, mm (NaN: background)
///   truth/column.tiff    ground-truth direct column (SPEC §7; NaN where not lit directly)
///   truth/interreflection.png  pixels whose indirect light exceeds 20% of the direct
///
/// Checkerboard: --scene checkerboard renders a printed board (--board FILE, a target
/// definition; default the bench's 9 x 6 inner corners of 20 mm,
/// calibration/targets/checkerboard-9x6-20mm.toml) alone before a black background, at
/// --board-pose YAW,PITCH,ROLL,Z (or YAW,PITCH,ROLL,X,Y,Z): the board faces the camera with
/// its rows along the image rows, turned by ROLL about its normal, tilted by PITCH about the
/// camera's x axis and YAW about its y axis (degrees), the centre of its corner grid at
/// (X, Y, Z) mm in the camera frame (X = Y = 0 by default). The plan defaults to
/// paper-efsm-1 (76 patterns). The output folder is then a pose folder of
/// `fsm calibrate target`: the frames are 16-bit PNGs at its top (0000.png…, --images is
/// implied), beside plan.toml, calibration.toml, board.toml (the target definition) and
/// truth/ (as above, plus truth/corners.json: every inner corner's true camera pixel, pixel
/// centres at integers as SPEC §1, its camera-frame point and projector column, row-major).
/// --board-poses N (1-9) instead writes N pose folders pose-01 … pose-N under the output
/// folder, each as above, at a spread of well-conditioned poses (all tilted 15-30 degrees,
/// 540-580 mm; pose i's noise seed is --seed + i − 1), and board.toml beside them.
///
/// Examples:
///   fsm simulate --scene plane_mirror --preset paper-bfsm --out sim/
///   fsm scan --plan sim/plan.toml --calibration sim/calibration.toml --dump sim/scan.dump --out scan/
///
///   fsm simulate --scene checkerboard --board-poses 6 --out boards/
///   fsm calibrate target --board boards/board.toml --plan boards/pose-01/plan.toml \
///       --poses boards/pose-* --bit-depth 12 --out cal.toml --report report.json
///   fsm simulate --scene checkerboard --board-pose 25,-15,10,520 --out pose/
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Scene: a preset, or checkerboard (described above).
    #[arg(
        long,
        value_parser = clap::builder::PossibleValuesParser::new(NAMES.iter().copied().chain([CHECKERBOARD]))
    )]
    scene: String,
    /// Scan-plan file.
    #[arg(long, value_name = "FILE", conflicts_with = "preset")]
    plan: Option<PathBuf>,
    /// A preset plan instead of a file: paper-bfsm, paper-efsm-1 or paper-efsm-2 (one of
    /// the two is required, except for --scene checkerboard: default paper-efsm-1).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(Preset::ALL.map(|(_, n)| n)))]
    preset: Option<String>,
    /// Output folder (created; must not exist or be empty, unless --force).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Camera size WxH (same field of view; the footprint shrinks as it grows).
    #[arg(long, value_name = "WxH", default_value = "320x240", value_parser = parse_size)]
    camera: (u32, u32),
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Rays per pixel along each axis of the light transport (N x N per pixel). More rays
    /// render edges closer to a real pixel's integral: a board's corners are 0.008 px off
    /// with 4, 0.004 px with 8 (the calibration's end-to-end test), at about twice the time.
    #[arg(long, value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    supersampling: u32,
    /// Write a 16-bit PNG per frame under images/ instead of a row dump.
    #[arg(long)]
    images: bool,
    /// Replace the output folder if it exists and is not empty.
    #[arg(long)]
    force: bool,
    /// Checkerboard: the target definition file (default the bench's 9 x 6, 20 mm).
    #[arg(long, value_name = "FILE")]
    board: Option<PathBuf>,
    /// Checkerboard: the board's pose, degrees and mm (described above).
    #[arg(
        long,
        value_name = "YAW,PITCH,ROLL,Z",
        value_parser = parse_board_pose,
        conflicts_with = "board_poses",
        allow_hyphen_values = true
    )]
    board_pose: Option<BoardPlacement>,
    /// Checkerboard: N pose folders pose-01 … pose-N at a spread of tilted poses (1-9).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=SPREAD.len() as i64))]
    board_poses: Option<u8>,
}

/// Where the board is: `R = R_y(yaw)·R_x(pitch)·R_z(roll)`, the centre of its corner grid at
/// `centre_mm` (camera frame), as `fsm_sim::target::BoardPose::tilted`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardPlacement {
    /// About the camera's `y` axis, degrees.
    pub yaw_deg: f64,
    /// About the camera's `x` axis, degrees.
    pub pitch_deg: f64,
    /// About the board's normal, degrees.
    pub roll_deg: f64,
    /// Centre of the corner grid, camera frame, mm.
    pub centre_mm: [f64; 3],
}

impl BoardPlacement {
    const fn new(yaw_deg: f64, pitch_deg: f64, roll_deg: f64, z_mm: f64) -> BoardPlacement {
        BoardPlacement {
            yaw_deg,
            pitch_deg,
            roll_deg,
            centre_mm: [0.0, 0.0, z_mm],
        }
    }

    fn pose(&self, board: &target::Checkerboard) -> BoardPose {
        BoardPose::tilted(
            board,
            self.centre_mm,
            self.yaw_deg,
            self.pitch_deg,
            self.roll_deg,
        )
    }
}

impl std::fmt::Display for BoardPlacement {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [x, y, z] = self.centre_mm;
        write!(
            f,
            "{},{},{},{x},{y},{z}",
            self.yaw_deg, self.pitch_deg, self.roll_deg
        )
    }
}

/// The poses of `--board-poses`, in order: the first nine of host/calibrate/tests/end_to_end.rs,
/// which calibrate the bench to its thresholds (every one tilted by 15° or more). The first four
/// already turn about four different axes. (The end-to-end test adds boards parallel to the
/// image and turned by 90°, which pin the principal point down better.)
const SPREAD: [BoardPlacement; 9] = [
    BoardPlacement::new(15.0, -15.0, 0.0, 540.0),
    BoardPlacement::new(30.0, 0.0, 5.0, 560.0),
    BoardPlacement::new(-30.0, 0.0, -5.0, 560.0),
    BoardPlacement::new(0.0, 30.0, 0.0, 560.0),
    BoardPlacement::new(0.0, -30.0, 8.0, 560.0),
    BoardPlacement::new(20.0, 20.0, 10.0, 580.0),
    BoardPlacement::new(-20.0, -20.0, -10.0, 570.0),
    BoardPlacement::new(20.0, -20.0, 0.0, 560.0),
    BoardPlacement::new(-20.0, 20.0, 5.0, 560.0),
];

/// `YAW,PITCH,ROLL,Z` or `YAW,PITCH,ROLL,X,Y,Z` (degrees, mm).
pub fn parse_board_pose(s: &str) -> std::result::Result<BoardPlacement, String> {
    let values = s
        .split(',')
        .map(|v| {
            v.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("`{s}`: `{}` is not a number", v.trim()))
        })
        .collect::<std::result::Result<Vec<f64>, String>>()?;
    let (angles, centre) = match values.as_slice() {
        [a, b, c, z] => ([*a, *b, *c], [0.0, 0.0, *z]),
        [a, b, c, x, y, z] => ([*a, *b, *c], [*x, *y, *z]),
        _ => {
            return Err(format!(
                "`{s}`: expected YAW,PITCH,ROLL,Z or YAW,PITCH,ROLL,X,Y,Z (degrees, mm), e.g. 25,-15,10,520"
            ))
        }
    };
    for (name, v) in [("YAW", angles[0]), ("PITCH", angles[1])] {
        if v.abs() >= 80.0 {
            return Err(format!(
                "`{s}`: {name} {v}: the camera would see the board edge-on (use -80 < {name} < 80)"
            ));
        }
    }
    if centre[2] <= 0.0 {
        return Err(format!(
            "`{s}`: Z {}: the board must be in front of the camera (Z > 0 mm)",
            centre[2]
        ));
    }
    Ok(BoardPlacement {
        yaw_deg: angles[0],
        pitch_deg: angles[1],
        roll_deg: angles[2],
        centre_mm: centre,
    })
}

/// `WxH`.
pub fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| format!("`{s}`: expected WxH, e.g. 320x240"))?;
    let parse = |v: &str| {
        v.parse::<u32>()
            .ok()
            .filter(|&v| v >= 8)
            .ok_or_else(|| format!("`{s}`: `{v}` is not a size of 8 or more"))
    };
    Ok((parse(w)?, parse(h)?))
}

fn sim_error(e: impl std::fmt::Display) -> Error {
    Error::Usage(format!("simulation: {e}"))
}

pub fn run(args: Args) -> Result<()> {
    if args.scene == CHECKERBOARD {
        return run_board(args);
    }
    for (option, given) in [
        ("--board", args.board.is_some()),
        ("--board-pose", args.board_pose.is_some()),
        ("--board-poses", args.board_poses.is_some()),
    ] {
        if given {
            return Err(Error::Usage(format!(
                "{option} is for --scene {CHECKERBOARD}, not --scene {}",
                args.scene
            )));
        }
    }
    let plan = plan_of(&args, None)?;
    let scene = Scene::by_name(&args.scene).map_err(sim_error)?;
    let system = System::bench_with_camera(args.camera.0, args.camera.1);
    let staged = StagedDir::create(&args.out, args.force)?;
    let capture = capture_of(&scene, &plan, &system, args.seed, args.supersampling)?;
    write_plan(&plan, &staged.file("plan.toml"))?;
    write_calibration(&system, &staged.file("calibration.toml"))?;
    if args.images {
        let dir = staged.file("images");
        std::fs::create_dir(&dir).map_err(|e| Error::io(&dir, e))?;
        write_stack(&capture, &plan, &dir)?;
    } else {
        let path = staged.file("scan.dump");
        capture.write_row_dump_file(&path).map_err(sim_error)?;
    }
    write_truth(&capture, &staged.file("truth"))?;
    let out = staged.commit()?;
    eprintln!(
        "simulated {} ({}x{}, {} frames, seed {}) -> {}",
        args.scene,
        capture.width(),
        capture.height(),
        capture.frame_count(),
        args.seed,
        out.display()
    );
    Ok(())
}

/// The plan of `--plan` (as it is), or of `--preset` (or `default`, a preset name) stating
/// the simulated camera's sensor as its datasheet would (`decoding.sensor`: the cosine search
/// sets its threshold from it), else an error.
fn plan_of(args: &Args, default: Option<&str>) -> Result<ScanPlan> {
    Ok(match (&args.plan, args.preset.as_deref().or(default)) {
        (Some(path), _) => super::load_plan(path)?,
        (None, Some(name)) => {
            let mut plan = Preset::from_name(name)
                .expect("clap checked the name")
                .plan();
            plan.decoding.sensor = Sensor::default().datasheet();
            plan
        }
        (None, None) => {
            return Err(Error::Usage(format!(
                "--scene {}: give the plan with --plan FILE or --preset NAME",
                args.scene
            )))
        }
    })
}

/// The scene's light transport (`supersampling` rays per pixel side, other settings default)
/// and a capture of `plan` over it.
fn capture_of(
    scene: &Scene,
    plan: &ScanPlan,
    system: &System,
    seed: u64,
    supersampling: u32,
) -> Result<Capture> {
    let settings = TransportSettings {
        supersampling,
        ..TransportSettings::default()
    };
    fsm_sim::simulate_with(plan, scene, system, &Sensor::default(), seed, &settings)
        .map_err(sim_error)
}

fn write_calibration(system: &System, path: &Path) -> Result<()> {
    system
        .calibration
        .write(path)
        .map_err(|e| Error::Usage(e.to_string()))
}

/// `--scene checkerboard`: one pose folder (`--board-pose`) or `--board-poses` of them.
fn run_board(args: Args) -> Result<()> {
    let board = match &args.board {
        Some(path) => Checkerboard::read(path).map_err(|e| Error::Usage(e.to_string()))?,
        None => {
            let b = target::Checkerboard::bench();
            Checkerboard {
                inner_columns: b.inner_columns,
                inner_rows: b.inner_rows,
                square_mm: b.square_mm,
            }
        }
    };
    let sim_board =
        target::Checkerboard::new(board.inner_columns, board.inner_rows, board.square_mm);
    let plan = plan_of(&args, Some(BOARD_PRESET))?;
    let system = System::bench_with_camera(args.camera.0, args.camera.1);
    // (label for messages, sub-folder or None for the output folder itself, placement)
    type Poses = Vec<(String, Option<String>, BoardPlacement)>;
    let poses: Poses = match (args.board_pose, args.board_poses) {
        (Some(p), _) => vec![(format!("--board-pose {p}"), None, p)],
        (None, Some(n)) => SPREAD[..n as usize]
            .iter()
            .enumerate()
            .map(|(i, p)| {
                (
                    format!("--board-poses: pose {} ({p})", i + 1),
                    Some(format!("pose-{:02}", i + 1)),
                    *p,
                )
            })
            .collect(),
        (None, None) => {
            return Err(Error::Usage(format!(
                "--scene {CHECKERBOARD}: give the board's pose with --board-pose \
                 YAW,PITCH,ROLL,Z, or --board-poses N for N pose folders"
            )))
        }
    };
    // Every pose is checked before any work: the whole board seen and lit.
    for (label, _, placement) in &poses {
        check_board_visible(&system, &sim_board, &placement.pose(&sim_board), &args)
            .map_err(|e| Error::Usage(format!("{label}: {e}")))?;
    }
    let staged = StagedDir::create(&args.out, args.force)?;
    write_file(&staged.file("board.toml"), board.to_toml().as_bytes())?;
    let t0 = std::time::Instant::now();
    for (i, (_, folder, placement)) in poses.iter().enumerate() {
        let dir = match folder {
            Some(name) => {
                let dir = staged.file(name);
                std::fs::create_dir(&dir).map_err(|e| Error::io(&dir, e))?;
                dir
            }
            None => staged.path().to_path_buf(),
        };
        let seed = args.seed + i as u64;
        write_board_pose(
            &dir,
            &plan,
            &system,
            &sim_board,
            placement,
            seed,
            args.supersampling,
        )?;
        let name = folder.as_deref().unwrap_or("pose");
        eprintln!(
            "{name}: yaw {} pitch {} roll {} deg, centre ({}, {}, {}) mm, seed {seed} ({:.1} s)",
            placement.yaw_deg,
            placement.pitch_deg,
            placement.roll_deg,
            placement.centre_mm[0],
            placement.centre_mm[1],
            placement.centre_mm[2],
            t0.elapsed().as_secs_f64()
        );
    }
    let out = staged.commit()?;
    let (w, h) = args.camera;
    eprintln!(
        "simulated {} {}x{} board at {} pose{} ({w}x{h}, {} frames each) -> {}",
        CHECKERBOARD,
        board.inner_columns,
        board.inner_rows,
        poses.len(),
        if poses.len() == 1 { "" } else { "s" },
        plan.sequence_len(),
        out.display()
    );
    if poses.len() > 1 {
        let d = out.display();
        eprintln!(
            "calibrate with: fsm calibrate target --board {d}/board.toml --plan {d}/pose-01/plan.toml --poses {d}/pose-* --bit-depth 12 --out calibration.toml"
        );
    }
    Ok(())
}

/// Checks that every inner corner of `board` at `pose` lands on the camera image and on the
/// projector's, and that the camera and the projector see the board's printed face.
fn check_board_visible(
    system: &System,
    board: &target::Checkerboard,
    pose: &BoardPose,
    args: &Args,
) -> std::result::Result<(), String> {
    let cal = &system.calibration;
    let corners = target::corners_camera_mm(board, pose);
    let normal = pose.rotation.matrix().column(2).into_owned();
    let origin = corners[0];
    // The printed face looks along −z of the board frame: towards the camera when the board's
    // +z points away from it.
    if normal.dot(&origin.coords) <= 0.0 {
        return Err("the camera sees the back of the board".into());
    }
    if normal.dot(&(origin - cal.projector_centre_mm())) <= 0.0 {
        return Err("the projector lights the back of the board".into());
    }
    let pixels = target::true_corner_pixels(system, board, pose);
    for (i, (point, pixel)) in corners.iter().zip(&pixels).enumerate() {
        let (c, r) = (
            i as u32 % board.inner_columns,
            i as u32 / board.inner_columns,
        );
        match pixel {
            Some(p) if cal.camera.contains(*p) => {}
            Some(p) => {
                return Err(format!(
                    "inner corner ({c}, {r}) falls at pixel ({:.1}, {:.1}), off the {}x{} camera image (move or turn the board, or give a smaller --board)",
                    p.x, p.y, args.camera.0, args.camera.1
                ))
            }
            None => {
                return Err(format!(
                    "inner corner ({c}, {r}) is outside the camera's field of view"
                ))
            }
        }
        match cal.projector_point_of(point) {
            Some(q) if cal.projector.contains(q) => {}
            _ => {
                return Err(format!(
                    "inner corner ({c}, {r}) is outside the projector's image (not lit)"
                ))
            }
        }
    }
    Ok(())
}

/// One board pose folder: the plan, the true calibration, the frames at the top (a captured
/// stack of `fsm calibrate target`), the ground truth and the true corners.
fn write_board_pose(
    dir: &Path,
    plan: &ScanPlan,
    system: &System,
    board: &target::Checkerboard,
    placement: &BoardPlacement,
    seed: u64,
    supersampling: u32,
) -> Result<()> {
    let pose = placement.pose(board);
    let scene = Scene::checkerboard(board, &pose);
    let capture = capture_of(&scene, plan, system, seed, supersampling)?;
    write_plan(plan, &dir.join("plan.toml"))?;
    write_calibration(system, &dir.join("calibration.toml"))?;
    write_stack(&capture, plan, dir)?;
    let truth = dir.join("truth");
    write_truth(&capture, &truth)?;
    let json = corners_json(system, board, &pose, placement);
    let path = truth.join("corners.json");
    let text = serde_json::to_string_pretty(&json).expect("the corners serialise");
    write_file(&path, text.as_bytes())
}

/// The board, its pose and every inner corner's truth (row-major, index = row ·
/// inner_columns + column).
fn corners_json(
    system: &System,
    board: &target::Checkerboard,
    pose: &BoardPose,
    placement: &BoardPlacement,
) -> serde_json::Value {
    let cal = &system.calibration;
    let board_mm = board.corners_board_mm();
    let camera_mm = target::corners_camera_mm(board, pose);
    let pixels = target::true_corner_pixels(system, board, pose);
    let corners: Vec<serde_json::Value> = board_mm
        .iter()
        .zip(&camera_mm)
        .zip(&pixels)
        .enumerate()
        .map(|(i, ((b, p), px))| {
            serde_json::json!({
                "column": i as u32 % board.inner_columns,
                "row": i as u32 / board.inner_columns,
                "board_mm": [b.x, b.y],
                "camera_mm": [p.x, p.y, p.z],
                "pixel": px.map(|q| [q.x, q.y]),
                "projector_column": cal.projector_column_of(p),
            })
        })
        .collect();
    let m = pose.rotation.matrix();
    let t = pose.translation_mm;
    serde_json::json!({
        "format": "fsm-simulated-corners",
        "version": 1,
        "note": "true inner corners of the simulated board: pixel = camera pixel (pixel centres at integers, SPEC 1), camera_mm = camera frame, projector_column as SPEC 7; row-major",
        "board": {
            "inner_columns": board.inner_columns,
            "inner_rows": board.inner_rows,
            "square_mm": board.square_mm,
            "margin_mm": board.margin_mm,
            "dark_albedo": board.dark_albedo,
            "light_albedo": board.light_albedo,
        },
        "pose": {
            "yaw_deg": placement.yaw_deg,
            "pitch_deg": placement.pitch_deg,
            "roll_deg": placement.roll_deg,
            "centre_mm": placement.centre_mm,
            "rotation": [
                [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
                [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
                [m[(2, 0)], m[(2, 1)], m[(2, 2)]],
            ],
            "translation_mm": [t.x, t.y, t.z],
        },
        "camera": {
            "width": cal.camera.width_px(),
            "height": cal.camera.height_px(),
        },
        "corners": corners,
    })
}

/// One 16-bit PNG per frame in `dir` (which exists), numbered in sequence order like the
/// patterns.
fn write_stack(capture: &Capture, plan: &ScanPlan, dir: &Path) -> Result<()> {
    let (w, h) = (capture.width() as usize, capture.height() as usize);
    let frames = plan.sequence_len();
    let mut images = vec![0u16; frames * w * h];
    for y in 0..h {
        let row = capture.row(y as u32).map_err(sim_error)?;
        for i in 0..frames {
            images[(i * h + y) * w..(i * h + y + 1) * w].copy_from_slice(&row[i * w..(i + 1) * w]);
        }
    }
    for i in 0..frames {
        let path = dir.join(format!("{i:04}.png"));
        let mut bytes = Vec::new();
        write_png_gray16(
            &mut bytes,
            w as u32,
            h as u32,
            &images[i * w * h..(i + 1) * w * h],
        )
        .map_err(|e| Error::Encode {
            path: path.clone(),
            message: e.0,
        })?;
        write_file(&path, &bytes)?;
    }
    Ok(())
}

/// The ground truth as images.
fn write_truth(capture: &Capture, dir: &Path) -> Result<()> {
    std::fs::create_dir(dir).map_err(|e| Error::io(dir, e))?;
    let truth = capture.ground_truth();
    let (w, h) = (capture.width(), capture.height());
    let mut depth = vec![f32::NAN; (w * h) as usize];
    let mut column = vec![f32::NAN; (w * h) as usize];
    let mut interreflection = vec![0u8; (w * h) as usize];
    for (x, y, p) in truth.iter() {
        let i = (y * w + x) as usize;
        depth[i] = p.point_mm[2] as f32;
        column[i] = p.direct_column as f32;
        interreflection[i] = if p.is_interreflection() { 255 } else { 0 };
    }
    for (name, values) in [("depth.tiff", &depth), ("column.tiff", &column)] {
        let path = dir.join(name);
        let mut bytes = Vec::new();
        write_tiff_f32(&mut std::io::Cursor::new(&mut bytes), w, h, values).map_err(|e| {
            Error::Encode {
                path: path.clone(),
                message: e.0,
            }
        })?;
        write_file(&path, &bytes)?;
    }
    let path = dir.join("interreflection.png");
    let mut bytes = Vec::new();
    write_png_gray8(&mut bytes, w, h, &interreflection).map_err(|e| Error::Encode {
        path: path.clone(),
        message: e.0,
    })?;
    write_file(&path, &bytes)
}
