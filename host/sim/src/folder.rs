//! A simulation folder, as `fsm simulate` writes it: the plan, the simulated scanner's true
//! calibration, the captures (a row dump or one 16-bit PNG per frame) and the ground truth as
//! images; for a calibration target, a pose folder of `fsm calibrate target` with the true
//! corners. Every file goes through the workspace's one atomic writer (`fsm_io::outputs`); the
//! caller stages the folder and commits it whole. [`SimulationRequest`] is `fsm simulate`'s
//! options, checked into a [`Simulation`] before any work.

use std::path::{Path, PathBuf};
use std::str::FromStr;
use std::time::Instant;

use fsm_calibrate::board::Checkerboard;
use fsm_core::ScanPlan;
use fsm_io::image_files::{write_png_gray16, write_png_gray8, write_tiff_f32};
use fsm_io::outputs::write_file;
use fsm_io::plan_file::{
    read_method_plan, write_method_plan, write_plan, MethodPlan, MethodPlanText, Preset,
};
use fsm_io::progress::Progress;
use fsm_io::{Error, Result};

use crate::target::{self, BoardPose, PrintedBoard};
use crate::{Capture, PatternSequence, Scene, Sensor, System, TransportSettings};

/// The scene name of the calibration target (not a preset: it takes a board and a pose).
pub const CHECKERBOARD: &str = "checkerboard";

/// The plan of board scans when neither a plan file nor a preset is given: EFSM, one group, 76
/// patterns (what the calibration's end-to-end test uses).
pub const BOARD_PRESET: Preset = Preset::PaperEfsm1;

/// The scenes of `fsm simulate --scene`: the presets, then [`CHECKERBOARD`].
pub fn scene_names() -> impl Iterator<Item = &'static str> {
    crate::scene::presets::NAMES
        .iter()
        .copied()
        .chain([CHECKERBOARD])
}

/// What `fsm simulate` is asked for, as its options give it (its messages name the options).
/// [`SimulationRequest::resolve`] checks it and reads its files before any work.
#[derive(Clone, Debug)]
pub struct SimulationRequest {
    /// A preset scene's name, or [`CHECKERBOARD`] (`--scene`).
    pub scene: String,
    /// A plan file of any method; a board takes FSM plans (`--plan`).
    pub plan: Option<PathBuf>,
    /// A preset plan instead, stating the simulated sensor (`--preset`); a board's default is
    /// [`BOARD_PRESET`].
    pub preset: Option<Preset>,
    /// How the captures are made.
    pub rendering: Rendering,
    /// A preset scene's frames as `images/0000.png…` instead of `scan.dump` (`--images`).
    pub images: bool,
    /// The board's target definition file (`--board`; default [`PrintedBoard::bench`]).
    pub board: Option<PathBuf>,
    /// One board pose, written into the output folder itself (`--board-pose`).
    pub board_pose: Option<BoardPlacement>,
    /// That many pose folders at the poses of [`SPREAD`] (`--board-poses`).
    pub board_poses: Option<u8>,
}

/// A checked [`SimulationRequest`], ready to be written ([`Simulation::write`]).
pub struct Simulation {
    rendering: Rendering,
    subject: Subject,
}

/// What a [`Simulation`] renders.
enum Subject {
    /// A preset scene under a plan ([`write_scene`]).
    Scene {
        name: String,
        scene: Box<Scene>,
        plan: MethodPlan,
        images: bool,
    },
    /// A printed board at one or more poses ([`write_board_poses`]).
    Boards {
        board: PrintedBoard,
        plan: ScanPlan,
        poses: Vec<BoardPoseFolder>,
    },
}

impl SimulationRequest {
    /// The simulation asked for: the scene and its plan, or the board, its FSM plan and its
    /// poses; an error names the option that is missing, misplaced or wrong.
    pub fn resolve(self) -> Result<Simulation> {
        let subject = if self.scene == CHECKERBOARD {
            self.boards()?
        } else {
            self.preset_scene()?
        };
        Ok(Simulation {
            rendering: self.rendering,
            subject,
        })
    }

