//! Corner detection against the simulator's truth, the target definition file.
//!
//! The simulator renders the bench's 9 × 6 board (20 mm squares) at a pose; the true pixel of
//! each corner is its projection through the bench camera model. Default run:
//! `cargo test -p fsm-calibrate --test suite corners:: -- --nocapture` (prints the measured errors).
//! Many more poses and a 640 × 480 camera:
//! `cargo test -p fsm-calibrate --test suite corners:: -- --ignored --nocapture`.

use std::path::PathBuf;

use fsm_calibrate::board::{BoardErrorKind, Checkerboard};
use fsm_calibrate::corners::{detect, CornerError};
use fsm_sim::target::{self, BoardPose};
use fsm_sim::{Scene, Sensor, System};
use nalgebra::Point2;
use proptest::prelude::*;

/// The bench target as fsm-calibrate describes it.
fn board_of(sim: &target::PrintedBoard) -> Checkerboard {
    sim.grid
}

/// Rays per pixel side for the accuracy tests: 8 × 8 footprint samples (the default transport
/// has 4 × 4; both are multi-jittered per pixel, 8 × 8 with a quarter of the coverage noise on
/// edges; the default's corners: `fronto_parallel_corners_at_the_default_rays`).
const SUPERSAMPLING: u32 = 8;

