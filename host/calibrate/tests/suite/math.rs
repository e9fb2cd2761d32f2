//! The calibration math on synthetic correspondences: the bench scanner of
//! `fsm_sim::System::bench()` is the truth, board corners are projected with its camera and
//! projector models, Gaussian noise is added, and the calibration must recover the truth.
//!
//! Tolerances are measured figures with margin (see the `eprintln!` lines, `--nocapture`):
//! each test prints what it measured.

use crate::support;

use fsm_calibrate::calibrate::corner_points;
use fsm_calibrate::homography::{homography, local_column, transform, LocalColumnSettings};
use fsm_calibrate::projector::{calibrate_projector, initial_column_model, ProjectorSettings};
use fsm_calibrate::refine::{refine_camera, CameraRefineSettings};
use fsm_calibrate::zhang::{initial_estimate, BoardPose, ZhangError};
use fsm_calibrate::{calibrate_from_columns, CalibrateError, CalibrationSettings};
use fsm_geometry::{BrownConrady, Calibration, Pinhole};
use fsm_sim::System;
use nalgebra::{Matrix3, Point2, Point3, Rotation3, Vector3};
use support::plane_deviation;

/// SplitMix64 and Box–Muller: reproducible noise without a dependency.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }
    fn gauss(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }
}

/// 9 × 7 inner corners, 18 mm squares, row-major (the order of `Checkerboard::corners_mm`).
fn board() -> Vec<Point2<f64>> {
    let mut v = Vec::new();
    for r in 0..7 {
        for c in 0..9 {
            v.push(Point2::new(c as f64 * 18.0, r as f64 * 18.0));
        }
    }
    v
}

/// A board pose: rotation (degrees about x, y, z) about the board's centre, centre at `at`.
fn pose(board: &[Point2<f64>], deg: [f64; 3], at: [f64; 3]) -> BoardPose {
    let n = board.len() as f64;
    let centre = Vector3::new(
        board.iter().map(|p| p.x).sum::<f64>() / n,
        board.iter().map(|p| p.y).sum::<f64>() / n,
        0.0,
    );
    let r = Rotation3::from_euler_angles(
        deg[0].to_radians(),
        deg[1].to_radians(),
        deg[2].to_radians(),
    );
    BoardPose {
        rotation: r,
        translation_mm: Vector3::from(at) - r * centre,
    }
}

/// Ten poses tilted up to 35° in different directions, 450–540 mm away (a usual calibration
/// session: Zhang's figures improve with tilt and pose count).
fn poses(board: &[Point2<f64>]) -> Vec<BoardPose> {
    [
        ([0.0, 0.0, 0.0], [0.0, 0.0, 500.0]),
        ([35.0, 0.0, 5.0], [-10.0, 10.0, 525.0]),
        ([-35.0, 0.0, -5.0], [10.0, -5.0, 520.0]),
        ([0.0, 35.0, 0.0], [5.0, 0.0, 500.0]),
        ([0.0, -35.0, 8.0], [-5.0, 8.0, 470.0]),
        ([25.0, 25.0, 10.0], [0.0, -8.0, 540.0]),
        ([-25.0, 25.0, -10.0], [12.0, 6.0, 500.0]),
        ([25.0, -25.0, 15.0], [-8.0, 4.0, 510.0]),
        ([-25.0, -25.0, -15.0], [6.0, -4.0, 490.0]),
        ([10.0, -10.0, 30.0], [0.0, 5.0, 530.0]),
    ]
    .into_iter()
    .map(|(d, t)| pose(board, d, t))
    .collect()
}

struct Data {
    board: Vec<Point2<f64>>,
    poses: Vec<BoardPose>,
    corners: Vec<Vec<Point2<f64>>>,
    columns: Vec<Vec<Option<f64>>>,
}

