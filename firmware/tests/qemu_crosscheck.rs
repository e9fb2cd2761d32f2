//! The firmware cross-check as a Rust test: the ARM ELF decodes a row dump placed in RAM under
//! `qemu-system-arm -M xilinx-zynq-a9`, and the candidate file it writes must equal the host's
//! decode of the same dump byte for byte (BFSM, and EFSM with two groups; 32 rows of the mirror
//! scene, with interreflections). Then the protocol side: a recorded host session with one of
//! each kind of bad input, served by the device loop on the Cortex-A9, must be answered as
//! expected (an error for each bad input) and carry the same candidates.
//!
//! Runs when `qemu-system-arm` is on PATH (or `$QEMU`) and the ARM ELF
//! (`$FW_ELF`, default `firmware/target/armv7a-none-eabihf/release/fsm-firmware`, built by
//! `scripts/build-arm.sh`) exists and is newer than every source it is built from (sources,
//! manifests, `build.rs`, the linker script, `Cargo.lock`); otherwise it prints `SKIP ...` on
//! stderr, uncaptured, and passes — unless `FW_REQUIRE_QEMU=1` (set by `.ci/run` and
//! `scripts/ci-arm.sh`, which build the ELF first): then a missing QEMU or a missing or stale
//! ELF fails the test.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::SystemTime;

use fsm_core::{GroupCount, ScanPlan};
use fsm_firmware::reference;
use fsm_firmware::scene::MirrorScene;
use fsm_firmware::session;

const ROWS: u32 = 32;
const WIDTH: u32 = 24;

fn firmware_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Writes past the test harness's capture, so that a skip is visible in `cargo test`.
fn say(msg: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{msg}");
}

/// The newest of `paths`: files given count whatever their name, files inside folders given
/// when they are Rust sources, manifests or linker scripts.
fn newest_source(paths: &[PathBuf]) -> (SystemTime, PathBuf) {
    let mut newest = (SystemTime::UNIX_EPOCH, PathBuf::new());
    let mut stack: Vec<(PathBuf, bool)> = paths.iter().map(|p| (p.clone(), true)).collect();
    while let Some((p, given)) = stack.pop() {
        let Ok(meta) = std::fs::metadata(&p) else {
            continue;
        };
        if meta.is_dir() {
            if let Ok(entries) = std::fs::read_dir(&p) {
                stack.extend(entries.flatten().map(|e| (e.path(), false)));
            }
        } else if given
            || matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("rs" | "toml" | "x")
            )
        {
            if let Ok(t) = meta.modified() {
                if t > newest.0 {
                    newest = (t, p);
                }
            }
        }
    }
    newest
}

/// The ELF and QEMU to use, or why the test cannot run here.
fn setup() -> Result<(PathBuf, String), String> {
    let qemu = std::env::var("QEMU").unwrap_or_else(|_| "qemu-system-arm".into());
    match Command::new(&qemu).arg("--version").output() {
        Ok(o) if o.status.success() => {}
        _ => {
            return Err(format!(
                "{qemu} not found (firmware/scripts/install-toolchain.sh installs it)"
            ))
        }
    }
    let fw = firmware_dir();
    let elf = std::env::var_os("FW_ELF")
        .map(PathBuf::from)
        .unwrap_or_else(|| fw.join("target/armv7a-none-eabihf/release/fsm-firmware"));
    let built = std::fs::metadata(&elf)
        .and_then(|m| m.modified())
        .map_err(|_| {
            format!(
                "no ARM build at {} (run firmware/scripts/build-arm.sh)",
                elf.display()
            )
        })?;
    let root = fw.parent().expect("firmware/ is in the workspace");
    let core = root.join("core");
    let (newest, path) = newest_source(&[
        fw.join("src"),
        fw.join("Cargo.toml"),
        fw.join("build.rs"),
        fw.join("link.x"),
        root.join("Cargo.lock"),
        root.join("Cargo.toml"),
        fw.join("protocol/src"),
        fw.join("protocol/Cargo.toml"),
        core.join("src"),
        core.join("Cargo.toml"),
    ]);
    if newest > built {
        return Err(format!(
            "the ARM build {} is older than {} (run firmware/scripts/build-arm.sh)",
            elf.display(),
            path.display()
        ));
    }
    Ok((elf, qemu))
}

/// Runs the firmware on `input` (with `plan` in the mailbox, if given); returns the file
/// `output` it wrote.
fn run_firmware(
    elf: &Path,
    dir: &Path,
    plan: Option<&ScanPlan>,
    input: &[u8],
    output: &str,
) -> Vec<u8> {
    std::fs::write(dir.join("input.bin"), input).unwrap();
    let _ = std::fs::remove_file(dir.join(output));
    let mut qemu = Command::new("bash");
    qemu.arg(firmware_dir().join("scripts/run-qemu.sh"))
        .args(["--timeout", "300"]);
    if let Some(plan) = plan {
        std::fs::write(dir.join("plan.bin"), plan.to_bytes()).unwrap();
        qemu.args(["--plan", "plan.bin"]);
    }
    let out = qemu
        .arg(elf)
        .arg("input.bin")
        .current_dir(dir)
        .output()
        .expect("run-qemu.sh runs");
    let console = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "firmware failed ({}):\n{console}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    std::fs::read(dir.join(output)).unwrap_or_else(|e| panic!("no {output} ({e}):\n{console}"))
}

#[test]
fn firmware_under_qemu_matches_the_host_decode() {
    let (elf, _qemu) = match setup() {
        Ok(s) => s,
        Err(why) if std::env::var_os("FW_REQUIRE_QEMU").is_some_and(|v| v == "1") => {
            panic!("FW_REQUIRE_QEMU=1, but the cross-check cannot run: {why}")
        }
        Err(why) => {
            say(&format!(
                "SKIP firmware_under_qemu_matches_the_host_decode: {why}"
            ));
            return;
        }
    };
    let dir = std::env::temp_dir().join(format!("fsm-qemu-crosscheck-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, plan) in [
        ("BFSM", ScanPlan::paper_bfsm()),
        ("EFSM two groups", ScanPlan::paper_efsm(GroupCount::Two)),
    ] {
        let dump = MirrorScene::for_plan(&plan, WIDTH, ROWS).dump(&plan);
        let host = reference::decode_dump(&plan, &dump).unwrap();
        let firmware = run_firmware(&elf, &dir, Some(&plan), &dump, "fw-candidates.bin");
        if let Err(d) = reference::compare(&host, &firmware) {
            panic!("{name}: firmware (Cortex-A9) and host candidates differ: {d}");
        }
        assert_eq!(firmware, host);
        let census = reference::census(&host).unwrap();
        assert!(census.by_count[2] + census.by_count[3] > 0, "{census}");
        say(&format!(
            "ok   - {name}: firmware (Cortex-A9, QEMU) and host candidates bit-identical, {} bytes; {census}",
            host.len()
        ));

        let script = session::script(&plan, &dump, true).unwrap();
        let replies = run_firmware(&elf, &dir, None, &script.requests, "fw-link.bin");
        let carried = session::check_replies(&script, &replies)
            .unwrap_or_else(|e| panic!("{name}: the firmware's answers: {e}"));
        assert_eq!(carried, host, "{name}: candidates carried by the protocol");
        say(&format!(
            "ok   - {name}: protocol session on the Cortex-A9, {} requests (5 bad inputs refused), same candidates",
            script.expect.len()
        ));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