/// A pose: (name, centre of the corner grid mm, yaw°, pitch°, roll°).
type PoseSpec = (&'static str, [f64; 3], f64, f64, f64);

/// Default-run poses: facing, tilted up to 40°, 470–650 mm, turned upside down and sideways.
const POSES: [PoseSpec; 5] = [
    (
        "facing, rolled 8 deg, 520 mm",
        [0.0, 0.0, 520.0],
        0.0,
        0.0,
        8.0,
    ),
    ("yaw 40 deg, 560 mm", [0.0, 0.0, 560.0], 40.0, 0.0, 3.0),
    (
        "pitch -30, yaw 20, 600 mm",
        [10.0, 5.0, 600.0],
        20.0,
        -30.0,
        -6.0,
    ),
    (
        "upside down (roll 177), pitch 25, 480 mm",
        [0.0, 0.0, 480.0],
        -10.0,
        25.0,
        177.0,
    ),
    (
        "portrait (roll 90), yaw -35, 650 mm",
        [0.0, 0.0, 650.0],
        -35.0,
        10.0,
        90.0,
    ),
];

struct Measured {
    rms: f64,
    max: f64,
}

/// Renders the board at `spec` with `supersampling` rays per pixel side (noise-free signal with
/// `sensor = None`) and detects its corners: the true projections and the detected corners.
fn render_and_detect(
    system: &System,
    spec: &PoseSpec,
    sensor: Option<&Sensor>,
    seed: u64,
    supersampling: u32,
) -> (Vec<Point2<f64>>, Vec<Point2<f64>>) {
    let sim_board = target::PrintedBoard::bench();
    let (name, centre, yaw, pitch, roll) = *spec;
    let pose = BoardPose::tilted(&sim_board, centre, yaw, pitch, roll);
    let truth: Vec<Point2<f64>> = target::true_corner_pixels(system, &sim_board, &pose)
        .into_iter()
        .map(|p| p.expect("every corner projects"))
        .collect();
    let scene = Scene::checkerboard(&sim_board, &pose);
    let image = target::white_frame(&scene, system, sensor, seed, supersampling).unwrap();
    let found = detect(
        &image,
        system.width() as usize,
        system.height() as usize,
        &board_of(&sim_board),
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(found.len(), truth.len());
    (truth, found)
}

/// Renders the board at `pose` (noise-free signal with `sensor = None`), detects its corners and
/// compares them with the true projections.
fn measure(system: &System, spec: &PoseSpec, sensor: Option<&Sensor>, seed: u64) -> Measured {
    let name = spec.0;
    let (truth, found) = render_and_detect(system, spec, sensor, seed, SUPERSAMPLING);
    let cam = &system.calibration.camera;
    for p in &truth {
        assert!(
            p.x > 8.0
                && p.y > 8.0
                && p.x < cam.width_px() as f64 - 9.0
                && p.y < cam.height_px() as f64 - 9.0,
            "{name}: test pose puts corner {p:?} off the image"
        );
    }
    let errors: Vec<f64> = found
        .iter()
        .zip(&truth)
        .map(|(a, b)| (a - b).norm())
        .collect();
    let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
    let max = errors.iter().copied().fold(0.0, f64::max);
    let bias = found
        .iter()
        .zip(&truth)
        .fold(nalgebra::Vector2::zeros(), |s, (a, b)| s + (a - b))
        / found.len() as f64;
    eprintln!(
        "{name:45} {}: RMS {rms:.4} px, max {max:.4} px, mean error ({:+.4}, {:+.4}) px",
        if sensor.is_some() { "noisy" } else { "clean" },
        bias.x,
        bias.y
    );
    Measured { rms, max }
}

/// Measured: RMS 0.0029–0.0039 px per pose, worst corner 0.012 px, 0.0034 px over all.
#[test]
fn corners_match_the_true_projection_without_noise() {
    let system = System::bench();
    let mut all = 0.0;
    for spec in &POSES {
        let m = measure(&system, spec, None, 0);
        // A wrong order (a turned board) would be off by whole squares.
        assert!(m.max < 0.03, "{}: max error {} px", spec.0, m.max);
        assert!(m.rms <= 0.01, "{}: RMS {} px", spec.0, m.rms);
        all += m.rms * m.rms;
    }
    let rms = (all / POSES.len() as f64).sqrt();
    eprintln!("all poses, clean: RMS {rms:.4} px");
    assert!(rms <= 0.006);
}

/// Measured: RMS 0.0035–0.0053 px per pose, worst corner 0.012 px, 0.0046 px over all.
#[test]
fn corners_match_the_true_projection_with_default_sensor_noise() {
    let system = System::bench();
    let sensor = Sensor::default();
    let mut all = 0.0;
    for (k, spec) in POSES.iter().enumerate() {
        let m = measure(&system, spec, Some(&sensor), 100 + k as u64);
        assert!(m.max < 0.05, "{}: max error {} px", spec.0, m.max);
        assert!(m.rms <= 0.01, "{}: RMS {} px", spec.0, m.rms);
        all += m.rms * m.rms;
    }
    let rms = (all / POSES.len() as f64).sqrt();
    eprintln!("all poses, noisy: RMS {rms:.4} px");
    assert!(rms <= 0.008);
}

/// Many poses (yaw and pitch up to ±40°, 450–700 mm, any roll), both noise levels, the bench
/// camera and a 640 × 480 one. Measured: worst pose RMS 0.0058 px clean, 0.0069 px noisy, worst
/// corner 0.016 px (320 × 240); 0.0041, 0.0052 and 0.013 px (640 × 480). Corners whose
/// windows the image's border cuts are among them.
/// `cargo test -p fsm-calibrate --test suite corners:: -- --ignored --nocapture`
#[test]
#[ignore]
fn corners_over_many_poses_and_two_cameras() {
    for system in [System::bench(), System::bench_with_camera(640, 480)] {
        let mut worst_rms = [0.0f64; 2];
        let mut worst_max = [0.0f64; 2];
        let mut k = 0u64;
        for &z in &[470.0, 560.0, 650.0] {
            for &(yaw, pitch) in &[
                (0.0, 0.0),
                (40.0, 0.0),
                (-40.0, 0.0),
                (0.0, 35.0),
                (0.0, -35.0),
                (28.0, 28.0),
                (-28.0, -28.0),
            ] {
                k += 1;
                let roll = (k as f64 * 47.0) % 360.0;
                let spec: PoseSpec = ("", [0.0, 0.0, z], yaw, pitch, roll);
                // Skip poses that put corners off the image (rolled boards near the edge).
                let sim_board = target::PrintedBoard::bench();
                let pose = BoardPose::tilted(&sim_board, spec.1, yaw, pitch, roll);
                let cam = &system.calibration.camera;
                let inside = target::true_corner_pixels(&system, &sim_board, &pose)
                    .iter()
                    .all(|p| {
                        p.is_some_and(|p| {
                            p.x > 8.0
                                && p.y > 8.0
                                && p.x < cam.width_px() as f64 - 9.0
                                && p.y < cam.height_px() as f64 - 9.0
                        })
                    });
                if !inside {
                    continue;
                }
                eprint!(
                    "{}x{} z {z} yaw {yaw} pitch {pitch} roll {roll}: ",
                    system.width(),
                    system.height()
                );
                for (n, sensor) in [None, Some(Sensor::default())].iter().enumerate() {
                    let m = measure(&system, &spec, sensor.as_ref(), k);
                    worst_rms[n] = worst_rms[n].max(m.rms);
                    worst_max[n] = worst_max[n].max(m.max);
                }
            }
        }
        eprintln!(
            "{}x{}: worst RMS clean {:.4} noisy {:.4}, worst max clean {:.4} noisy {:.4}",
            system.width(),
            system.height(),
            worst_rms[0],
            worst_rms[1],
            worst_max[0],
            worst_max[1]
        );
        assert!(worst_rms[0] <= 0.01 && worst_rms[1] <= 0.012);
        assert!(worst_max[0] <= 0.03 && worst_max[1] <= 0.03);
    }
}

#[test]
fn a_board_partly_out_of_view_is_named() {
    let system = System::bench();
    let sim_board = target::PrintedBoard::bench();
    // Shifted right so that its last columns of corners leave the image.
    let pose = BoardPose::tilted(&sim_board, [80.0, 0.0, 520.0], 0.0, 0.0, 4.0);
    let cam = &system.calibration.camera;
    let outside = target::true_corner_pixels(&system, &sim_board, &pose)
        .iter()
        .filter(|p| !p.is_some_and(|p| cam.contains(p)))
        .count();
    assert!(outside >= 6, "{outside} corners off the image");
    let scene = Scene::checkerboard(&sim_board, &pose);
    let image = target::white_frame(&scene, &system, Some(&Sensor::default()), 3, 4).unwrap();
    let err = detect(&image, 320, 240, &board_of(&sim_board)).unwrap_err();
    eprintln!("{err}");
    match &err {
        CornerError::BoardNotFound {
            candidates,
            grid,
            expected,
            at_border,
        } => {
            assert_eq!(*expected, (9, 6));
            assert!(*at_border, "{err}");
            assert!(*candidates >= 30, "{err}");
            assert!(grid.0 * grid.1 < 54 && grid.0 * grid.1 >= 30, "{err}");
        }
        other => panic!("expected BoardNotFound, got {other:?}"),
    }
    let message = err.to_string();
    assert!(message.starts_with("board not found: found "), "{message}");
    assert!(message.contains("expected 9 x 6"), "{message}");
    assert!(message.contains("partly out of view"), "{message}");
}

#[test]
fn no_board_is_named() {
    let system = System::bench();
    let board = board_of(&target::PrintedBoard::bench());
    // A plain diffuse plane: light, but no corners.
    let scene = Scene::preset("plane").unwrap();
    let image = target::white_frame(&scene, &system, Some(&Sensor::default()), 4, 2).unwrap();
    let err = detect(&image, 320, 240, &board).unwrap_err();
    eprintln!("{err}");
    assert!(
        matches!(
            err,
            CornerError::BoardNotFound {
                at_border: false,
                ..
            }
        ),
        "{err:?}"
    );
    assert!(err.to_string().starts_with("board not found"));
    // A black image has no contrast at all.
    let err = detect(&vec![64.0; 320 * 240], 320, 240, &board).unwrap_err();
    assert_eq!(err, CornerError::NoContrast);
    assert!(err.to_string().starts_with("board not found"));
}

#[test]
fn a_board_of_another_size_is_not_taken_for_the_target() {
    let system = System::bench();
    let sim_board = target::PrintedBoard::bench();
    let pose = BoardPose::tilted(&sim_board, [0.0, 0.0, 520.0], 15.0, 0.0, 5.0);
    let scene = Scene::checkerboard(&sim_board, &pose);
    let image = target::white_frame(&scene, &system, None, 0, 4).unwrap();
    // The image holds 9 × 6 corners; an 8 × 6 definition must not pick part of them.
    let wrong = Checkerboard {
        inner_columns: 8,
        ..board_of(&sim_board)
    };
    let err = detect(&image, 320, 240, &wrong).unwrap_err();
    eprintln!("{err}");
    assert!(
        matches!(
            err,
            CornerError::BoardNotFound {
                grid: (9, 6) | (6, 9),
                expected: (8, 6),
                ..
            }
        ),
        "{err:?}"
    );
    // The right definition finds it.
    assert_eq!(
        detect(&image, 320, 240, &board_of(&sim_board))
            .unwrap()
            .len(),
        54
    );
}

#[test]
fn bad_inputs_are_named() {
    let board = board_of(&target::PrintedBoard::bench());
    assert_eq!(
        detect(&[0.0; 10], 4, 3, &board).unwrap_err(),
        CornerError::ImageSize {
            width: 4,
            height: 3,
            len: 10
        }
    );
    assert!(matches!(
        detect(&[0.0; 12], 4, 3, &board).unwrap_err(),
        CornerError::ImageTooSmall { .. }
    ));
    let mut image = vec![0.0f32; 40 * 30];
    image[5 * 40 + 7] = f32::NAN;
    assert_eq!(
        detect(&image, 40, 30, &board).unwrap_err(),
        CornerError::NonFinite { x: 7, y: 5 }
    );
    let tiny = Checkerboard {
        inner_columns: 1,
        ..board
    };
    let err = detect(&image, 40, 30, &tiny).unwrap_err();
    assert!(err.to_string().contains("inner_columns"), "{err}");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    /// `detect` returns (an error or corners), never panics, on any image.
    #[test]
    fn detect_never_panics(
        w in 0usize..48,
        h in 0usize..48,
        values in proptest::collection::vec(any::<f32>(), 0..2400),
        columns in 0u32..6,
        rows in 0u32..6,
    ) {
        let board = Checkerboard { inner_columns: columns, inner_rows: rows, square_mm: 10.0 };
        let _ = detect(&values, w, h, &board);
        // The same values at the size they fill, finite ones only.
        let finite: Vec<f32> = values.iter().map(|v| if v.is_finite() { *v } else { 0.0 }).collect();
        if w > 0 && finite.len() >= w {
            let h2 = finite.len() / w;
            let _ = detect(&finite[..w * h2], w, h2, &board);
        }
    }

    /// Random blocky images (many X-junctions of random shapes): never a panic, and any corners
    /// returned are inside the image, one per board corner.
    #[test]
    fn detect_never_panics_on_blocky_images(
        cells in proptest::collection::vec(0u8..4, 64),
        cell in 4usize..14,
        columns in 2u32..5,
        rows in 2u32..5,
    ) {
        let (w, h) = (8 * cell, 8 * cell);
        let image: Vec<f32> = (0..w * h)
            .map(|i| cells[(i / w / cell) * 8 + (i % w) / cell] as f32)
            .collect();
        let board = Checkerboard { inner_columns: columns, inner_rows: rows, square_mm: 10.0 };
        if let Ok(corners) = detect(&image, w, h, &board) {
            prop_assert_eq!(corners.len(), board.corner_count());
            for p in corners {
                prop_assert!(p.x >= 0.0 && p.y >= 0.0 && p.x <= w as f64 && p.y <= h as f64);
            }
        }
    }
}

fn targets_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../calibration/targets")
}

#[test]
fn the_default_target_file_is_the_simulated_bench_target() {
    let path = targets_dir().join("checkerboard-9x6-20mm.toml");
    let board = Checkerboard::read(&path).unwrap();
    assert_eq!(board, board_of(&target::PrintedBoard::bench()));
    let corners = board.corners_mm();
    assert_eq!(corners.len(), 54);
    assert_eq!(corners[0], Point2::new(0.0, 0.0));
    assert_eq!(corners[1], Point2::new(20.0, 0.0));
    assert_eq!(corners[9], Point2::new(0.0, 20.0));
    assert_eq!(corners[53], Point2::new(160.0, 100.0));
}

#[test]
fn target_definitions_round_trip() {
    for board in [
        Checkerboard {
            inner_columns: 9,
            inner_rows: 6,
            square_mm: 20.0,
        },
        Checkerboard {
            inner_columns: 2,
            inner_rows: 1000,
            square_mm: 0.1 + 0.2,
        },
        Checkerboard {
            inner_columns: 13,
            inner_rows: 8,
            square_mm: 1e-3 / 3.0,
        },
    ] {
        let text = board.to_toml();
        assert_eq!(
            Checkerboard::from_toml(&text, "round trip").unwrap(),
            board,
            "{text}"
        );
    }
}

#[test]
fn target_definition_errors_name_the_file_and_the_key() {
    let good = Checkerboard {
        inner_columns: 9,
        inner_rows: 6,
        square_mm: 20.0,
    }
    .to_toml();
    let cases: [(String, &str); 9] = [
        (
            good.replace("square_mm = 20.0", "square_mm = -20.0"),
            "square_mm = -20.0: must be a finite number above 0 mm",
        ),
        (
            good.replace("square_mm = 20.0", "square_mm = \"20\""),
            "square_mm = \"20\": must be a number",
        ),
        (
            good.replace("inner_rows = 6", "inner_rows = 1"),
            "inner_rows = 1: must be an integer from 2 to 1000",
        ),
        (
            good.replace("inner_columns = 9", "inner_columns = 9.5"),
            "inner_columns = 9.5: must be an integer",
        ),
        (
            good.replace("inner_rows = 6\n", ""),
            "key `inner_rows` is missing",
        ),
        (
            good.replace("square_mm", "square_size_mm"),
            "unknown key `square_size_mm`",
        ),
        (
            good.replace("version = 1", "version = 2"),
            "version = 2: this build reads version 1",
        ),
        (
            good.replace("fsm-checkerboard", "fsm-calibration"),
            "format = \"fsm-calibration\": expected \"fsm-checkerboard\"",
        ),
        (good.replace("inner_rows = 6", "inner_rows = = 6"), "line 6"),
    ];
    for (text, expected) in &cases {
        let err = Checkerboard::from_toml(text, "boards/x.toml").unwrap_err();
        let message = err.to_string();
        assert!(
            message.starts_with("target file boards/x.toml: "),
            "{message}"
        );
        assert!(
            message.contains(expected),
            "{message}\n  expected: {expected}"
        );
    }
    // Reading names the file.
    let missing = targets_dir().join("no-such-board.toml");
    let err = Checkerboard::read(&missing).unwrap_err();
    assert!(matches!(err.kind, BoardErrorKind::Io(_)));
    assert!(err.to_string().contains("no-such-board.toml"), "{err}");
}

/// The structure of one pose's corner errors.
struct Structure {
    rms: f64,
    max: f64,
    /// Mean error vector, px.
    mean: nalgebra::Vector2<f64>,
    /// Correlation of the x (y) error with the error a fixed grid of `s × s` rays would cause
    /// on edges parallel to the pixel grid ([`fixed_grid_error`]).
    corr_fixed_grid: (f64, f64),
}

fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt().max(1e-300)
}

