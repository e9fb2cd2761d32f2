//! The real `fsm` client against the camera emulator (the firmware's loop behind a TCP
//! listener on 127.0.0.1): upload a plan, scan a simulated mirror scene's rows, receive the
//! camera's candidates — byte for byte what `fsm decode` makes of the same dump.

use std::fs;

use crate::run::{fsm, s, simulate};
use fsm_firmware::emulator::Emulator;
use fsm_io::candidate_file::CANDIDATE_FILE_NAME;

fn stderr(assert: &assert_cmd::assert::Assert) -> String {
    String::from_utf8_lossy(&assert.get_output().stderr).to_string()
}

#[test]
fn the_camera_decodes_a_simulated_scan_exactly_as_the_host_does() {
    let camera = Emulator::spawn("127.0.0.1:0").unwrap();
    let device = camera.url();
    let dir = tempfile::tempdir().unwrap();
    for preset in ["paper-bfsm", "paper-efsm-2"] {
        let sim = dir.path().join(preset);
        simulate("plane_mirror", preset, "48x32", &sim);
        let plan = sim.join("plan.toml");
        let dump = sim.join("scan.dump");
        let upload = fsm()
            .args(["upload", "--plan", s(&plan), "--device", &device])
            .assert()
            .success();
        assert!(stderr(&upload).contains("accepted"), "{}", stderr(&upload));
        let from_camera = dir.path().join(format!("{preset}.fsmc"));
        fsm()
            .args([
                "camera",
                "scan",
                "--plan",
                s(&plan),
                "--device",
                &device,
                "--dump",
                s(&dump),
                "--out",
                s(&from_camera),
            ])
            .assert()
            .success();
        let decoded = dir.path().join(format!("{preset}-decoded"));
        fsm()
            .args([
                "decode",
                "--plan",
                s(&plan),
                "--dump",
                s(&dump),
                "--out",
                s(&decoded),
            ])
            .assert()
            .success();
        let host = fs::read(decoded.join(CANDIDATE_FILE_NAME)).unwrap();
        let device_bytes = fs::read(&from_camera).unwrap();
        assert!(host.len() > 64 + 32 * 12, "{preset}: {} bytes", host.len());
        assert!(
            host == device_bytes,
            "{preset}: camera and host candidate files differ"
        );
    }
    let info = fsm()
        .args(["camera", "info", "--device", &device])
        .assert()
        .success();
    let out = String::from_utf8_lossy(&info.get_output().stdout).to_string();
    assert!(
        out.contains("loaded plan") && !out.contains("none"),
        "{out}"
    );
}

#[test]
fn the_camera_decodes_every_baselines_scan_exactly_as_the_host_does() {
    let camera = Emulator::spawn("127.0.0.1:0").unwrap();
    let device = camera.url();
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for method in [
        "phase-shift",
        "micro-phase-shift",
        "code-ensemble",
        "line-scan",
    ] {
        let plan = d.join(format!("{method}.toml"));
        fsm()
            .args(["plan", "--method", method, "--projector-columns", "768"])
            .args(["--out", s(&plan)])
            .assert()
            .success();
        let sim = d.join(method);
        fsm()
            .args(["simulate", "--scene", "plane_mirror", "--plan", s(&plan)])
            .args(["--camera", "24x8", "--out", s(&sim)])
            .assert()
            .success();
        let dump = sim.join("scan.dump");
        let upload = fsm()
            .args(["upload", "--plan", s(&plan), "--device", &device])
            .assert()
            .success();
        let fingerprint = fsm_io::plan_file::read_method_plan(&plan)
            .unwrap()
            .fingerprint();
        assert!(
            stderr(&upload).contains(&format!("{fingerprint:016x}")),
            "{method}: {}",
            stderr(&upload)
        );
        let from_camera = d.join(format!("{method}.fsmc"));
        fsm()
            .args(["camera", "scan", "--plan", s(&plan), "--device", &device])
            .args(["--dump", s(&dump), "--out", s(&from_camera)])
            .assert()
            .success();
        let decoded = d.join(format!("{method}-decoded"));
        fsm()
            .args(["decode", "--plan", s(&plan), "--dump", s(&dump)])
            .args(["--out", s(&decoded)])
            .assert()
            .success();
        let host = fs::read(decoded.join(CANDIDATE_FILE_NAME)).unwrap();
        let device_bytes = fs::read(&from_camera).unwrap();
        let header = fsm_core::wire::candidates::CandidateHeader::decode(&host).unwrap();
        assert_eq!(header.plan_fingerprint, fingerprint, "{method}");
        assert!(host.len() > 64 + 8 * 12, "{method}: {} bytes", host.len());
        assert!(
            host == device_bytes,
            "{method}: camera and host candidate files differ"
        );
    }
}

#[test]
fn a_camera_that_is_not_there_is_named_in_the_error() {
    let dir = tempfile::tempdir().unwrap();
    let sim = dir.path().join("sim");
    simulate("plane", "paper-efsm-1", "16x8", &sim);
    // A port nothing listens on.
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let device = format!("tcp://{}", listener.local_addr().unwrap());
    drop(listener);
    let assert = fsm()
        .args([
            "upload",
            "--plan",
            s(&sim.join("plan.toml")),
            "--device",
            &device,
            "--timeout",
            "2",
        ])
        .assert()
        .failure();
    assert!(stderr(&assert).contains(&device), "{}", stderr(&assert));
}