    fn preset_scene(&self) -> Result<Subject> {
        let board_options = [
            ("--board", self.board.is_some()),
            ("--board-pose", self.board_pose.is_some()),
            ("--board-poses", self.board_poses.is_some()),
        ];
        if let Some((option, _)) = board_options.iter().find(|(_, given)| *given) {
            return Err(Error::Usage(format!(
                "{option} is for --scene {CHECKERBOARD}, not --scene {}",
                self.scene
            )));
        }
        let plan = self.plan(None)?;
        let scene = Box::new(Scene::by_name(&self.scene)?);
        let (name, images) = (self.scene.clone(), self.images);
        Ok(Subject::Scene {
            name,
            scene,
            plan,
            images,
        })
    }

    fn boards(&self) -> Result<Subject> {
        let board = match &self.board {
            Some(path) => PrintedBoard::new(Checkerboard::read(path)?),
            None => PrintedBoard::bench(),
        };
        // The board's scans are decoded for calibration, which takes FSM plans.
        let plan = (self.plan(Some(BOARD_PRESET))?.fsm()).map_err(|source| Error::PlanFile {
            path: self.plan.clone().unwrap_or_default(),
            source,
        })?;
        let poses = match (self.board_pose, self.board_poses) {
            (Some(p), _) => BoardPoseFolder::one(p),
            (None, Some(n)) => BoardPoseFolder::spread(n as usize),
            (None, None) => {
                return Err(Error::Usage(format!(
                    "--scene {CHECKERBOARD}: give the board's pose with --board-pose \
                     YAW,PITCH,ROLL,Z, or --board-poses N for N pose folders"
                )))
            }
        };
        Ok(Subject::Boards { board, plan, poses })
    }

    /// The plan of `--plan` (as it is), or of `--preset` (or `default`) stating the simulated
    /// camera's sensor ([`preset_plan`]), else an error.
    fn plan(&self, default: Option<Preset>) -> Result<MethodPlan> {
        match (&self.plan, self.preset.or(default)) {
            (Some(path), _) => read_method_plan(path),
            (None, Some(preset)) => Ok(MethodPlan::Fsm(preset_plan(preset))),
            (None, None) => Err(Error::Usage(format!(
                "--scene {}: give the plan with --plan FILE or --preset NAME",
                self.scene
            ))),
        }
    }
}

impl Simulation {
    /// Renders the simulation into `dir` (which exists): a scene's folder ([`write_scene`]) or
    /// the board's pose folders ([`write_board_poses`]). The rows rendered are reported to
    /// `progress`, and each board pose written to `done` as the line `fsm simulate` prints:
    /// `pose-01: yaw 15 … mm, seed 1 (2.4 s)`, the seconds since the start of the write.
    pub fn write(
        &self,
        dir: &Path,
        progress: &Progress,
        mut done: impl FnMut(String),
    ) -> Result<Simulated> {
        let (rendering, t0) = (&self.rendering, Instant::now());
        Ok(match &self.subject {
            Subject::Scene {
                name,
                scene,
                plan,
                images,
            } => {
                let capture = write_scene(dir, scene, plan, rendering, *images, progress)?;
                let (w, h, frames) = (capture.width(), capture.height(), capture.frame_count());
                Simulated {
                    what: format!("{name} ({w}x{h}, {frames} frames, seed {})", rendering.seed),
                    pose_folders: false,
                }
            }
            Subject::Boards { board, plan, poses } => {
                let seconds = || t0.elapsed().as_secs_f64();
                let pose_done = |pose: &BoardPoseFolder, seed: u64| {
                    done(format!("{pose}, seed {seed} ({:.1} s)", seconds()))
                };
                write_board_poses(dir, plan, rendering, board, poses, progress, pose_done)?;
                let (w, h) = (rendering.system.width(), rendering.system.height());
                let (grid, n) = (&board.grid, poses.len());
                Simulated {
                    what: format!(
                        "{CHECKERBOARD} {}x{} board at {n} pose{} ({w}x{h}, {} frames each)",
                        grid.inner_columns,
                        grid.inner_rows,
                        if n == 1 { "" } else { "s" },
                        plan.sequence_len(),
                    ),
                    pose_folders: n > 1,
                }
            }
        })
    }
}

/// What a [`Simulation`] wrote, for the message that ends `fsm simulate`.
#[derive(Clone, Debug)]
pub struct Simulated {
    /// `plane (320x240, 770 frames, seed 1)`, `checkerboard 9x6 board at 6 poses (…)`.
    what: String,
    /// Pose folders under the output folder (`--board-poses` of 2 or more).
    pose_folders: bool,
}