/// Projects the board's corners with the true models, adds noise (σ px per coordinate,
/// σ columns), and checks every corner is seen by both devices.
fn synthesize(truth: &Calibration, sigma_px: f64, sigma_col: f64, seed: u64) -> Data {
    let board = board();
    let poses = poses(&board);
    let mut rng = Rng(seed);
    let mut corners = Vec::new();
    let mut columns = Vec::new();
    for (i, p) in poses.iter().enumerate() {
        let mut cs = Vec::new();
        let mut cols = Vec::new();
        for b in &board {
            let x = p.to_camera(b);
            let px = truth.camera.project(&x).expect("in front");
            assert!(
                truth.camera.contains(px),
                "pose {i}: corner off the camera image: {px}"
            );
            cs.push(Point2::new(
                px.x + sigma_px * rng.gauss(),
                px.y + sigma_px * rng.gauss(),
            ));
            let c = truth.projector_column_of(&x).expect("in front");
            assert!(
                (0.0..768.0).contains(&c),
                "pose {i}: corner off the projector: {c}"
            );
            cols.push(Some(c + sigma_col * rng.gauss()));
        }
        corners.push(cs);
        columns.push(cols);
    }
    Data {
        board,
        poses,
        corners,
        columns,
    }
}

fn bench() -> Calibration {
    System::bench().calibration
}

fn settings() -> CalibrationSettings {
    CalibrationSettings::new(320, 240, 768, 1024)
}

fn labels(n: usize) -> Vec<String> {
    (0..n).map(|i| format!("pose{i}")).collect()
}

// ---------------------------------------------------------------------------------------
// Homographies

#[test]
fn homography_is_exact_on_noise_free_points() {
    let h = Matrix3::new(1.3, 0.2, 150.0, -0.1, 1.1, 90.0, 2e-4, -1e-4, 1.0);
    let src = board();
    let dst: Vec<Point2<f64>> = src.iter().map(|p| transform(&h, p).unwrap()).collect();
    let got = homography(&src, &dst).unwrap();
    let err = (got / got[(2, 2)] - h).abs().max();
    eprintln!("homography max entry error {err:.2e}");
    assert!(err < 1e-9, "{got}");
    // Four points are the minimum and still exact.
    let got4 = homography(&src[..4], &dst[..4]);
    assert!(got4.is_err(), "the first 4 board corners are collinear");
    let idx = [0, 8, 54, 62];
    let s4: Vec<_> = idx.iter().map(|&i| src[i]).collect();
    let d4: Vec<_> = idx.iter().map(|&i| dst[i]).collect();
    let got4 = homography(&s4, &d4).unwrap();
    assert!((got4 / got4[(2, 2)] - h).abs().max() < 1e-9);
    // Degenerate and malformed inputs are errors.
    assert!(homography(&src[..3], &dst[..3]).is_err());
    assert!(
        homography(&src[..9], &dst[..9]).is_err(),
        "one row of corners is collinear"
    );
    assert!(homography(&src, &dst[..10]).is_err());
    let mut bad = dst.clone();
    bad[3].x = f64::NAN;
    assert!(homography(&src, &bad).is_err());
}

/// A column map from a known projective map with holes and outliers: the fit at the corner
/// must recover the map's value.
#[test]
fn local_column_is_exact_and_robust() {
    let (w, h) = (64usize, 48usize);
    let truth = |x: f64, y: f64| (1.9 * x + 0.15 * y + 12.0) / (1e-4 * x - 2e-4 * y + 1.0);
    let mut map: Vec<f32> = (0..w * h)
        .map(|i| truth((i % w) as f64, (i / w) as f64) as f32)
        .collect();
    let corner = Point2::new(30.37, 21.81);
    let exact = truth(corner.x, corner.y);
    let s = LocalColumnSettings::default();
    let fit = local_column(&map, w, h, corner, &s).unwrap();
    eprintln!(
        "local column exact data: error {:.2e} (f32 map)",
        fit.column - exact
    );
    assert!((fit.column - exact).abs() < 1e-4);
    // The fitted map holds near the corner too (where the camera model puts the corner).
    let near = Point2::new(corner.x + 0.6, corner.y - 0.4);
    assert!((fit.at(near) - truth(near.x, near.y)).abs() < 1e-4);
    // Holes (the dark squares decode badly) and gross outliers (interreflections).
    let mut rng = Rng(3);
    for (i, v) in map.iter_mut().enumerate() {
        let (x, y) = ((i % w) as f64, (i / w) as f64);
        if (x - corner.x) * (y - corner.y) > 0.0 && rng.uniform() < 0.7 {
            *v = f32::NAN;
        } else if rng.uniform() < 0.08 {
            *v += 40.0 * (rng.uniform() as f32 - 0.5);
        } else {
            *v += 0.05 * rng.gauss() as f32;
        }
    }
    let fit = local_column(&map, w, h, corner, &s).unwrap();
    eprintln!(
        "local column with holes, 8% outliers, 0.05 col noise: error {:.4} col over {} px",
        fit.column - exact,
        fit.pixels
    );
    assert!((fit.column - exact).abs() < 0.02);
    // An empty window is an error, not a panic.
    let empty = vec![f32::NAN; w * h];
    assert!(local_column(&empty, w, h, corner, &s).is_err());
    assert!(local_column(&map, w, h, Point2::new(f64::NAN, 3.0), &s).is_err());
    assert!(local_column(&map[..10], w, h, corner, &s).is_err());
}

