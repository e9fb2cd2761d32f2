//! `fsm plan --method` for every method the toolkit knows, on a projector that is not the
//! paper's, and `fsm patterns` of each plan: dependent fields derived from the width, the
//! images what each method shows, `fsm inspect` of each, and the camera saying it takes FSM
//! plans.

use std::fs;
use std::path::{Path, PathBuf};

use fsm_core::{MicroPhaseShiftPlan, PhaseShiftPlan, ScanPlan};
use fsm_io::plan_file::{read_method_plan, MethodPlan};

use crate::run::{fails, ok, ok_stderr, s};

/// `fsm plan --method METHOD --projector-columns 256 --out DIR/METHOD.toml`; the plan read back.
fn plan(dir: &std::path::Path, method: &str, extra: &[&str]) -> MethodPlan {
    let path = dir.join(format!("{method}.toml"));
    let mut args = vec![
        "plan",
        "--method",
        method,
        "--projector-columns",
        "256",
        "--out",
        s(&path),
    ];
    args.extend(extra);
    ok(&args);
    let checked = ok(&["plan", "--check", s(&path)]);
    assert!(checked.contains("256 columns"), "{checked}");
    read_method_plan(&path).unwrap()
}

#[test]
fn every_method_derives_its_plan_from_the_projector_width() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // BFSM: one fringe per column of this projector, not the paper's 768.
    let bfsm = plan(d, "bfsm", &[]);
    assert_eq!(bfsm, MethodPlan::Fsm(ScanPlan::bfsm(256)));
    let MethodPlan::Fsm(bfsm) = bfsm else {
        unreachable!()
    };
    assert_eq!((bfsm.band.count, bfsm.band.period_columns), (256, 512));
    assert_eq!(ScanPlan::bfsm(768), ScanPlan::paper_bfsm());
    let efsm = plan(d, "efsm", &["--block-width", "32", "--groups", "1"]);
    assert_eq!(
        efsm,
        MethodPlan::Fsm(ScanPlan::efsm(256, 32, fsm_core::GroupCount::One))
    );
    // Phase shift: 512/12 = 43 half periods need 6 Gray-code bits (the paper's 768 need 7).
    let ps = plan(d, "phase-shift", &[]);
    assert_eq!(
        ps,
        MethodPlan::PhaseShift(PhaseShiftPlan::for_projector(256))
    );
    let MethodPlan::PhaseShift(p) = ps else {
        unreachable!()
    };
    assert_eq!((p.bits, p.period_columns, p.steps), (6, 12, 6));
    let mps = plan(d, "micro-phase-shift", &[]);
    assert_eq!(mps.patterns().pattern_count(), 17);
    assert_eq!(
        mps,
        MethodPlan::MicroPhaseShift(MicroPhaseShiftPlan::spread(256, 16.0, 4.0, 15))
    );
    let ls = plan(d, "line-scan", &["--set", "line_scan.noise_factor=8"]);
    let MethodPlan::LineScan(l) = ls else {
        panic!("{ls:?}")
    };
    assert_eq!(
        (
            l.projector_columns,
            l.noise_factor,
            ls.patterns().frame_count()
        ),
        (256, 8.0, 258)
    );
    // Code Ensemble: 80 patterns for any width; --set reaches its table.
    let ce = plan(
        d,
        "code-ensemble",
        &["--set", "code_ensemble.agreement_columns=2"],
    );
    let MethodPlan::CodeEnsemble(c) = ce else {
        panic!("{ce:?}")
    };
    assert_eq!(
        (
            c.projector_columns,
            c.agreement_columns,
            ce.patterns().frame_count()
        ),
        (256, 2, 80)
    );
    // A baseline's field misspelt is named as written.
    let e = fails(&[
        "plan",
        "--method",
        "line-scan",
        "--projector-columns",
        "256",
        "--set",
        "line_scan.noise_factr=8",
    ]);
    assert!(e.contains("line_scan.noise_factr"), "{e}");
    // The camera takes every method's plan: a baseline's wire form is its canonical bytes.
    ok(&[
        "plan",
        "--check",
        s(&d.join("line-scan.toml")),
        "--wire",
        s(&d.join("ls.bin")),
    ]);
    let bytes = fs::read(d.join("ls.bin")).unwrap();
    let wired = MethodPlan::from_bytes(&bytes).unwrap();
    assert_eq!(wired, read_method_plan(&d.join("line-scan.toml")).unwrap());
    assert_eq!(&bytes[..2], b"LS");
}

