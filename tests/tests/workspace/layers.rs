//! The workspace's crates import one way: [`LAYERS`] lists every package by layer, lowest first,
//! and a package's dependencies (normal and build, read from `cargo metadata`) may name only
//! packages of a lower layer. A crate reaching up or sideways (`fsm-geometry` using `fsm-scan`,
//! the simulator using the CLI) fails here with both names. Dev-dependencies are free: tests may
//! use anything. The core's own modules are held to their order by `core/tests/suite/layers.rs`.

use std::process::Command;

/// The layers, lowest first. Every workspace package is in exactly one.
const LAYERS: [&[&str]; 7] = [
    // The no_std decoder the camera and the host share.
    &["fsm-core"],
    // What stands on the core alone: the camera protocol; host I/O (files, decoding in
    // parallel, the one atomic writer).
    &["fsm-protocol", "fsm-io"],
    // The camera program; camera and projector geometry and the calibration files.
    &["fsm-firmware", "fsm-geometry"],
    // The host's calibration and scan.
    &["fsm-calibrate", "fsm-scan"],
    // The simulator: it renders the calibration's targets and scores the scan (the paper's
    // comparison); the calibration's and the scan's tests use it as a dev-dependency only.
    &["fsm-sim"],
    // The `fsm` tool.
    &["fsm-cli"],
    // Tests only: the workspace's, and the decoder's digest (`core/digest`).
    &["fsm-tests", "fsm-digest"],
];

fn layer_of(package: &str) -> Option<usize> {
    LAYERS.iter().position(|layer| layer.contains(&package))
}

/// One package and the workspace packages its normal and build dependencies name.
struct Package {
    name: String,
    depends_on: Vec<String>,
}

fn workspace_packages() -> Vec<Package> {
    let out = Command::new(env!("CARGO"))
        .args([
            "metadata",
            "--format-version",
            "1",
            "--no-deps",
            "--offline",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo metadata runs");
    assert!(
        out.status.success(),
        "cargo metadata failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let metadata: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let packages = metadata["packages"].as_array().unwrap();
    let names: Vec<&str> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap())
        .collect();
    packages
        .iter()
        .map(|p| Package {
            name: p["name"].as_str().unwrap().to_owned(),
            depends_on: p["dependencies"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|d| d["kind"].as_str() != Some("dev"))
                .map(|d| d["name"].as_str().unwrap())
                .filter(|d| names.contains(d))
                .map(str::to_owned)
                .collect(),
        })
        .collect()
}

/// Every dependency that does not point to a lower layer, as `from -> to` lines.
fn violations(packages: &[Package]) -> Vec<String> {
    let mut found = Vec::new();
    for p in packages {
        let Some(from) = layer_of(&p.name) else {
            found.push(format!(
                "{} is in no layer of tests/tests/workspace/layers.rs",
                p.name
            ));
            continue;
        };
        for d in &p.depends_on {
            match layer_of(d) {
                Some(to) if to < from => {}
                Some(to) => found.push(format!(
                    "{} (layer {from}) depends on {d} (layer {to}): only lower layers",
                    p.name
                )),
                None => found.push(format!(
                    "{d} is in no layer of tests/tests/workspace/layers.rs"
                )),
            }
        }
    }
    found
}

#[test]
fn crates_depend_only_on_lower_layers() {
    let packages = workspace_packages();
    for layer in LAYERS {
        for name in layer {
            assert!(
                packages.iter().any(|p| p.name == *name),
                "{name} is listed in LAYERS but is not a workspace package"
            );
        }
    }
    let found = violations(&packages);
    assert!(
        found.is_empty(),
        "crates importing upwards:\n{}",
        found.join("\n")
    );
}

#[test]
fn an_upward_or_sideways_dependency_is_caught() {
    let package = |name: &str, deps: &[&str]| Package {
        name: name.to_owned(),
        depends_on: deps.iter().map(|d| (*d).to_owned()).collect(),
    };
    assert!(violations(&[package("fsm-scan", &["fsm-core", "fsm-io"])]).is_empty());
    assert_eq!(
        violations(&[package("fsm-geometry", &["fsm-scan"])]).len(),
        1
    );
    assert_eq!(violations(&[package("fsm-io", &["fsm-geometry"])]).len(), 1);
    assert_eq!(violations(&[package("fsm-scan", &["fsm-sim"])]).len(), 1);
    assert_eq!(
        violations(&[package("fsm-scan", &["fsm-calibrate"])]).len(),
        1
    );
    assert!(violations(&[package("fsm-sim", &["fsm-scan", "fsm-calibrate"])]).is_empty());
    assert_eq!(violations(&[package("fsm-core", &["fsm-cli"])]).len(), 1);
    assert_eq!(violations(&[package("fsm-new", &[])]).len(), 1);
}