// ---------------------------------------------------------------------------------------
// Zhang

#[test]
fn zhang_is_exact_on_noise_free_data_without_distortion() {
    let mut truth = bench();
    let k = *truth.camera.intrinsics();
    truth.camera = Pinhole::new("camera", 320, 240, k, BrownConrady::NONE).unwrap();
    let d = synthesize(&truth, 0.0, 0.0, 1);
    let est = initial_estimate(&d.board, &d.corners).unwrap();
    let errs = [
        est.camera.fx - k.fx_px,
        est.camera.fy - k.fy_px,
        est.camera.cx - k.cx_px,
        est.camera.cy - k.cy_px,
    ];
    eprintln!("Zhang noise-free K error (fx, fy, cx, cy) px: {errs:?}");
    assert!(errs.iter().all(|e| e.abs() < 1e-6), "{errs:?}");
    for (got, want) in est.poses.iter().zip(&d.poses) {
        assert!((got.translation_mm - want.translation_mm).norm() < 1e-6);
        assert!((got.rotation.matrix() - want.rotation.matrix()).abs().max() < 1e-9);
    }
}

#[test]
fn levenberg_marquardt_converges_from_zhang_on_noisy_data() {
    let truth = bench();
    let k = *truth.camera.intrinsics();
    let kd = *truth.camera.distortion();
    let mut worst = [0.0f64; 8];
    for seed in 1..=4 {
        let d = synthesize(&truth, 0.05, 0.02, seed);
        let est = initial_estimate(&d.board, &d.corners).unwrap();
        let fit = refine_camera(
            &d.board,
            &d.corners,
            &est.camera,
            &BrownConrady::NONE,
            &est.poses,
            &CameraRefineSettings::default(),
        )
        .unwrap();
        let t_err = fit
            .poses
            .iter()
            .zip(&d.poses)
            .map(|(a, b)| (a.translation_mm - b.translation_mm).norm())
            .fold(0.0, f64::max);
        let r_err = fit
            .poses
            .iter()
            .zip(&d.poses)
            .map(|(a, b)| a.rotation.angle_to(&b.rotation).to_degrees())
            .fold(0.0, f64::max);
        let e = [
            (fit.camera.fx / k.fx_px - 1.0).abs() * 100.0,
            (fit.camera.cx - k.cx_px).abs(),
            (fit.camera.cy - k.cy_px).abs(),
            (fit.distortion.k1 - kd.k1).abs(),
            (fit.distortion.k2 - kd.k2).abs(),
            t_err,
            r_err,
            fit.rms_total_px,
        ];
        eprintln!(
            "seed {seed}: fx {:.3}% cx {:.3} px cy {:.3} px k1 {:.4} k2 {:.4} t {:.3} mm R {:.4} deg rms {:.4} px, {} iterations ({:?}); Zhang fx {:.1}",
            e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7], fit.iterations, fit.stop, est.camera.fx
        );
        for (w, v) in worst.iter_mut().zip(e) {
            *w = w.max(v);
        }
        // The standard deviations are honest: every error within 4 σ.
        assert!((fit.camera.fx - k.fx_px).abs() < 4.0 * fit.std_dev[0] + 1e-9);
        assert!((fit.camera.cx - k.cx_px).abs() < 4.0 * fit.std_dev[2] + 1e-9);
        assert!((fit.distortion.k1 - kd.k1).abs() < 4.0 * fit.std_dev[4] + 1e-9);
    }
    eprintln!("worst over seeds: {worst:.4?}");
    // Measured worst over the 4 seeds (σ = 0.05 px, 10 poses of 63 corners, 320 × 240):
    // fx 0.09%, cx 1.34 px, cy 0.99 px, k1 0.011, k2 0.23 (k2 is poorly determined over a
    // 28° field: it trades off against k1), t 1.2 mm, R 0.17°.
    assert!(worst[0] < 0.2, "fx within 0.2%");
    assert!(
        worst[1] < 2.0 && worst[2] < 2.0,
        "principal point within 2 px"
    );
    assert!(worst[3] < 0.02, "k1 within 0.02");
    assert!(worst[4] < 0.35, "k2 within 0.35");
    assert!(worst[5] < 2.0, "board translations within 2 mm");
    assert!(worst[6] < 0.3, "board rotations within 0.3 degree");
    // σ = 0.05 px per coordinate: RMS distance ≈ 0.05·√2 ≈ 0.071.
    assert!(worst[7] < 0.08, "camera RMS");
}