#[test]
fn patterns_of_every_method_show_what_the_method_projects() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (method, plan) in [
        ("phase-shift", plan(d, "phase-shift", &[])),
        ("micro-phase-shift", plan(d, "micro-phase-shift", &[])),
        ("line-scan", plan(d, "line-scan", &[])),
        ("code-ensemble", plan(d, "code-ensemble", &[])),
    ] {
        let out = d.join(format!("{method}-patterns"));
        let said = ok_stderr(&[
            "patterns",
            "--plan",
            s(&d.join(format!("{method}.toml"))),
            "--height",
            "2",
            "--sixteen-bit",
            "--out",
            s(&out),
        ]);
        let patterns = plan.patterns();
        let frames = patterns.frame_count();
        assert!(said.contains(&format!("wrote {frames} images")), "{said}");
        let manifest: serde_json::Value =
            serde_json::from_slice(&fs::read(out.join("manifest.json")).unwrap()).unwrap();
        assert_eq!(manifest["frames"].as_array().unwrap().len(), frames);
        assert_eq!(
            manifest["plan_fingerprint"],
            format!("{:016x}", patterns.fingerprint())
        );
        assert_eq!(
            manifest["pattern_fingerprint"],
            format!("{:016x}", patterns.pattern_fingerprint())
        );
        // Every image is the plan's pattern function at each column, to the 16-bit code.
        for frame in [0, 1, 2, frames / 2, frames - 1] {
            let file = out.join(manifest["frames"][frame]["file"].as_str().unwrap());
            let (info, data) = fsm_io::image_files::read_image(&file).unwrap();
            assert_eq!((info.width, info.height), (256, 2));
            for column in 0..256u32 {
                let want = (patterns.frame_intensity(frame, column) as f64 * 65535.0).round();
                assert_eq!(
                    data[column as usize] as f64, want,
                    "{method} frame {frame} column {column}"
                );
            }
        }
    }
    // Line scanning: image 2 + j lights column j alone.
    let manifest: serde_json::Value =
        serde_json::from_slice(&fs::read(d.join("line-scan-patterns/manifest.json")).unwrap())
            .unwrap();
    assert_eq!(manifest["frames"][130]["kind"], "line");
    assert_eq!(manifest["frames"][130]["column"], 128);
    assert_eq!(manifest["plan"]["line_scan"]["projector_columns"], 256);
    // Code Ensemble: each code's bits, each followed by its inverse.
    let manifest: serde_json::Value =
        serde_json::from_slice(&fs::read(d.join("code-ensemble-patterns/manifest.json")).unwrap())
            .unwrap();
    assert_eq!(manifest["frames"][23]["kind"], "code_bit");
    assert_eq!(manifest["frames"][23]["code"], "long-run Gray");
    assert_eq!(manifest["frames"][23]["bit"], 1);
    assert_eq!(manifest["frames"][23]["inverse"], true);
}

#[test]
fn upload_takes_a_baselines_plan_and_names_the_camera_that_is_not_there() {
    // The camera decodes every method: a line-scan plan is read and sent; only the missing
    // camera stops it (tests/fsm/camera.rs scans one through the emulator).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    plan(d, "line-scan", &[]);
    let e = fails(&[
        "upload",
        "--plan",
        s(&d.join("line-scan.toml")),
        "--device",
        "tcp://127.0.0.1:9",
        "--timeout",
        "2",
    ]);
    assert!(e.contains("127.0.0.1:9"), "{e}");
    assert!(!e.contains("line_scan plan"), "{e}");
}