impl Simulated {
    /// `simulated WHAT -> OUT`, and after pose folders the `fsm calibrate target` command that
    /// calibrates from them; `out` is where the folder was committed.
    pub fn message(&self, out: &Path) -> String {
        let d = out.display();
        let mut message = format!("simulated {} -> {d}", self.what);
        if self.pose_folders {
            message += &format!(
                "\ncalibrate with: fsm calibrate target --board {d}/board.toml --plan {d}/pose-01/plan.toml --poses {d}/pose-* --bit-depth 12 --out calibration.toml"
            );
        }
        message
    }
}

/// How the captures of a simulation folder are made (`fsm simulate --camera --seed
/// --supersampling`).
#[derive(Clone, Debug)]
pub struct Rendering {
    /// The scanner.
    pub system: System,
    /// The sensor noise's seed.
    pub seed: u64,
    /// Rays per pixel along each axis of the light transport.
    pub supersampling: u32,
}

/// A scene's folder: `plan.toml`, `calibration.toml`, `scan.dump` (or `images/0000.png…`
/// with `images`), and `truth/` ([`write_truth`]), of the capture of `scene` under `plan`'s
/// patterns ([`capture_of`]), which is returned. `dir` exists. The rows rendered are reported
/// to `progress`.
pub fn write_scene(
    dir: &Path,
    scene: &Scene,
    plan: &MethodPlan,
    rendering: &Rendering,
    images: bool,
    progress: &Progress,
) -> Result<Capture> {
    let capture = capture_of(scene, plan.patterns(), rendering, progress)?;
    let system = &rendering.system;
    write_method_plan(plan, &dir.join("plan.toml"))?;
    write_calibration(system, &dir.join("calibration.toml"))?;
    if images {
        let images = dir.join("images");
        std::fs::create_dir(&images).map_err(|e| Error::io(&images, e))?;
        write_stack(&capture, &images, progress)?;
    } else {
        capture
            .write_row_dump_file(&dir.join("scan.dump"), progress)
            .map_err(Error::from)?;
    }
    write_truth(&capture, &dir.join("truth"))?;
    Ok(capture)
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
    /// Turned by `[yaw, pitch, roll]` (degrees), the grid's centre at `centre_mm`.
    pub const fn at(angles_deg: [f64; 3], centre_mm: [f64; 3]) -> BoardPlacement {
        BoardPlacement {
            yaw_deg: angles_deg[0],
            pitch_deg: angles_deg[1],
            roll_deg: angles_deg[2],
            centre_mm,
        }
    }

    /// The pose of `board` so placed.
    pub fn pose(&self, board: &target::PrintedBoard) -> BoardPose {
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

/// The board poses the bench is calibrated from (fsm-calibrate's end-to-end test).
///
/// (yaw, pitch, roll) degrees, centre of the corner grid (camera frame, mm). The first nine
/// (those of `fsm simulate --board-poses`) are tilted by 15–30° about four axes; then two
/// boards parallel to the image, their edges along the pixel grid (one centred, one offset by
/// (¼, ½) px); then six turned by ±90° (portrait: the corners reach the top and bottom of the
/// image), four of them tilted by 25°.
///
/// What the poses are for: the principal point. The camera's tangential distortion is free, and
/// with the bench camera's narrow field (28°) a shift of the principal point is nearly the
/// same as a turn of the whole camera frame plus a change of `p1`, `p2`: only the perspective
/// of the turn, largest at the image's rim, tells them apart. With corners of 0.02 px noise
/// per axis (iid, synthetic, 8 trials), the first nine poses leave the principal point
/// σ = (0.41, 0.27) px (the plane 0.49 mm RMS off in 3D, raw); with the 17 here (0.21,
/// 0.19) px and 0.29 mm (measured; `p1 = p2 = 0` held fixed would give σ ≈ 0.1 px but a biased
/// principal point, the bench having `p1 = 5e-4`, `p2 = −3e-4`). Close boards (400 mm) would
/// help more but leave the projector's field; so would many more poses (σ falls as 1/√N).
/// With the simulator's former fixed 4 × 4 ray grid, the two fronto-parallel boards were off
/// by up to ±1/8 px along their grid-aligned edges (the plane 0.089% off); the rays are now
/// multi-jittered per pixel (`fsm_sim::transport::footprint`).
pub const CALIBRATION_POSES: [BoardPlacement; 17] = [
    BoardPlacement::at([15.0, -15.0, 0.0], [0.0, 0.0, 540.0]),
    BoardPlacement::at([30.0, 0.0, 5.0], [0.0, 0.0, 560.0]),
    BoardPlacement::at([-30.0, 0.0, -5.0], [0.0, 0.0, 560.0]),
    BoardPlacement::at([0.0, 30.0, 0.0], [0.0, 0.0, 560.0]),
    BoardPlacement::at([0.0, -30.0, 8.0], [0.0, 0.0, 560.0]),
    BoardPlacement::at([20.0, 20.0, 10.0], [0.0, 0.0, 580.0]),
    BoardPlacement::at([-20.0, -20.0, -10.0], [0.0, 0.0, 570.0]),
    BoardPlacement::at([20.0, -20.0, 0.0], [0.0, 0.0, 560.0]),
    BoardPlacement::at([-20.0, 20.0, 5.0], [0.0, 0.0, 560.0]),
    BoardPlacement::at([0.0, 0.0, 0.0], [0.0, 0.0, 540.0]),
    BoardPlacement::at([0.0, 0.0, 0.0], [0.1875, 0.375, 480.0]),
    BoardPlacement::at([-2.0, 6.0, 90.0], [66.0, -7.0, 574.0]),
    BoardPlacement::at([4.0, -11.0, 90.0], [-34.0, -5.0, 527.0]),
    BoardPlacement::at([-25.0, 0.0, 90.0], [40.0, 0.0, 560.0]),
    BoardPlacement::at([25.0, 0.0, 90.0], [-20.0, 0.0, 540.0]),
    BoardPlacement::at([0.0, 25.0, -90.0], [30.0, 0.0, 560.0]),
    BoardPlacement::at([0.0, -25.0, -90.0], [-10.0, 0.0, 540.0]),
];

/// The poses of `fsm simulate --board-poses`, in order: the first nine of
/// [`CALIBRATION_POSES`], which calibrate the bench to its thresholds (every one tilted by 15°
/// or more; the first four already turn about four different axes). The other eight add boards
/// parallel to the image and turned by 90°, which pin the principal point down better.
pub const SPREAD: &[BoardPlacement] = CALIBRATION_POSES.split_at(9).0;

/// `YAW,PITCH,ROLL,Z` or `YAW,PITCH,ROLL,X,Y,Z` (degrees, mm), the angles within ±80° and the
/// board in front of the camera.
impl FromStr for BoardPlacement {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<BoardPlacement, String> {
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
        Ok(BoardPlacement::at(angles, centre))
    }
}

/// The scene's light transport (`rendering`'s rays per pixel side, other settings default;
/// its rows reported to `progress`) and a capture of `plan` over it.
pub fn capture_of(
    scene: &Scene,
    plan: &(impl PatternSequence + ?Sized),
    rendering: &Rendering,
    progress: &Progress,
) -> Result<Capture> {
    let settings = TransportSettings {
        supersampling: rendering.supersampling,
        ..TransportSettings::default()
    };
    let (system, seed) = (&rendering.system, rendering.seed);
    crate::simulate_with(
        plan,
        scene,
        system,
        &Sensor::default(),
        seed,
        &settings,
        progress,
    )
    .map_err(Error::from)
}

fn write_calibration(system: &System, path: &Path) -> Result<()> {
    Ok(system.calibration.write(path)?)
}

/// Checks that every inner corner of `board` at `pose` lands on the camera image and on the
/// projector's, and that the camera and the projector see the board's printed face.
pub fn check_board_visible(
    system: &System,
    board: &target::PrintedBoard,
    pose: &BoardPose,
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
            i as u32 % board.grid.inner_columns,
            i as u32 / board.grid.inner_columns,
        );
        match pixel {
            Some(p) if cal.camera.contains(*p) => {}
            Some(p) => {
                return Err(format!(
                    "inner corner ({c}, {r}) falls at pixel ({:.1}, {:.1}), off the {}x{} camera image (move or turn the board, or give a smaller --board)",
                    p.x, p.y, cal.camera.width_px(), cal.camera.height_px()
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
/// stack of `fsm calibrate target`), the ground truth and the true corners; the work
/// reported to `progress`.
pub fn write_board_pose(
    dir: &Path,
    plan: &ScanPlan,
    rendering: &Rendering,
    board: &target::PrintedBoard,
    placement: &BoardPlacement,
    progress: &Progress,
) -> Result<()> {
    let system = &rendering.system;
    let pose = placement.pose(board);
    let scene = Scene::checkerboard(board, &pose);
    let capture = capture_of(&scene, plan, rendering, progress)?;
    write_plan(plan, &dir.join("plan.toml"))?;
    write_calibration(system, &dir.join("calibration.toml"))?;
    write_stack(&capture, dir, progress)?;
    let truth = dir.join("truth");
    write_truth(&capture, &truth)?;
    let json = corners_json(system, board, &pose, placement);
    let path = truth.join("corners.json");
    let text = serde_json::to_string_pretty(&json).expect("the corners serialise");
    write_file(&path, text.as_bytes())
}

/// A preset plan as a user of the simulated camera writes it: `decoding.sensor` states the
/// simulated sensor as its datasheet would (the cosine search sets its threshold from it).
pub fn preset_plan(preset: Preset) -> ScanPlan {
    let mut plan = preset.plan();
    plan.decoding.sensor = Sensor::default().datasheet();
    plan
}

/// One pose of a board scan: how messages name it, its sub-folder (`None`: the output
/// folder itself) and where the board is.
#[derive(Clone, Debug)]
pub struct BoardPoseFolder {
    /// The pose in messages (e.g. the option that gave it).
    pub label: String,
    /// Its sub-folder of the output folder, or `None` for the output folder itself.
    pub folder: Option<String>,
    /// The board's placement.
    pub placement: BoardPlacement,
}

impl BoardPoseFolder {
    /// The one pose of `fsm simulate --board-pose`: the output folder itself.
    pub fn one(placement: BoardPlacement) -> Vec<BoardPoseFolder> {
        vec![BoardPoseFolder {
            label: format!("--board-pose {placement}"),
            folder: None,
            placement,
        }]
    }

    /// The first `count` poses of [`SPREAD`] (`fsm simulate --board-poses`), in the folders
    /// `pose-01`, `pose-02`, ….
    pub fn spread(count: usize) -> Vec<BoardPoseFolder> {
        (SPREAD[..count].iter().enumerate())
            .map(|(i, placement)| BoardPoseFolder {
                label: format!("--board-poses: pose {} ({placement})", i + 1),
                folder: Some(format!("pose-{:02}", i + 1)),
                placement: *placement,
            })
            .collect()
    }
}

/// `pose-01: yaw 15 pitch -15 roll 0 deg, centre (0, 0, 540) mm` (`pose:` for the output
/// folder itself).
impl std::fmt::Display for BoardPoseFolder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let p = &self.placement;
        let [x, y, z] = p.centre_mm;
        write!(
            f,
            "{}: yaw {} pitch {} roll {} deg, centre ({x}, {y}, {z}) mm",
            self.folder.as_deref().unwrap_or("pose"),
            p.yaw_deg,
            p.pitch_deg,
            p.roll_deg
        )
    }
}

/// Writes the pose folders of `fsm calibrate target` into `dir`: `board.toml` (the target
/// definition), then every pose ([`write_board_pose`], pose `i`'s noise seed `rendering.seed +
/// i`). Every pose is checked first, the whole board seen and lit ([`check_board_visible`];
/// the error names the pose by its label), so a bad pose costs no work. `done(pose, seed)` is
/// called after each.
pub fn write_board_poses(
    dir: &Path,
    plan: &ScanPlan,
    rendering: &Rendering,
    board: &target::PrintedBoard,
    poses: &[BoardPoseFolder],
    progress: &Progress,
    mut done: impl FnMut(&BoardPoseFolder, u64),
) -> Result<()> {
    for pose in poses {
        check_board_visible(&rendering.system, board, &pose.placement.pose(board))
            .map_err(|e| Error::Usage(format!("{}: {e}", pose.label)))?;
    }
    write_file(&dir.join("board.toml"), board.grid.to_toml().as_bytes())?;
    for (i, pose) in poses.iter().enumerate() {
        let pose_dir = match &pose.folder {
            Some(name) => {
                let pose_dir = dir.join(name);
                std::fs::create_dir(&pose_dir).map_err(|e| Error::io(&pose_dir, e))?;
                pose_dir
            }
            None => dir.to_path_buf(),
        };
        let rendering = Rendering {
            seed: rendering.seed + i as u64,
            ..rendering.clone()
        };
        write_board_pose(
            &pose_dir,
            plan,
            &rendering,
            board,
            &pose.placement,
            progress,
        )?;
        done(pose, rendering.seed);
    }
    Ok(())
}

/// The board, its pose and every inner corner's truth (row-major, index = row ·
/// inner_columns + column).
pub fn corners_json(
    system: &System,
    board: &target::PrintedBoard,
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
                "column": i as u32 % board.grid.inner_columns,
                "row": i as u32 / board.grid.inner_columns,
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
            "inner_columns": board.grid.inner_columns,
            "inner_rows": board.grid.inner_rows,
            "square_mm": board.grid.square_mm,
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
/// patterns; the rows rendered, then the images written, reported to `progress`.
pub fn write_stack(capture: &Capture, dir: &Path, progress: &Progress) -> Result<()> {
    let (w, h) = (capture.width() as usize, capture.height() as usize);
    let frames = capture.frame_count();
    let mut images = vec![0u16; frames * w * h];
    progress.start(h as u64, "rendering rows");
    for y in 0..h {
        let row = capture.row(y as u32).map_err(Error::from)?;
        for i in 0..frames {
            images[(i * h + y) * w..(i * h + y + 1) * w].copy_from_slice(&row[i * w..(i + 1) * w]);
        }
        progress.advance(1);
    }
    progress.finish();
    progress.start(frames as u64, "writing images");
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
        progress.advance(1);
    }
    progress.finish();
    Ok(())
}

/// The ground truth as images (what `fsm scan --truth` reads: `fsm_scan::pipeline::Truth`).
pub fn write_truth(capture: &Capture, dir: &Path) -> Result<()> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn requests_are_checked_before_any_work() {
        let request = |scene: &str| SimulationRequest {
            scene: scene.into(),
            plan: None,
            preset: None,
            rendering: Rendering {
                system: System::bench_with_camera(32, 24),
                seed: 1,
                supersampling: 1,
            },
            images: false,
            board: None,
            board_pose: None,
            board_poses: None,
        };
        let refusal = |r: SimulationRequest| r.resolve().err().expect("refused").to_string();
        let no_plan = refusal(request("plane"));
        assert!(
            no_plan.contains("--scene plane: give the plan with --plan"),
            "{no_plan}"
        );
        let misplaced = refusal(SimulationRequest {
            board_poses: Some(3),
            preset: Some(Preset::PaperBfsm),
            ..request("plane")
        });
        assert!(misplaced.contains("--board-poses is for --scene checkerboard, not --scene plane"));
        let no_pose = refusal(request(CHECKERBOARD));
        assert!(
            no_pose.contains("--board-pose YAW,PITCH,ROLL,Z"),
            "{no_pose}"
        );
        assert!(SimulationRequest {
            board_poses: Some(2),
            ..request(CHECKERBOARD)
        }
        .resolve()
        .is_ok());
        let written = Simulated {
            what: "checkerboard 9x6 board at 2 poses".into(),
            pose_folders: true,
        };
        let message = written.message(Path::new("boards"));
        assert!(message.starts_with("simulated checkerboard 9x6 board at 2 poses -> boards\n"));
        assert!(
            message.contains("--poses boards/pose-* --bit-depth 12"),
            "{message}"
        );
    }

    #[test]
    fn board_pose_folders_are_named_and_labelled() {
        let poses = BoardPoseFolder::spread(3);
        let folders: Vec<_> = poses.iter().map(|p| p.folder.as_deref().unwrap()).collect();
        assert_eq!(folders, ["pose-01", "pose-02", "pose-03"]);
        assert_eq!(poses[1].placement, SPREAD[1]);
        assert_eq!(poses[0].label, "--board-poses: pose 1 (15,-15,0,0,0,540)");
        assert_eq!(
            poses[0].to_string(),
            "pose-01: yaw 15 pitch -15 roll 0 deg, centre (0, 0, 540) mm"
        );
        let one = BoardPoseFolder::one("25,-15,10,520".parse().unwrap());
        assert_eq!((one.len(), one[0].folder.as_deref()), (1, None));
        assert_eq!(one[0].label, "--board-pose 25,-15,10,0,0,520");
        assert_eq!(
            one[0].to_string(),
            "pose: yaw 25 pitch -15 roll 10 deg, centre (0, 0, 520) mm"
        );
    }
}
