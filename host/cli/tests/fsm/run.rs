//! Running the `fsm` binary the way a user does, and reading what it says.

use std::path::Path;

use assert_cmd::Command;

/// The `fsm` binary of this build.
pub fn fsm() -> Command {
    Command::cargo_bin("fsm").unwrap()
}

fn succeeded(args: &[&str]) -> std::process::Output {
    let out = fsm().args(args).output().unwrap();
    assert!(
        out.status.success(),
        "fsm {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Runs `fsm args…`, which must succeed; its standard output.
pub fn ok(args: &[&str]) -> String {
    String::from_utf8(succeeded(args).stdout).unwrap()
}

/// Runs `fsm args…`, which must succeed; what it said on standard error.
pub fn ok_stderr(args: &[&str]) -> String {
    String::from_utf8(succeeded(args).stderr).unwrap()
}

/// Runs `fsm args…`, which must fail with exit status 1; its message.
pub fn fails(args: &[&str]) -> String {
    let out = fsm().args(args).output().unwrap();
    assert!(!out.status.success(), "fsm {args:?} should have failed");
    assert_eq!(out.status.code(), Some(1), "fsm {args:?}: exit code");
    String::from_utf8(out.stderr).unwrap()
}

/// A path as an argument.
pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// `fsm simulate --scene SCENE --preset PRESET --camera WxH --out OUT`, which must succeed.
pub fn simulate(scene: &str, preset: &str, camera: &str, out: &Path) {
    fsm()
        .args(["simulate", "--scene", scene, "--preset", preset])
        .args(["--camera", camera, "--out", s(out)])
        .assert()
        .success();
}