/// Where an edge parallel to the pixel grid at coordinate `x` would appear in an image rendered
/// with a fixed grid of `s` rays per pixel side (at `(i + ½)/s` across the pixel, the same in
/// every pixel, as the simulator did before its rays were multi-jittered per pixel), minus `x`:
/// every pixel along the edge would read it at the nearest ray boundary (RMS 1/(s√12) per
/// axis over the phases, 0.072 px for s = 4). With that grid the fronto-parallel corners'
/// errors correlated with this at 0.86–0.98.
fn fixed_grid_error(x: f64, s: u32) -> f64 {
    let s = s as f64;
    let f = x + 0.5 - (x + 0.5).floor(); // from the pixel's left (top) side
    (s * f - 0.5).ceil() / s - f
}

/// Renders the board at a pose with `supersampling` rays per pixel side and measures the
/// structure of the detected corners' errors (and prints it).
fn structure(
    system: &System,
    spec: &PoseSpec,
    sensor: Option<&Sensor>,
    seed: u64,
    supersampling: u32,
) -> Structure {
    let name = spec.0;
    let (truth, found) = render_and_detect(system, spec, sensor, seed, supersampling);
    let ex: Vec<f64> = found.iter().zip(&truth).map(|(a, b)| a.x - b.x).collect();
    let ey: Vec<f64> = found.iter().zip(&truth).map(|(a, b)| a.y - b.y).collect();
    let n = ex.len() as f64;
    let norms: Vec<f64> = ex.iter().zip(&ey).map(|(x, y)| x.hypot(*y)).collect();
    let qx: Vec<f64> = truth
        .iter()
        .map(|p| fixed_grid_error(p.x, supersampling))
        .collect();
    let qy: Vec<f64> = truth
        .iter()
        .map(|p| fixed_grid_error(p.y, supersampling))
        .collect();
    let m = Structure {
        rms: (norms.iter().map(|e| e * e).sum::<f64>() / n).sqrt(),
        max: norms.iter().copied().fold(0.0, f64::max),
        mean: nalgebra::Vector2::new(ex.iter().sum::<f64>() / n, ey.iter().sum::<f64>() / n),
        corr_fixed_grid: (correlation(&ex, &qx), correlation(&ey, &qy)),
    };
    eprintln!(
        "{name:34} {s:2} rays {}: RMS {:.4} max {:.4} mean ({:+.4}, {:+.4}) px | corr. with a fixed grid's error ({:+.2}, {:+.2})",
        if sensor.is_some() { "noisy" } else { "clean" },
        m.rms,
        m.max,
        m.mean.x,
        m.mean.y,
        m.corr_fixed_grid.0,
        m.corr_fixed_grid.1,
        s = supersampling,
    );
    m
}