// ---------------------------------------------------------------------------------------
// Projector

#[test]
fn projector_linear_init_is_exact_without_distortion() {
    let mut truth = bench();
    let k = *truth.projector.intrinsics();
    truth.projector = Pinhole::new("projector", 768, 1024, k, BrownConrady::NONE).unwrap();
    let d = synthesize(&truth, 0.0, 0.0, 1);
    let points: Vec<Point3<f64>> = corner_points(&d.board, &d.poses).concat();
    let cols: Vec<f64> = d.columns.concat().into_iter().map(|c| c.unwrap()).collect();
    let m = initial_column_model(&points, &cols).unwrap();
    let want = truth.pose;
    eprintln!(
        "projector linear init, exact data: fx {:.2e} cx {:.2e} t {:.2e} mm R {:.2e} rad",
        m.fx - k.fx_px,
        m.cx - k.cx_px,
        (m.translation_mm - want.translation_mm()).norm(),
        m.rotation.angle_to(want.rotation())
    );
    assert!((m.fx - k.fx_px).abs() < 1e-6);
    assert!((m.cx - k.cx_px).abs() < 1e-6);
    assert!((m.translation_mm - want.translation_mm()).norm() < 1e-6);
    assert!((m.rotation.matrix() - want.rotation().matrix()).abs().max() < 1e-9);
    // One pose only: the corners lie on a plane and the pencil is not determined.
    let one_pose = corner_points(&d.board, &d.poses[..1]).concat();
    let err = initial_column_model(&one_pose, &cols[..one_pose.len()]).unwrap_err();
    eprintln!("one pose: {err}");
}

#[test]
fn projector_recovered_from_noisy_columns_with_the_true_board_poses() {
    let truth = bench();
    let k = *truth.projector.intrinsics();
    let kd = *truth.projector.distortion();
    let d = synthesize(&truth, 0.0, 0.02, 5);
    let points = corner_points(&d.board, &d.poses);
    let fit = calibrate_projector(&points, &d.columns, &ProjectorSettings::default()).unwrap();
    let m = fit.model;
    eprintln!(
        "projector alone: fx {:.3}% cx {:.3} k1 {:.4} k2 {:.4} t {:.3} mm R {:.4} deg rms {:.4} col, {} it",
        (m.fx / k.fx_px - 1.0) * 100.0,
        m.cx - k.cx_px,
        m.distortion.k1 - kd.k1,
        m.distortion.k2 - kd.k2,
        (m.translation_mm - truth.pose.translation_mm()).norm(),
        m.rotation.angle_to(truth.pose.rotation()).to_degrees(),
        fit.rms_total_columns,
        fit.iterations
    );
    assert!(fit.rms_total_columns < 0.025);
    assert!((m.fx / k.fx_px - 1.0).abs() < 0.002);
    assert!((m.cx - k.cx_px).abs() < 1.0);
    assert!((m.distortion.k1 - kd.k1).abs() < 0.02);
    assert!((m.translation_mm - truth.pose.translation_mm()).norm() < 0.5);
}

