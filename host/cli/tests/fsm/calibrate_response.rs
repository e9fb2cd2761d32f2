//! `fsm calibrate response` end to end with the real binary: grey-level images written, "captured"
//! by a synthetic camera in front of a gamma-2.2 projector (uneven albedo, dark offset, a patch
//! saturated at full code, 12-bit in 16-bit PNGs), estimated → response file, JSON report and
//! the calibration's [projector_response]; `fsm patterns --calibration` pre-corrects exactly
//! like `--gamma`; bad captures exit 1 naming the file and the level.

use std::path::{Path, PathBuf};

use crate::run::{fails, fsm, ok, s};
use fsm_geometry::file::{CalibrationFile, ProjectorResponseSection};
use fsm_io::image_files;
use fsm_io::projector_response::{GreyLevelManifest, ProjectorResponse, GREY_LEVELS_MANIFEST};

const GAMMA: f64 = 2.2;
const W: u32 = 48;
const H: u32 = 32;

/// The camera's 12-bit value at pixel `i` for projector code `code` (fraction of full).
fn camera(i: usize, code: f64) -> u16 {
    let (x, y) = (i % W as usize, i / W as usize);
    let albedo = 0.4 + 0.6 * ((x * 13 + y * 7) % 17) as f64 / 16.0;
    // A glint: this patch clips at full code.
    let gain = if x < 4 && y < 4 {
        6000.0
    } else {
        3000.0 * albedo
    };
    let noise = ((i * 7919) % 5) as f64 - 2.0;
    (70.0 + gain * code.powf(GAMMA) + noise)
        .round()
        .clamp(0.0, 4095.0) as u16
}

/// Captures of the projected grey levels: each image's code read back from the projector
/// image itself.
fn capture(levels: &Path, out: &Path, manifest: &GreyLevelManifest) {
    std::fs::create_dir_all(out).unwrap();
    for level in &manifest.levels {
        let (_, projected) = image_files::read_image(&levels.join(&level.file)).unwrap();
        let max = ((1u32 << manifest.bit_depth) - 1) as f64;
        let samples: Vec<u16> = projected
            .iter()
            .enumerate()
            .map(|(i, &c)| camera(i % (W * H) as usize, c as f64 / max))
            .collect();
        let f = std::fs::File::create(out.join(format!("{:04}.png", level.index))).unwrap();
        image_files::write_png_gray16(std::io::BufWriter::new(f), W, H, &samples).unwrap();
    }
}

#[test]
fn grey_levels_to_response_file_calibration_and_pre_corrected_patterns() {
    let dir = tempfile::tempdir().unwrap();
    let levels = dir.path().join("levels");
    ok(&[
        "calibrate",
        "response",
        "--write-patterns",
        s(&levels),
        "--levels",
        "9",
        "--width",
        &W.to_string(),
        "--height",
        &H.to_string(),
    ]);
    let manifest = GreyLevelManifest::read(&levels.join(GREY_LEVELS_MANIFEST)).unwrap();
    assert_eq!(manifest.levels.len(), 9);
    assert_eq!(
        manifest.levels.iter().map(|l| l.code).collect::<Vec<_>>(),
        [0, 32, 64, 96, 128, 159, 191, 223, 255]
    );
    let captures = dir.path().join("captures");
    capture(&levels, &captures, &manifest);

    let calibration = dir.path().join("calibration.toml");
    fsm_sim::System::bench()
        .calibration
        .write(&calibration)
        .unwrap();
    let response = dir.path().join("response.toml");
    let report = dir.path().join("report.json");
    let manifest_arg = levels.join(GREY_LEVELS_MANIFEST);
    let stdout = ok(&[
        "calibrate",
        "response",
        "--images",
        s(&captures),
        "--manifest",
        s(&manifest_arg),
        "--bit-depth",
        "12",
        "--out",
        s(&response),
        "--calibration",
        s(&calibration),
        "--json",
        s(&report),
    ]);
    println!("{stdout}");
    assert!(stdout.contains("best-fit gamma 2.2"), "{stdout}");
    assert!(stdout.contains("16 saturated"), "{stdout}");

    // The response file: the power law (it fits), gamma within 0.01.
    let written = ProjectorResponse::read(&response).unwrap();
    let ProjectorResponse::Gamma(g) = written else {
        panic!("{written:?}");
    };
    assert!((g - GAMMA).abs() < 0.01, "{g}");
    // The report.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(json["model"], "gamma");
    assert_eq!(json["pixels_saturated"], 16);
    assert_eq!(json["levels"].as_array().unwrap().len(), 9);
    assert!((json["gamma"].as_f64().unwrap() - g).abs() < 1e-12);
    assert!(json["fit_rms"].as_f64().unwrap() < 0.002);
    // The calibration now carries it, and its geometry is unchanged.
    let file = CalibrationFile::read(&calibration).unwrap();
    assert_eq!(file.calibration, fsm_sim::System::bench().calibration);
    assert_eq!(
        file.projector_response,
        Some(ProjectorResponseSection::Gamma(g))
    );

    // fsm patterns: --calibration pre-corrects exactly like --gamma.
    let plan = dir.path().join("plan.toml");
    ok(&["plan", "--preset", "paper-efsm-1", "--out", s(&plan)]);
    let with_gamma = dir.path().join("p-gamma");
    let with_cal = dir.path().join("p-cal");
    let plain = dir.path().join("p-plain");
    for (out, extra) in [
        (&with_gamma, vec!["--gamma", s(&response)]),
        (&with_cal, vec!["--calibration", s(&calibration)]),
        (&plain, vec![]),
    ] {
        let mut args = vec![
            "patterns",
            "--plan",
            s(&plan),
            "--height",
            "2",
            "--out",
            s(out),
        ];
        args.extend(extra);
        ok(&args);
    }
    let fringe = "0002.png";
    let (_, a) = image_files::read_image(&with_gamma.join(fringe)).unwrap();
    let (_, b) = image_files::read_image(&with_cal.join(fringe)).unwrap();
    let (_, c) = image_files::read_image(&plain.join(fringe)).unwrap();
    assert_eq!(a, b);
    assert_ne!(a, c);
    let m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(with_cal.join("manifest.json")).unwrap())
            .unwrap();
    assert_eq!(m["response_file"], s(&calibration));

    // --model table stores the measured table instead.
    ok(&[
        "calibrate",
        "response",
        "--images",
        s(&captures),
        "--levels",
        "9",
        "--bit-depth",
        "12",
        "--model",
        "table",
        "--calibration",
        s(&calibration),
    ]);
    let file = CalibrationFile::read(&calibration).unwrap();
    let Some(ProjectorResponseSection::Table { input, output }) = file.projector_response else {
        panic!("{:?}", file.projector_response);
    };
    assert_eq!(input.len(), 9);
    assert!(
        (output[4] - input[4].powf(GAMMA)).abs() < 0.003,
        "{output:?}"
    );
}