/// Boards parallel to the image, their rows along the image rows, at the transport's default
/// 4 × 4 rays per pixel. A fixed ray grid (the same offsets in every pixel) read such edges at
/// the nearest 1/4 px ray boundary in every pixel along them (0.10 px RMS per corner, errors
/// correlated with that step at 0.86–0.98); the rays are now multi-jittered per pixel
/// (`fsm_sim::transport::footprint`), so the edges' coverage errors are independent from pixel
/// to pixel and the corners are as good as on tilted boards: RMS within the tilted poses'
/// limits, mean error under 0.01 px, no correlation left with the fixed grid's step.
/// Measured: RMS 0.0058–0.0077 px, worst corner 0.030 px, mean under 0.0025 px, correlations
/// under 0.25.
#[test]
fn fronto_parallel_corners_at_the_default_rays() {
    let system = System::bench();
    let rays = fsm_sim::TransportSettings::default().supersampling;
    let f = system.calibration.camera.intrinsics().fx_px;
    let at = |name, z: f64, yaw, (ox, oy): (f64, f64)| -> PoseSpec {
        (name, [ox * z / f, oy * z / f, z], yaw, 0.0, 0.0)
    };
    for spec in [
        at("facing, 520 mm", 520.0, 0.0, (0.0, 0.0)),
        at("facing, 480 mm, offset (¼, ½) px", 480.0, 0.0, (0.25, 0.5)),
        at("yaw 2 deg, 600 mm", 600.0, 2.0, (0.0, 0.0)),
    ] {
        for (k, sensor) in [None, Some(Sensor::default())].iter().enumerate() {
            let m = structure(&system, &spec, sensor.as_ref(), 20 + k as u64, rays);
            assert!(m.rms <= 0.015, "{}: RMS {}", spec.0, m.rms);
            assert!(m.mean.norm() <= 0.005, "{}: mean {}", spec.0, m.mean);
            assert!(m.max < 0.06, "{}: max {}", spec.0, m.max);
            let (cx, cy) = m.corr_fixed_grid;
            assert!(cx.abs() < 0.5 && cy.abs() < 0.5, "{}: {cx} {cy}", spec.0);
        }
    }
}