/// The whole pipeline on synthetic corners and columns; then the `plane` scene (a plane at
/// 500 mm facing the camera) triangulated with the recovered calibration from true
/// (pixel, column) pairs, against the truth.
#[test]
fn full_calibration_recovers_the_bench_and_triangulates_the_plane() {
    let truth = bench();
    let mut worst_dev = 0.0f64;
    for seed in 1..=3 {
        let d = synthesize(&truth, 0.05, 0.02, 100 + seed);
        let (cal, report) = calibrate_from_columns(
            &d.board,
            &labels(d.corners.len()),
            &d.corners,
            &d.columns,
            &settings(),
        )
        .unwrap();
        let ck = cal.camera.intrinsics();
        let pk = cal.projector.intrinsics();
        let tk = truth.camera.intrinsics();
        let tp = truth.projector.intrinsics();
        let t_err = (cal.pose.translation_mm() - truth.pose.translation_mm()).norm();
        let r_err = cal
            .pose
            .rotation()
            .angle_to(truth.pose.rotation())
            .to_degrees();
        let d = plane_deviation(&truth, &cal);
        let (raw, dev) = (d.raw_mm, d.aligned_mm);
        eprintln!(
            "seed {seed}: camera rms {:.4} px, projector rms {:.4} col | camera fx {:.3}% cx {:.3} k1 {:.4} | projector fx {:.3}% cx {:.3} k1 {:.4} k2 {:.4} | t {:.3} mm R {:.4} deg | plane RMS {:.4} mm raw, {:.4} mm = {:.4}% of 500 mm after rigid alignment | iterations {:?}",
            report.camera_rms_px,
            report.projector_rms_columns,
            (ck.fx_px / tk.fx_px - 1.0) * 100.0,
            ck.cx_px - tk.cx_px,
            cal.camera.distortion().k1 - truth.camera.distortion().k1,
            (pk.fx_px / tp.fx_px - 1.0) * 100.0,
            pk.cx_px - tp.cx_px,
            cal.projector.distortion().k1 - truth.projector.distortion().k1,
            cal.projector.distortion().k2 - truth.projector.distortion().k2,
            t_err,
            r_err,
            raw,
            dev,
            dev / 5.0,
            report.iterations
        );
        assert!(report.camera_rms_px <= 0.1);
        assert!(report.projector_rms_columns <= 0.05);
        assert!((ck.fx_px / tk.fx_px - 1.0).abs() < 0.002);
        assert!((ck.cx_px - tk.cx_px).abs() < 1.0 && (ck.cy_px - tk.cy_px).abs() < 1.0);
        assert!((pk.fx_px / tp.fx_px - 1.0).abs() < 0.003);
        assert!((pk.cx_px - tp.cx_px).abs() < 2.0);
        assert!(t_err < 1.0, "projector translation within 1 mm");
        // The camera frame itself is uncertain by δcx/fx (≈ 0.1°): so is the pose.
        assert!(r_err < 0.2, "projector rotation within 0.2 degree");
        assert_eq!(report.poses.len(), 10);
        // The report is JSON with the per-pose figures.
        let json: serde_json::Value = serde_json::from_str(&report.to_json()).unwrap();
        assert_eq!(json["poses"].as_array().unwrap().len(), 10);
        assert!(json["poses"][0]["camera_rms_px"].as_f64().unwrap() > 0.0);
        worst_dev = worst_dev.max(dev);
        // Without alignment the camera frame itself is off by the principal point's error
        // (δcx/fx rad ≈ 0.1° here, 0.9 mm at 500 mm): the frame is defined by the calibration.
        assert!(raw < 2.0, "raw plane deviation {raw} mm");
    }
    assert!(
        worst_dev <= 0.0002 * 500.0,
        "plane deviation {worst_dev} mm above 0.02% of the standoff"
    );
}

// ---------------------------------------------------------------------------------------
// Degenerate input