#[test]
fn every_method_goes_plan_simulate_decode_scan() {
    // The simulator's bench projector has 768 columns: each method's plan for it, a plane
    // captured with it, decoded to candidates and scanned to points, scored by the truth. At
    // 128 x 96 a camera pixel sees about 6 columns (fsm demo's smallest camera).
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for method in [
        "bfsm",
        "phase-shift",
        "micro-phase-shift",
        "code-ensemble",
        "line-scan",
    ] {
        // A binary code names one codeword per pixel: where a pixel sees 6 columns it is up
        // to 3 columns off (81% of the points beyond 1 mm at 128 x 96, measured), so Code
        // Ensemble is scanned with a pixel of 2 columns, as its authors' camera resolved.
        let camera = if method == "code-ensemble" {
            "384x288"
        } else {
            "128x96"
        };
        let (plan, sim) = plane_of(d, method, camera, &[]);
        let frames = read_method_plan(&plan).unwrap().patterns().frame_count();
        // The dump carries the plan's fingerprint; its decode is a candidate file.
        let decoded = d.join(format!("{method}-decoded"));
        let said = ok_stderr(&[
            "decode",
            "--plan",
            s(&plan),
            "--dump",
            s(&sim.join("scan.dump")),
            "--out",
            s(&decoded),
        ]);
        assert!(said.contains("decoded"), "{method}: {said}");
        assert!(decoded.join("candidates.fsmc").is_file(), "{method}");
        let scan = d.join(format!("{method}-scan"));
        ok_stderr(&[
            "scan",
            "--plan",
            s(&plan),
            "--calibration",
            s(&sim.join("calibration.toml")),
            "--dump",
            s(&sim.join("scan.dump")),
            "--truth",
            s(&sim.join("truth")),
            "--out",
            s(&scan),
        ]);
        let summary: serde_json::Value =
            serde_json::from_slice(&fs::read(scan.join("summary.json")).unwrap()).unwrap();
        let truth = &summary["truth"];
        let (wrong, completeness) = (
            truth["wrong_share"].as_f64().unwrap(),
            truth["completeness"].as_f64().unwrap(),
        );
        println!(
            "{method} ({frames} frames): {} points, {:.2}% wrong, {:.2}% of the lit pixels right",
            summary["points"],
            100.0 * wrong,
            100.0 * completeness
        );
        assert!(wrong <= 0.01, "{method}: {summary}");
        assert!(completeness >= 0.95, "{method}: {summary}");
        // Every method's points carry a quality, and the default filter kept those of at
        // least 20 times the noise of a dark pixel's amplitude.
        let qualities = crate::scan::ply_qualities(&scan.join("points.ply"));
        assert_eq!(qualities.len() as u64, summary["points"].as_u64().unwrap());
        assert!(
            qualities.iter().all(|&q| q >= 20.0),
            "{method}: {:?}",
            qualities.iter().copied().fold(f32::NAN, f32::min)
        );
        // `fsm inspect` draws what the method's decoder sees, and names the same candidate.
        let (x, y) = if method == "code-ensemble" {
            (192, 144)
        } else {
            (64, 48)
        };
        let pixel = format!("{x},{y}");
        let picture = d.join(format!("{method}-pixel.png"));
        let said = ok(&[
            "inspect",
            "--plan",
            s(&plan),
            "--dump",
            s(&sim.join("scan.dump")),
            "--pixel",
            &pixel,
            "--out",
            s(&picture),
        ]);
        assert!(
            said.contains(&format!("pixel ({x}, {y}): column")),
            "{method}: {said}"
        );
        assert!(fs::metadata(&picture).unwrap().len() > 1000, "{method}");
        let picture = d.join(format!("{method}-row.png"));
        ok(&[
            "inspect",
            "--plan",
            s(&plan),
            "--dump",
            s(&sim.join("scan.dump")),
            "--row",
            &y.to_string(),
            "--out",
            s(&picture),
        ]);
        assert!(fs::metadata(&picture).unwrap().len() > 1000, "{method}");
        if method != "bfsm" {
            let e = fails(&[
                "inspect",
                "--plan",
                s(&plan),
                "--dump",
                s(&sim.join("scan.dump")),
                "--row",
                "1",
                "--group",
                "2",
                "--out",
                s(&d.join("never.png")),
            ]);
            assert!(e.contains("no pattern groups"), "{method}: {e}");
        }
        // Another method's plan does not decode this capture.
        let other = if method == "line-scan" {
            "bfsm"
        } else {
            "line-scan"
        };
        let e = fails(&[
            "scan",
            "--plan",
            s(&d.join(format!("{other}.toml"))),
            "--calibration",
            s(&sim.join("calibration.toml")),
            "--dump",
            s(&sim.join("scan.dump")),
            "--out",
            s(&d.join("never")),
        ]);
        if d.join(format!("{other}.toml")).exists() {
            assert!(e.contains("fingerprint") || e.contains("plan"), "{e}");
        }
    }
}