/// Boards parallel to the image and tilted by 2° and 5° at 480–600 mm, rendered with 32 × 32
/// rays: the detector's own accuracy on aligned edges, with the renderer's coverage noise made
/// negligible. What correlates with the pixel phase is the detector's own pixel-phase bias of
/// ≈ 0.01 px (`corners::tests::refinement_pixel_phase_bias_on_aligned_junctions`).
/// `cargo test -p fsm-calibrate --test suite corners::fronto -- --ignored --nocapture` (minutes)
#[test]
#[ignore]
fn fronto_parallel_poses_with_fine_rays() {
    let system = System::bench();
    let f = system.calibration.camera.intrinsics().fx_px;
    for &z in &[480.0, 520.0, 600.0] {
        for &(name, yaw, pitch) in &[
            ("facing", 0.0, 0.0),
            ("yaw 2 deg", 2.0, 0.0),
            ("pitch 5 deg", 0.0, 5.0),
        ] {
            let (ox, oy) = (0.25, 0.5);
            let spec: PoseSpec = (name, [ox * z / f, oy * z / f, z], yaw, pitch, 0.0);
            eprint!("{z} mm ");
            for (k, sensor) in [None, Some(Sensor::default())].iter().enumerate() {
                let m = structure(&system, &spec, sensor.as_ref(), 40 + k as u64, 32);
                let limit = if sensor.is_some() { 0.04 } else { 0.03 };
                assert!(m.rms <= limit, "{name} {z}: RMS {}", m.rms);
                assert!(m.mean.norm() <= 0.01, "{name} {z}: mean {}", m.mean);
            }
        }
    }
}
