//! `fsm simulate --scene checkerboard` and `fsm calibrate target` through the real binary: the
//! bench's checkerboard simulated at five tilted poses (EFSM one group, 76 patterns, the bench's
//! 320 × 240 camera), calibrated from those pose folders, the result checked against the
//! simulator's true calibration and true corner pixels; and the errors of bad input.
//!
//! Measured (seed 1, so repeatable; the simulator's rays multi-jittered per pixel): camera RMS
//! 0.026 px, projector RMS 0.0044 column; camera fx −0.06%, projector fx −0.05%, baseline
//! −0.06%, camera cx +0.0 px, cy +0.1 px; the detected corners 0.027 px RMS from the true ones.
//! (With the former fixed 4 × 4 ray grid: 0.040 px, fx −0.05%, projector fx −0.10%, baseline
//! −0.08%, cx +0.8 px; seeds 2-4 then gave fx −0.03% to −0.11% and baseline −0.04% to −0.14%:
//! the limits below leave a margin of 3-4 times that.) About 18 s in the test profile
//! (`cargo test -p fsm-cli --test fsm calibrate_target:: -- --nocapture` prints it).

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::run::{fsm, s};
use fsm_geometry::Calibration;

/// Board poses simulated (the first ones of `fsm simulate --board-poses`).
const POSES: usize = 5;

/// The bench's target definition, as a user passes it.
fn bench_board() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../calibration/targets/checkerboard-9x6-20mm.toml")
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())))
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Width and height of a PNG file (its IHDR chunk), or a panic if it is not one.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert!(
        bytes.len() > 24 && bytes[..8] == *b"\x89PNG\r\n\x1a\n" && &bytes[12..16] == b"IHDR",
        "{}: not a PNG",
        path.display()
    );
    let word = |i: usize| u32::from_be_bytes(bytes[i..i + 4].try_into().unwrap());
    (word(16), word(20))
}

fn stderr_of(assert: &assert_cmd::assert::Assert) -> String {
    String::from_utf8_lossy(&assert.get_output().stderr).to_string()
}

fn relative(a: f64, b: f64) -> f64 {
    a / b - 1.0
}