#[test]
fn single_file_outputs_follow_the_folders_rule() {
    // An existing file is kept unless --force, a missing parent folder is named, and the
    // command does no work first.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let out = d.join("plan.toml");
    fs::write(&out, "mine").unwrap();
    let e = fails(&["plan", "--preset", "paper-bfsm", "--out", s(&out)]);
    assert!(e.contains("plan.toml") && e.contains("--force"), "{e}");
    assert_eq!(fs::read_to_string(&out).unwrap(), "mine");
    ok(&[
        "plan",
        "--preset",
        "paper-bfsm",
        "--out",
        s(&out),
        "--force",
    ]);
    assert!(read_method_plan(&out).is_ok());
    let wire = d.join("plan.bin");
    fs::write(&wire, "mine").unwrap();
    let e = fails(&["plan", "--check", s(&out), "--wire", s(&wire)]);
    assert!(e.contains("plan.bin") && e.contains("--force"), "{e}");
    let nested = d.join("missing/plan.toml");
    let e = fails(&["plan", "--preset", "paper-bfsm", "--out", s(&nested)]);
    assert!(e.contains("missing") && e.contains("does not exist"), "{e}");
    let e = fails(&["plan", "--preset", "paper-bfsm", "--out", s(d)]);
    assert!(e.contains("is a folder"), "{e}");
}

#[test]
fn a_baselines_image_stack_converts_and_decodes_like_its_dump() {
    // Phase shift (15 frames): captured as images, converted to a dump, both decoded.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (plan, sim) = plane_of(d, "phase-shift", "64x48", &["--images"]);
    let dump = d.join("converted.dump");
    ok_stderr(&[
        "convert",
        "--plan",
        s(&plan),
        "--images",
        s(&sim.join("images")),
        "--out",
        s(&dump),
    ]);
    let decode = |source: &[&str], out: &str| {
        let out = d.join(out);
        let mut args = vec!["decode", "--plan", s(&plan), "--out", s(&out)];
        args.extend(source);
        ok_stderr(&args);
        fs::read(out.join("candidates.fsmc")).unwrap()
    };
    let from_images = decode(&["--images", s(&sim.join("images"))], "from-images");
    let from_dump = decode(&["--dump", s(&dump)], "from-dump");
    assert!(from_images.len() > 1000);
    assert_eq!(from_images, from_dump);
}

/// `fsm plan --method METHOD` for the simulator's 768-column projector (`DIR/METHOD.toml`),
/// then `fsm simulate` of the plane with it (`DIR/METHOD-sim`, camera `camera`, `extra`
/// arguments); returns the plan file and the simulation folder.
fn plane_of(dir: &Path, method: &str, camera: &str, extra: &[&str]) -> (PathBuf, PathBuf) {
    let plan = dir.join(format!("{method}.toml"));
    ok(&[
        "plan",
        "--method",
        method,
        "--projector-columns",
        "768",
        "--out",
        s(&plan),
    ]);
    let sim = dir.join(format!("{method}-sim"));
    let mut args = vec!["simulate", "--scene", "plane", "--plan", s(&plan)];
    args.extend(["--camera", camera, "--out", s(&sim)]);
    args.extend_from_slice(extra);
    ok_stderr(&args);
    (plan, sim)
}