#[test]
fn degenerate_input_is_a_clear_error() {
    let truth = bench();
    let d = synthesize(&truth, 0.05, 0.02, 9);
    let s = settings();
    // Fewer than 3 poses.
    let err = calibrate_from_columns(&d.board, &labels(2), &d.corners[..2], &d.columns[..2], &s)
        .unwrap_err();
    assert!(
        matches!(err, CalibrateError::TooFewPoses { given: 2 }),
        "{err}"
    );
    eprintln!("{err}");
    // Too few corners.
    let small: Vec<Vec<Point2<f64>>> = d.corners.iter().map(|c| c[..4].to_vec()).collect();
    let small_cols: Vec<Vec<Option<f64>>> = d.columns.iter().map(|c| c[..4].to_vec()).collect();
    let err =
        calibrate_from_columns(&d.board[..4], &labels(10), &small, &small_cols, &s).unwrap_err();
    assert!(matches!(err, CalibrateError::TooFewCorners { .. }), "{err}");
    eprintln!("{err}");
    // A pose with a corner missing.
    let mut short = d.corners.clone();
    short[3].pop();
    let err = calibrate_from_columns(&d.board, &labels(10), &short, &d.columns, &s).unwrap_err();
    assert!(matches!(err, CalibrateError::CornerCount { .. }), "{err}");
    // All poses parallel: the same tilt, shifted and turned in the board plane only.
    let board = board();
    let parallel: Vec<BoardPose> = (0..4)
        .map(|i| {
            pose(
                &board,
                [10.0, 5.0, 0.0],
                [
                    -20.0 + 12.0 * i as f64,
                    10.0 - 5.0 * i as f64,
                    470.0 + 20.0 * i as f64,
                ],
            )
        })
        .collect();
    let corners: Vec<Vec<Point2<f64>>> = parallel
        .iter()
        .map(|p| {
            board
                .iter()
                .map(|b| truth.camera.project(&p.to_camera(b)).unwrap())
                .collect()
        })
        .collect();
    let err = initial_estimate(&board, &corners).unwrap_err();
    assert!(matches!(err, ZhangError::Degenerate { .. }), "{err}");
    eprintln!("parallel, noise-free: {err}");
    let mut rng = Rng(4);
    let noisy: Vec<Vec<Point2<f64>>> = corners
        .iter()
        .map(|c| {
            c.iter()
                .map(|p| Point2::new(p.x + 0.05 * rng.gauss(), p.y + 0.05 * rng.gauss()))
                .collect()
        })
        .collect();
    let cols = vec![vec![Some(300.0); board.len()]; 4];
    let err = calibrate_from_columns(&board, &labels(4), &noisy, &cols, &s).unwrap_err();
    eprintln!("parallel, noisy: {err}");
    assert!(
        matches!(err, CalibrateError::Camera(ZhangError::Degenerate { .. })),
        "{err}"
    );
    // Columns missing everywhere: a projector error, not a panic.
    let none = vec![vec![None; d.board.len()]; 10];
    let err = calibrate_from_columns(&d.board, &labels(10), &d.corners, &none, &s).unwrap_err();
    assert!(matches!(err, CalibrateError::Projector(_)), "{err}");
    eprintln!("{err}");
    // NaN corners.
    let mut nan = d.corners.clone();
    nan[1][5].x = f64::NAN;
    let err = calibrate_from_columns(&d.board, &labels(10), &nan, &d.columns, &s).unwrap_err();
    eprintln!("{err}");
}

/// `t.y` is observable only through the projector's distortion (module docs of
/// `fsm_calibrate::projector`): freeing it must still converge, with a large standard
/// deviation, and leave the plane as good.
#[test]
fn projector_vertical_offset_is_weakly_observable() {
    let truth = bench();
    let d = synthesize(&truth, 0.05, 0.02, 101);
    let mut s = settings();
    s.projector.refine_vertical_offset = true;
    let (cal, report) = calibrate_from_columns(
        &d.board,
        &labels(d.corners.len()),
        &d.corners,
        &d.columns,
        &s,
    )
    .unwrap();
    let ty = report.projector.iter().find(|p| p.name == "ty_mm").unwrap();
    let tx = report.projector.iter().find(|p| p.name == "tx_mm").unwrap();
    let dev = plane_deviation(&truth, &cal).aligned_mm;
    eprintln!(
        "t.y free: {:.3} ± {:.3} mm (t.x ± {:.3} mm), plane {:.4} mm aligned, projector RMS {:.4}",
        ty.value,
        ty.std_dev.unwrap_or(f64::NAN),
        tx.std_dev.unwrap_or(f64::NAN),
        dev,
        report.projector_rms_columns
    );
    assert!(!ty.fixed);
    assert!(ty.std_dev.unwrap() > 5.0 * tx.std_dev.unwrap());
    assert!(dev <= 0.0002 * 500.0);
}
