//! `fsm plan --method` for every method the toolkit knows, on a projector that is not the
//! paper's, and `fsm patterns` of each plan: dependent fields derived from the width, the
//! images what each method shows, and the commands that take FSM plans only saying so.

use std::fs;

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
    assert_eq!(plan(d, "bfsm", &[]), MethodPlan::Fsm(ScanPlan::bfsm(256)));
    let MethodPlan::Fsm(bfsm) = plan(d, "bfsm", &[]) else {
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
    // The camera takes FSM plans: no wire form for a baseline.
    let e = fails(&[
        "plan",
        "--check",
        s(&d.join("line-scan.toml")),
        "--wire",
        s(&d.join("ls.bin")),
    ]);
    assert!(e.contains("line_scan plan") && e.contains("FSM"), "{e}");
    assert!(!d.join("ls.bin").exists());
}

#[test]
fn patterns_of_every_method_show_what_the_method_projects() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (method, plan) in [
        ("phase-shift", plan(d, "phase-shift", &[])),
        ("micro-phase-shift", plan(d, "micro-phase-shift", &[])),
        ("line-scan", plan(d, "line-scan", &[])),
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
}

#[test]
fn commands_that_decode_fsm_say_a_baseline_plan_is_not_theirs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    plan(d, "line-scan", &[]);
    let e = fails(&[
        "decode",
        "--plan",
        s(&d.join("line-scan.toml")),
        "--images",
        s(d),
        "--out",
        s(&d.join("out.cand")),
    ]);
    assert!(
        e.contains("line-scan.toml") && e.contains("line_scan plan"),
        "{e}"
    );
}