#[test]
fn bad_captures_and_files_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let levels = dir.path().join("levels");
    ok(&[
        "calibrate",
        "response",
        "--write-patterns",
        s(&levels),
        "--levels",
        "9",
        "--width",
        &W.to_string(),
        "--height",
        &H.to_string(),
    ]);
    let manifest = GreyLevelManifest::read(&levels.join(GREY_LEVELS_MANIFEST)).unwrap();
    let captures = dir.path().join("captures");
    capture(&levels, &captures, &manifest);
    let base = |extra: &[&str]| {
        let mut v: Vec<String> = [
            "calibrate",
            "response",
            "--images",
            s(&captures),
            "--levels",
            "9",
        ]
        .iter()
        .map(|a| a.to_string())
        .collect();
        v.extend(extra.iter().map(|a| a.to_string()));
        v
    };
    let run_fail = |args: Vec<String>| {
        let refs: Vec<&str> = args.iter().map(|a| a.as_str()).collect();
        fails(&refs)
    };

    // The wrong number of levels (default 17, 9 captured).
    let e = fails(&["calibrate", "response", "--images", s(&captures)]);
    assert!(
        e.contains("9 numbered images found, the grey-level set has 17"),
        "{e}"
    );

    // Level 5 captured darker than level 4 (the lamp dimmed): refused, naming file and level.
    let five = captures.join("0005.png");
    let (_, four) = image_files::read_image(&captures.join("0004.png")).unwrap();
    let dimmer: Vec<u16> = four.iter().map(|&v| v.saturating_sub(20)).collect();
    image_files::write_png_gray16(std::fs::File::create(&five).unwrap(), W, H, &dimmer).unwrap();
    let out = dir.path().join("response.toml");
    let e = run_fail(base(&["--bit-depth", "12", "--out", s(&out)]));
    assert!(e.contains("0005.png") && e.contains("level 5"), "{e}");
    assert!(e.contains("not above level 4"), "{e}");
    assert!(!out.exists(), "nothing written on error");

    // The wrong sensor depth: the file and pixel are named.
    let e = run_fail(base(&["--bit-depth", "10"]));
    assert!(e.contains("above the sensor's top code 1023"), "{e}");

    // A missing capture.
    std::fs::remove_file(captures.join("0007.png")).unwrap();
    let e = run_fail(base(&["--bit-depth", "12"]));
    assert!(e.contains("capture 7 is missing"), "{e}");

    // Neither mode, or too few levels.
    let out = fsm().args(["calibrate", "response"]).output().unwrap();
    assert_eq!(out.status.code(), Some(2), "clap's usage error");
    let e = String::from_utf8(out.stderr).unwrap();
    assert!(
        e.contains("--write-patterns") || e.contains("--images"),
        "{e}"
    );
    let e = fails(&[
        "calibrate",
        "response",
        "--write-patterns",
        s(&dir.path().join("x")),
        "--levels",
        "2",
        "--width",
        "4",
        "--height",
        "4",
    ]);
    assert!(e.contains("--levels 2"), "{e}");

    // A calibration without a response cannot pre-correct patterns.
    let calibration = dir.path().join("calibration.toml");
    fsm_sim::System::bench()
        .calibration
        .write(&calibration)
        .unwrap();
    let plan = dir.path().join("plan.toml");
    ok(&["plan", "--preset", "paper-efsm-1", "--out", s(&plan)]);
    let patterns: PathBuf = dir.path().join("patterns");
    let e = fails(&[
        "patterns",
        "--plan",
        s(&plan),
        "--height",
        "2",
        "--calibration",
        s(&calibration),
        "--out",
        s(&patterns),
    ]);
    assert!(
        e.contains("calibration.toml") && e.contains("no [projector_response]"),
        "{e}"
    );
}
