//! `fsm simulate`: the captures a scanner would record of a simulated scene, with the plan,
//! the calibration and the ground truth, ready for `fsm decode` and `fsm scan` — or, with
//! `--scene checkerboard`, scans of a calibration target ready for `fsm calibrate target`.

use std::path::PathBuf;

use fsm_io::plan_file::Preset;
use fsm_io::progress::Progress;
use fsm_io::Result;
use fsm_sim::folder::{scene_names, BoardPlacement, Rendering, SimulationRequest, SPREAD};

/// Simulate a scan: the camera's captures of a scene under a plan's patterns.
///
/// The bench scanner (SPEC §5; baseline 200 mm, standoff 500 mm, 768-column projector with
/// a 0.7-column defocus blur, 12-bit camera) looks at a preset scene (vgroove_glossy is rough
/// metal) or a calibration target; light reaches the camera directly and through mirrors and
/// diffuse and glossy interreflection, and the sensor adds shot and read noise.
///
/// Writes into the output folder:
///   plan.toml            the plan the patterns follow (a preset states the simulated sensor)
///   calibration.toml     the simulated scanner's calibration (the true one)
///   scan.dump            the captures as a row dump (or images/0000.png… with --images)
///   truth/depth.tiff     ground-truth depth, mm (NaN: background)
///   truth/column.tiff    ground-truth direct column (SPEC §7; NaN where not lit directly)
///   truth/interreflection.png  pixels whose indirect light exceeds 20% of the direct
///
/// --scene checkerboard renders a printed board (--board) alone before a black background at
/// --board-pose YAW,PITCH,ROLL,Z or YAW,PITCH,ROLL,X,Y,Z: facing the camera, its rows along
/// the image rows, turned by ROLL about its normal, tilted by PITCH about the camera's x axis
/// and YAW about its y axis (degrees), its corner grid's centre at (X, Y, Z) mm in the camera
/// frame (X = Y = 0 by default). The output folder is then a pose folder of `fsm calibrate
/// target`: the frames as 16-bit PNGs at its top (0000.png…; --images is implied), plan.toml,
/// calibration.toml, board.toml (the target definition) and truth/ as above plus
/// truth/corners.json (every inner corner's true camera pixel, pixel centres at integers as
/// SPEC §1, its camera-frame point and projector column, row-major). --board-poses N writes N
/// such folders pose-01 … pose-N instead, board.toml beside them.
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
    /// Scene: a preset, or checkerboard (a calibration target, described above).
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(scene_names()))]
    scene: String,
    /// Plan file, of any method (`fsm plan --method`); a calibration board takes FSM plans.
    #[arg(long, value_name = "FILE", conflicts_with = "preset")]
    plan: Option<PathBuf>,
    /// A preset plan instead of a file (one of the two is required, except for --scene
    /// checkerboard: default paper-efsm-1, 76 patterns).
    #[arg(long, value_parser = super::named(Preset::ALL))]
    preset: Option<Preset>,
    #[command(flatten)]
    output: super::OutDir,
    #[command(flatten)]
    bench: super::BenchArgs,
    /// Rays per pixel along each axis of the light transport (N x N per pixel). More rays
    /// render edges closer to a real pixel's integral: a board's corners are 0.008 px off
    /// with 4, 0.004 px with 8 (the calibration's end-to-end test), at about twice the time.
    #[arg(long, value_name = "N", default_value_t = 4, value_parser = clap::value_parser!(u32).range(1..=64))]
    supersampling: u32,
    /// Write a 16-bit PNG per frame under images/ instead of a row dump.
    #[arg(long)]
    images: bool,
    /// Checkerboard: the target definition file (default the bench's 9 x 6 inner corners of
    /// 20 mm, calibration/targets/checkerboard-9x6-20mm.toml).
    #[arg(long, value_name = "FILE")]
    board: Option<PathBuf>,
    /// Checkerboard: the board's pose, degrees and mm (described above).
    #[arg(
        long,
        value_name = "YAW,PITCH,ROLL,Z",
        value_parser = str::parse::<BoardPlacement>,
        conflicts_with = "board_poses",
        allow_hyphen_values = true
    )]
    board_pose: Option<BoardPlacement>,
    /// Checkerboard: N pose folders (1-9) at a spread of well-conditioned poses, all tilted
    /// 15-30 degrees, 540-580 mm; pose i's noise seed is --seed + i − 1.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u8).range(1..=SPREAD.len() as i64))]
    board_poses: Option<u8>,
}

pub fn run(args: Args) -> Result<()> {
    let simulation = SimulationRequest {
        scene: args.scene,
        plan: args.plan,
        preset: args.preset,
        rendering: Rendering {
            system: args.bench.system(),
            seed: args.bench.seed,
            supersampling: args.supersampling,
        },
        images: args.images,
        board: args.board,
        board_pose: args.board_pose,
        board_poses: args.board_poses,
    }
    .resolve()?;
    let staged = args.output.stage()?;
    let done = |line| eprintln!("{line}");
    let simulated = simulation.write(staged.path(), &Progress::stderr(), done)?;
    let out = staged.commit()?;
    eprintln!("{}", simulated.message(&out));
    Ok(())
}
