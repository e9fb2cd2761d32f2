//! `fsm calibrate import` / `fsm calibrate export` end to end, and the files of
//! `calibration/`: `bench.toml` is the simulator's calibration (`fsm_sim::System::bench()`),
//! and each example file in `calibration/examples/` is what `fsm calibrate export` writes for
//! it, importing back to the same geometry (the same 3D point for the same pixel and column
//! within 1e-6 mm). Bad input exits 1 with a message naming the file and the key, and leaves
//! no output behind.
//!
//! `FSM_BLESS_CALIBRATION=1 cargo test -p fsm-cli --test fsm calibrate_files::` rewrites
//! `calibration/bench.toml` and the examples from the simulator (after a deliberate change of
//! the bench or of the writers); without it the tests only compare.

use std::path::{Path, PathBuf};

use crate::run::{fails, ok_stderr, s};
use fsm_geometry::Calibration;
use fsm_sim::System;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn bless() -> bool {
    std::env::var_os("FSM_BLESS_CALIBRATION").is_some()
}

/// (format, example file, the import options the file needs beside itself).
fn formats(bench: &Calibration) -> Vec<(&'static str, &'static str, Vec<String>)> {
    let camera = format!("{}x{}", bench.camera.width_px(), bench.camera.height_px());
    let projector = format!(
        "{}x{}",
        bench.projector.width_px(),
        bench.projector.height_px()
    );
    let volume = [
        "--near-mm".to_string(),
        bench.volume.near_mm().to_string(),
        "--far-mm".to_string(),
        bench.volume.far_mm().to_string(),
    ];
    let with = |extra: &[&str]| {
        let mut v: Vec<String> = extra.iter().map(|s| s.to_string()).collect();
        v.extend(volume.iter().cloned());
        v
    };
    vec![
        // SLStudio's file has frameWidth/frameHeight and screenResX/screenResY.
        ("slstudio", "slstudio.xml", with(&[])),
        (
            "scan3d-capture",
            "scan3d-capture.yml",
            with(&["--camera-size", &camera, "--projector-size", &projector]),
        ),
        // procam's img_shape is the camera's.
        (
            "procam",
            "procam.xml",
            with(&["--projector-size", &projector]),
        ),
    ]
}

/// Every candidate `(pixel, column)` of points spread over `a`'s volume triangulates to the
/// same point (within 1e-6 mm) with `b`.
fn assert_same_geometry(a: &Calibration, b: &Calibration, what: &str) {
    let (near, far) = (a.volume.near_mm(), a.volume.far_mm());
    let mut n = 0;
    for i in -3..=3 {
        for j in -2..=2 {
            for k in 0..=4 {
                // (fsm-cli has no nalgebra of its own: reuse a point the library returns.)
                let mut point = a.projector_centre_mm();
                point.z = near + (far - near) * (0.05 + 0.225 * k as f64);
                point.x = point.z * 0.06 * i as f64;
                point.y = point.z * 0.06 * j as f64;
                let pixel = a.camera_pixel_of(&point).unwrap();
                let column = a.projector_column_of(&point).unwrap();
                let pa = a.triangulate(pixel, column).unwrap();
                assert!((pa - point).norm() < 1e-6, "{what}: {pa:?} vs {point:?}");
                let pb = b
                    .triangulate(pixel, column)
                    .unwrap_or_else(|e| panic!("{what}: {e}"));
                assert!(
                    (pa - pb).norm() < 1e-6,
                    "{what}: pixel {pixel:?}, column {column}: {pa:?} vs {pb:?}"
                );
                n += 1;
            }
        }
    }
    assert!(n > 100);
}

#[test]
fn bench_toml_is_the_simulators_calibration() {
    let path = repo().join("calibration/bench.toml");
    let bench = System::bench().calibration;
    if bless() {
        bench.write(&path).unwrap();
    }
    let read = Calibration::read(&path).unwrap();
    assert_eq!(
        read, bench,
        "calibration/bench.toml is not System::bench(): rerun with FSM_BLESS_CALIBRATION=1"
    );
}

#[test]
fn examples_are_the_exported_bench_and_import_to_it() {
    let bench = System::bench().calibration;
    let bench_toml = repo().join("calibration/bench.toml");
    let dir = tempfile::tempdir().unwrap();
    for (format, file, options) in formats(&bench) {
        let example = repo().join("calibration/examples").join(file);
        // The example is what export writes for the bench calibration, byte for byte.
        let exported = dir.path().join(file);
        let msg = ok_stderr(&[
            "calibrate",
            "export",
            "--calibration",
            s(&bench_toml),
            "--format",
            format,
            "--out",
            s(&exported),
        ]);
        assert!(msg.contains(s(&exported)), "{msg}");
        if bless() {
            std::fs::create_dir_all(example.parent().unwrap()).unwrap();
            std::fs::copy(&exported, &example).unwrap();
        }
        assert_eq!(
            std::fs::read_to_string(&exported).unwrap(),
            std::fs::read_to_string(&example).unwrap(),
            "{} is stale: rerun with FSM_BLESS_CALIBRATION=1",
            example.display()
        );
        // Importing the example gives the bench back.
        let toml = dir.path().join(format!("{format}.toml"));
        let mut args = vec![
            "calibrate".to_string(),
            "import".into(),
            "--format".into(),
            format.into(),
            "--in".into(),
            s(&example).into(),
            "--out".into(),
            s(&toml).into(),
        ];
        args.extend(options.iter().cloned());
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let msg = ok_stderr(&args);
        assert!(msg.contains("wrote"), "{msg}");
        let imported = Calibration::read(&toml).unwrap();
        assert_same_geometry(&bench, &imported, file);
        assert_eq!(imported, bench, "{file}");
    }
}