#[test]
fn simulated_board_poses_calibrate_the_bench() {
    let t0 = Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let boards = dir.path().join("boards");
    fsm()
        .args(["simulate", "--scene", "checkerboard", "--board-poses"])
        .arg(POSES.to_string())
        .args(["--out", s(&boards)])
        .assert()
        .success();
    let simulated = t0.elapsed().as_secs_f64();
    let pose_dirs: Vec<PathBuf> = (1..=POSES)
        .map(|i| boards.join(format!("pose-{i:02}")))
        .collect();
    for d in &pose_dirs {
        for name in [
            "plan.toml",
            "calibration.toml",
            "0000.png",
            "0077.png",
            "truth/corners.json",
            "truth/column.tiff",
        ] {
            assert!(d.join(name).is_file(), "{}/{name}", d.display());
        }
        // 76 patterns, dark and white: 78 frames and no more.
        assert!(!d.join("0078.png").exists());
    }
    assert!(boards.join("board.toml").is_file());

    let cal_path = dir.path().join("cal.toml");
    let report_path = dir.path().join("report.json");
    let residuals = dir.path().join("res");
    let t1 = Instant::now();
    fsm()
        .args(["calibrate", "target", "--board", s(&bench_board())])
        .args(["--plan", s(&pose_dirs[0].join("plan.toml")), "--poses"])
        .args(pose_dirs.iter().map(|d| s(d)))
        .args(["--out", s(&cal_path), "--report", s(&report_path)])
        .args(["--residuals", s(&residuals)])
        .assert()
        .success();
    let calibrated = t1.elapsed().as_secs_f64();

    // The report's fit.
    let report = json(&report_path);
    let camera_rms = report["camera_rms_px"].as_f64().unwrap();
    let projector_rms = report["projector_rms_columns"].as_f64().unwrap();
    assert!(camera_rms <= 0.1, "camera RMS {camera_rms} px");
    assert!(
        projector_rms <= 0.05,
        "projector RMS {projector_rms} column"
    );
    let poses = report["poses"].as_array().unwrap();
    assert_eq!(poses.len(), POSES);

    // The detected corners against the simulator's true ones (truth/corners.json).
    let mut squares = 0.0;
    let mut count = 0usize;
    for (pose, d) in poses.iter().zip(&pose_dirs) {
        let truth = json(&d.join("truth/corners.json"));
        let truth = truth["corners"].as_array().unwrap();
        let found = pose["corners_px"].as_array().unwrap();
        assert_eq!(found.len(), 54, "{}", d.display());
        assert_eq!(truth.len(), 54, "{}", d.display());
        assert_eq!(pose["corners_with_column"].as_u64(), Some(54));
        for (f, t) in found.iter().zip(truth) {
            let dx = f[0].as_f64().unwrap() - t["pixel"][0].as_f64().unwrap();
            let dy = f[1].as_f64().unwrap() - t["pixel"][1].as_f64().unwrap();
            squares += dx * dx + dy * dy;
            count += 1;
        }
    }
    let corner_rms = (squares / count as f64).sqrt();
    assert!(
        corner_rms < 0.15,
        "corners {corner_rms} px RMS from the truth"
    );

    // The recovered calibration against the simulator's true one.
    let cal = Calibration::read(&cal_path).unwrap();
    let truth = Calibration::read(&pose_dirs[0].join("calibration.toml")).unwrap();
    let (ck, tk) = (cal.camera.intrinsics(), truth.camera.intrinsics());
    let (pk, tp) = (cal.projector.intrinsics(), truth.projector.intrinsics());
    let fx = relative(ck.fx_px, tk.fx_px);
    let fy = relative(ck.fy_px, tk.fy_px);
    let pfx = relative(pk.fx_px, tp.fx_px);
    let baseline = relative(cal.pose.baseline_mm(), truth.pose.baseline_mm());
    let (dcx, dcy) = (ck.cx_px - tk.cx_px, ck.cy_px - tk.cy_px);
    let dpcx = pk.cx_px - tp.cx_px;
    eprintln!(
        "{POSES} poses: simulated in {simulated:.1} s, calibrated in {calibrated:.1} s | camera RMS {camera_rms:.4} px, projector RMS {projector_rms:.4} col, corners {corner_rms:.4} px from the truth | camera fx {:+.3}% fy {:+.3}% cx {dcx:+.2} cy {dcy:+.2} px | projector fx {:+.3}% cx {dpcx:+.2} px | baseline {:.3} mm ({:+.3}%)",
        fx * 100.0,
        fy * 100.0,
        pfx * 100.0,
        cal.pose.baseline_mm(),
        baseline * 100.0
    );
    assert!(fx.abs() < 0.003, "camera fx off by {:.3}%", fx * 100.0);
    assert!(fy.abs() < 0.003, "camera fy off by {:.3}%", fy * 100.0);
    assert!(pfx.abs() < 0.005, "projector fx off by {:.3}%", pfx * 100.0);
    assert!(
        baseline.abs() < 0.005,
        "baseline off by {:.3}%",
        baseline * 100.0
    );
    assert!(
        dcx.abs() < 3.0 && dcy.abs() < 3.0,
        "camera centre ({dcx}, {dcy}) px off"
    );
    assert!(dpcx.abs() < 4.0, "projector cx {dpcx} px off");
    assert_eq!(
        (cal.camera.width_px(), cal.camera.height_px()),
        (truth.camera.width_px(), truth.camera.height_px())
    );
    assert_eq!(cal.projector_columns(), truth.projector_columns());

    // One residual picture per pose, of the camera's size.
    for i in 0..POSES {
        let picture = residuals.join(format!("pose{i:02}.png"));
        assert_eq!(png_size(&picture), (320, 240), "{}", picture.display());
    }

    // Bad input: fewer than 3 poses.
    let bad_out = dir.path().join("bad.toml");
    let bad_report = dir.path().join("bad.json");
    let bad_residuals = dir.path().join("bad-res");
    let calibrate_bad = |poses: &[&Path]| {
        let mut cmd = fsm();
        cmd.args(["calibrate", "target", "--board", s(&bench_board())])
            .args(["--plan", s(&pose_dirs[0].join("plan.toml")), "--poses"])
            .args(poses.iter().map(|d| s(d)))
            .args(["--out", s(&bad_out), "--report", s(&bad_report)])
            .args(["--residuals", s(&bad_residuals)]);
        let assert = cmd.assert().code(1);
        for p in [&bad_out, &bad_report, &bad_residuals] {
            assert!(!p.exists(), "{} left behind", p.display());
        }
        stderr_of(&assert)
    };
    let stderr = calibrate_bad(&[&pose_dirs[0], &pose_dirs[1]]);
    assert!(
        stderr.contains("2 pose folders") && stderr.contains("at least 3"),
        "{stderr}"
    );

    // Bad input: a pose folder with no board in it (the plain `plane` scene, same camera).
    let plane = dir.path().join("plane");
    fsm()
        .args(["simulate", "--scene", "plane", "--preset", "paper-efsm-1"])
        .args(["--images", "--out", s(&plane)])
        .assert()
        .success();
    let no_board = plane.join("images");
    let stderr = calibrate_bad(&[&pose_dirs[0], &no_board, &pose_dirs[2]]);
    assert!(
        stderr.contains(&format!("{}: corners", no_board.display())),
        "{stderr}"
    );
    eprintln!("whole test {:.1} s", t0.elapsed().as_secs_f64());
}

