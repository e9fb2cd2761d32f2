//! What `fsm calibrate target` and `fsm calibrate response` write and say, made by the library:
//! the line per pose folder, a failed calibration as the host's error, the target's outputs and
//! the response's outputs, and where `fsm patterns` reads a response from.

use std::path::Path;

use fsm_calibrate::calibrate::Iterations;
use fsm_calibrate::pose_folder::{ObservedPoses, PoseSeen};
use fsm_calibrate::refine::Stop;
use fsm_calibrate::report::TargetOutputs;
use fsm_calibrate::response::{choose, read_response, ResponseModel, ResponseOutputs};
use fsm_calibrate::{CalibrateError, CalibrationReport};
use fsm_io::projector_response::{estimate, ProjectorResponse};
use fsm_sim::System;

#[test]
fn a_pose_folder_is_reported_in_a_line() {
    let seen = PoseSeen {
        dir: Path::new("pose1"),
        corners: 54,
        decoded: 0.8734,
    };
    assert_eq!(
        seen.to_string(),
        "pose1: 54 corners, 87.3% of pixels decoded"
    );
}

#[test]
fn a_failed_calibration_is_the_hosts_usage_error() {
    let e = fsm_io::Error::from(CalibrateError::TooFewPoses { given: 2 });
    assert!(matches!(e, fsm_io::Error::Usage(_)));
    assert!(
        e.to_string()
            .starts_with("calibration failed: 2 board poses given"),
        "{e}"
    );
}

fn report() -> CalibrationReport {
    let pose = fsm_calibrate::calibrate::PoseReport {
        label: "pose1".into(),
        corners: 0,
        corners_with_column: 0,
        camera_rms_px: 0.1,
        projector_rms_columns: 0.05,
        distance_mm: 500.0,
        tilt_deg: 20.0,
        corners_px: Vec::new(),
        camera_residuals_px: Vec::new(),
        projector_residuals_columns: Vec::new(),
        dense_samples: 0,
        dense_rms_columns: None,
    };
    CalibrationReport {
        camera_rms_px: 0.1,
        projector_rms_columns: 0.05,
        dense_rms_columns: None,
        poses: vec![pose],
        camera: Vec::new(),
        projector: Vec::new(),
        baseline_mm: 200.0,
        iterations: Iterations {
            camera: 1,
            projector: 1,
            joint: 0,
            last_stop: Stop::SmallStep,
        },
        assumptions: Vec::new(),
    }
}

#[test]
fn a_target_calibration_writes_its_files_in_order_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let (file, json, pictures) = (
        dir.path().join("cal.toml"),
        dir.path().join("report.json"),
        dir.path().join("residuals"),
    );
    let calibration = System::bench().calibration;
    let report = report();
    let poses = ObservedPoses {
        observations: Vec::new(),
        whites: vec![vec![0.5; 12]],
        width: 4,
        height: 3,
    };
    let mut lines = Vec::new();
    let outputs = TargetOutputs {
        calibration: &file,
        report: Some(&json),
        residuals: Some(&pictures),
    };
    outputs
        .write(&calibration, &report, &poses, |line| lines.push(line))
        .unwrap();
    let wrote = |p: &Path| format!("wrote {}", p.display());
    let pictures_line = format!("wrote 1 residual pictures to {}", pictures.display());
    assert_eq!(lines, [wrote(&file), wrote(&json), pictures_line]);
    let text = std::fs::read_to_string(&file).unwrap();
    assert_eq!(text, calibration.to_toml());
    assert_eq!(std::fs::read_to_string(&json).unwrap(), report.to_json());
    assert!(pictures.join("pose00.png").is_file());
    // Only the calibration file when nothing else is asked for.
    let other = dir.path().join("other.toml");
    let mut lines = Vec::new();
    let only = TargetOutputs {
        calibration: &other,
        report: None,
        residuals: None,
    };
    only.write(&calibration, &report, &poses, |line| lines.push(line))
        .unwrap();
    assert_eq!(lines, [wrote(&other)]);
}

#[test]
fn a_response_goes_to_each_output_given_and_back_to_patterns() {
    // Three levels of 64 pixels, the light following code^2.2.
    let codes = [0.0, 0.5, 1.0];
    let level = |code: f64| vec![(100.0 + 1000.0 * code.powf(2.2)).round() as u16; 64];
    let images: Vec<Vec<u16>> = codes.iter().map(|&c| level(c)).collect();
    let images: Vec<&[u16]> = images.iter().map(Vec::as_slice).collect();
    let estimate = estimate(&codes, 8, &images, 4095).unwrap();
    let chosen = choose(&estimate, ResponseModel::Gamma);

    let dir = tempfile::tempdir().unwrap();
    let (file, cal, json) = (
        dir.path().join("response.toml"),
        dir.path().join("cal.toml"),
        dir.path().join("report.json"),
    );
    System::bench().calibration.write(&cal).unwrap();
    let captures = Path::new("captures");
    let mut lines = Vec::new();
    let outputs = ResponseOutputs {
        file: Some(&file),
        calibration: Some(&cal),
        json: Some(&json),
    };
    outputs
        .write(captures, &estimate, &chosen, |line| lines.push(line))
        .unwrap();
    let what = &chosen.what;
    assert_eq!(what, &format!("gamma {:.4}", estimate.gamma));
    assert!((estimate.gamma - 2.2).abs() < 0.01, "{what}");
    assert_eq!(
        lines,
        [
            format!("wrote {} ({what})", file.display()),
            format!("stored {what} in {}", cal.display()),
            format!("wrote {}", json.display()),
        ]
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(report["model"], "gamma");
    assert_eq!(report["response_file"], file.display().to_string());
    assert_eq!(report["calibration_file"], cal.display().to_string());

    // fsm patterns: the response file wins over the calibration's section; none without both.
    let gamma = |r: Option<ProjectorResponse>| match r {
        Some(ProjectorResponse::Gamma(g)) => g,
        other => panic!("{other:?}"),
    };
    let from_file = gamma(read_response(Some(&file), Some(&cal)).unwrap());
    let from_calibration = gamma(read_response(None, Some(&cal)).unwrap());
    assert!((from_file - estimate.gamma).abs() < 1e-4, "{from_file}");
    assert!((from_calibration - estimate.gamma).abs() < 1e-4);
    assert!(read_response(None, None).unwrap().is_none());
    let missing = read_response(None, Some(&file)).unwrap_err().to_string();
    assert!(missing.contains("response.toml"), "{missing}");
}