#[test]
fn translation_units_round_trip_through_the_cli() {
    let bench = System::bench().calibration;
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("bench.toml");
    bench.write(&cal).unwrap();
    let yml = dir.path().join("procam_m.yml");
    ok_stderr(&[
        "calibrate",
        "export",
        "--calibration",
        s(&cal),
        "--format",
        "procam",
        "--unit",
        "m",
        "--out",
        s(&yml),
    ]);
    let text = std::fs::read_to_string(&yml).unwrap();
    assert!(text.starts_with("%YAML:1.0\n"), "{text}");
    let back = dir.path().join("back.toml");
    let msg = ok_stderr(&[
        "calibrate",
        "import",
        "--format",
        "procam",
        "--in",
        s(&yml),
        "--unit",
        "m",
        "--projector-size",
        "768x1024",
        "--near-mm",
        "350",
        "--far-mm",
        "700",
        "--out",
        s(&back),
    ]);
    assert!(
        msg.contains("img_shape"),
        "camera size from img_shape: {msg}"
    );
    assert_same_geometry(
        &bench,
        &Calibration::read(&back).unwrap(),
        "procam in metres",
    );
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn bad_input_names_the_file_and_the_key_and_leaves_nothing() {
    let bench = System::bench().calibration;
    let dir = tempfile::tempdir().unwrap();
    let cal = dir.path().join("bench.toml");
    bench.write(&cal).unwrap();
    let theirs = dir.path().join("theirs.yml");
    ok_stderr(&[
        "calibrate",
        "export",
        "--calibration",
        s(&cal),
        "--format",
        "scan3d-capture",
        "--out",
        s(&theirs),
    ]);
    let out = dir.path().join("out.toml");
    let import = |file: &Path, format: &str, extra: &[&str]| {
        let mut args = vec![
            "calibrate",
            "import",
            "--format",
            format,
            "--in",
            s(file),
            "--out",
            s(&out),
            "--camera-size",
            "320x240",
            "--projector-size",
            "768x1024",
        ];
        args.extend(extra);
        args.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let run_fails = |args: Vec<String>| {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        fails(&args)
    };
    let volume = ["--near-mm", "350", "--far-mm", "700"];

    // The wrong key set: the message names the missing key and what the file has.
    let msg = run_fails(import(&theirs, "slstudio", &volume));
    assert!(
        msg.contains(s(&theirs)) && msg.contains("`Kc` is missing") && msg.contains("`cam_K`"),
        "{msg}"
    );
    // No volume.
    let msg = run_fails(import(&theirs, "scan3d-capture", &[]));
    assert!(
        msg.contains(s(&theirs)) && msg.contains("--near-mm"),
        "{msg}"
    );
    // A wrong shape.
    let text = std::fs::read_to_string(&theirs).unwrap();
    let broken = dir.path().join("broken.yml");
    std::fs::write(
        &broken,
        text.replace(
            "T: !!opencv-matrix\n   rows: 3",
            "T: !!opencv-matrix\n   rows: 1",
        ),
    )
    .unwrap();
    let msg = run_fails(import(&broken, "scan3d-capture", &volume));
    assert!(msg.contains(s(&broken)) && msg.contains("key `T`"), "{msg}");
    // Not a FileStorage file at all.
    let msg = run_fails(import(&cal, "procam", &volume));
    assert!(msg.contains(s(&cal)) && msg.contains("%YAML:1.0"), "{msg}");
    // Nothing was written, not even a temporary file.
    assert_eq!(
        entries(dir.path()),
        ["bench.toml", "broken.yml", "theirs.yml"]
    );

    // Export: a name that is neither YAML nor XML; a folder that does not exist; a broken
    // calibration file.
    let msg = fails(&[
        "calibrate",
        "export",
        "--calibration",
        s(&cal),
        "--format",
        "procam",
        "--out",
        s(&dir.path().join("x.json")),
    ]);
    assert!(msg.contains("x.json") && msg.contains(".xml"), "{msg}");
    let msg = fails(&[
        "calibrate",
        "export",
        "--calibration",
        s(&cal),
        "--format",
        "procam",
        "--out",
        s(&dir.path().join("no/such/dir.xml")),
    ]);
    assert!(msg.contains("dir.xml"), "{msg}");
    let msg = fails(&[
        "calibrate",
        "export",
        "--calibration",
        s(&broken),
        "--format",
        "procam",
        "--out",
        s(&dir.path().join("y.xml")),
    ]);
    assert!(msg.contains(s(&broken)), "{msg}");
    assert_eq!(
        entries(dir.path()),
        ["bench.toml", "broken.yml", "theirs.yml"]
    );
    // An import that would overwrite its own input.
    let args = import(&theirs, "scan3d-capture", &volume);
    let mut args: Vec<String> = args;
    let at = args.iter().position(|a| a == "--out").unwrap();
    args[at + 1] = s(&theirs).to_string();
    let msg = run_fails(args);
    assert!(msg.contains("input"), "{msg}");
    assert_eq!(std::fs::read_to_string(&theirs).unwrap(), text);
}