/// `fsm simulate`'s board options: one pose folder, and the errors (which leave no folder).
#[test]
fn simulate_writes_one_board_pose_and_checks_the_options() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pose");
    // A 10 × 7 board of 15 mm squares at one pose (negative angles: allow_hyphen_values).
    let board = dir.path().join("board.toml");
    fs::write(
        &board,
        "format = \"fsm-checkerboard\"\nversion = 1\ninner_columns = 10\ninner_rows = 7\nsquare_mm = 15.0\n",
    )
    .unwrap();
    fsm()
        .args(["simulate", "--scene", "checkerboard", "--board", s(&board)])
        .args(["--board-pose", "-20,10,5,20,-10,520", "--camera", "64x48"])
        .args(["--out", s(&out)])
        .assert()
        .success();
    assert_eq!(png_size(&out.join("0000.png")), (64, 48));
    assert!(out.join("0077.png").is_file() && !out.join("0078.png").exists());
    for name in [
        "plan.toml",
        "calibration.toml",
        "board.toml",
        "truth/depth.tiff",
    ] {
        assert!(out.join(name).is_file(), "{name}");
    }
    let truth = json(&out.join("truth/corners.json"));
    assert_eq!(truth["board"]["inner_columns"], 10);
    assert_eq!(truth["pose"]["centre_mm"][0], 20.0);
    let corners = truth["corners"].as_array().unwrap();
    assert_eq!(corners.len(), 70);
    let truth_cal = Calibration::read(&out.join("calibration.toml")).unwrap();
    for c in corners {
        let (x, y) = (
            c["pixel"][0].as_f64().unwrap(),
            c["pixel"][1].as_f64().unwrap(),
        );
        assert!((0.0..63.0).contains(&x) && (0.0..47.0).contains(&y), "{c}");
        // The corner's camera point projects to its pixel; its column is the projector's.
        let p = &c["camera_mm"];
        let z = p[2].as_f64().unwrap();
        assert!((400.0..650.0).contains(&z), "{c}");
        let column = c["projector_column"].as_f64().unwrap();
        assert!((0.0..768.0).contains(&column), "{c}");
    }
    assert_eq!(truth_cal.camera.width_px(), 64);
    // The board file written beside the frames reads back as the one given.
    let written = fs::read_to_string(out.join("board.toml")).unwrap();
    assert!(written.contains("inner_columns = 10") && written.contains("square_mm = 15.0"));

    let refused = |args: &[&str], expect: &[&str]| {
        let target = dir.path().join("refused");
        let assert = fsm()
            .arg("simulate")
            .args(args)
            .args(["--camera", "64x48", "--out", s(&target)])
            .assert()
            .code(1);
        let stderr = stderr_of(&assert);
        for e in expect {
            assert!(stderr.contains(e), "{args:?}: `{e}` not in {stderr}");
        }
        assert!(!target.exists(), "{args:?}: output folder left behind");
    };
    // The board too near: its corners fall off the image.
    refused(
        &["--scene", "checkerboard", "--board-pose", "0,0,0,150"],
        &["--board-pose 0,0,0,0,0,150", "off the 64x48 camera image"],
    );
    // No pose.
    refused(
        &["--scene", "checkerboard"],
        &["--board-pose", "--board-poses"],
    );
    // Board options with a preset scene.
    refused(
        &[
            "--scene",
            "plane",
            "--preset",
            "paper-efsm-1",
            "--board-poses",
            "3",
        ],
        &["--board-poses is for --scene checkerboard"],
    );
    // A preset scene still needs a plan.
    refused(&["--scene", "plane"], &["--plan", "--preset"]);
    // A missing board file is named.
    let missing = dir.path().join("missing.toml");
    refused(
        &[
            "--scene",
            "checkerboard",
            "--board-poses",
            "3",
            "--board",
            s(&missing),
        ],
        &["missing.toml"],
    );
    // Out-of-range pose counts and malformed poses are clap's usage errors (exit 2).
    for bad in [
        vec!["--board-poses", "0"],
        vec!["--board-poses", "10"],
        vec!["--board-pose", "10,20,520"],
        vec!["--board-pose", "85,0,0,520"],
        vec!["--board-pose", "0,0,0,-5"],
    ] {
        let target = dir.path().join("usage");
        fsm()
            .args(["simulate", "--scene", "checkerboard"])
            .args(&bad)
            .args(["--out", s(&target)])
            .assert()
            .code(2);
        assert!(!target.exists());
    }
}
