//! The firmware cross-check as a Rust test: the ARM ELF decodes a row dump placed in RAM under
//! `qemu-system-arm -M xilinx-zynq-a9`, and the candidate file it writes must equal the host's
//! decode of the same dump byte for byte (BFSM, and EFSM with two groups; 32 rows of the mirror
//! scene, with interreflections). Then the protocol side: a recorded host session with one of
//! each kind of bad input, served by the device loop on the Cortex-A9, must be answered as
//! expected (an error for each bad input) and carry the same candidates. Then the real links:
//! the firmware serves the protocol on its UART (its own driver, QEMU's UART model, a TCP
//! socket on the host) and on its Ethernet (its GEM driver and smoltcp's TCP, QEMU's GEM model
//! on user networking, a forwarded port of 127.0.0.1), and the host's client scans through
//! each; the firmware must survive garbage and a host cut off mid-frame.
//!
//! Runs when `qemu-system-arm` is on PATH (or `$QEMU`) and the ARM ELF
//! (`$FW_ELF`, default `firmware/target/armv7a-none-eabihf/release/fsm-firmware`, built by
//! `scripts/build-arm.sh`) exists and is newer than every source it is built from (sources,
//! manifests, `build.rs`, the linker script, `Cargo.lock`); otherwise it prints `SKIP ...` on
//! stderr, uncaptured, and passes — unless `FW_REQUIRE_QEMU=1` (set by `.ci/run` and
//! `scripts/ci-arm.sh`, which build the ELF first): then a missing QEMU or a missing or stale
//! ELF fails the test.

use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{mpsc, Mutex};
use std::time::{Duration, Instant, SystemTime};

use fsm_core::{GroupCount, ScanPlan};
use fsm_firmware::scene::MirrorScene;
use fsm_firmware::{limits, reference, session};
use fsm_protocol::client::{Client, ClientError};
use fsm_protocol::{frame, DeviceError, Request, RequestKind, Response, RowOutput};

const ROWS: u32 = 32;
const WIDTH: u32 = 24;

/// One QEMU at a time: the tests of this file share the machine's cores.
static QEMU_LOCK: Mutex<()> = Mutex::new(());

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

/// The ELF to run, or `None` when the test is to be skipped (said on stderr); a missing QEMU
/// or ELF fails `test` instead when `FW_REQUIRE_QEMU=1`.
fn setup_or_skip(test: &str) -> Option<PathBuf> {
    match setup() {
        Ok((elf, _qemu)) => Some(elf),
        Err(why) if std::env::var_os("FW_REQUIRE_QEMU").is_some_and(|v| v == "1") => {
            panic!("FW_REQUIRE_QEMU=1, but {test} cannot run: {why}")
        }
        Err(why) => {
            say(&format!("SKIP {test}: {why}"));
            None
        }
    }
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
    let Some(elf) = setup_or_skip("firmware_under_qemu_matches_the_host_decode") else {
        return;
    };
    let _one = QEMU_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let dir = std::env::temp_dir().join(format!("fsm-qemu-crosscheck-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, plan) in [
        ("BFSM", ScanPlan::paper_bfsm()),
        ("EFSM two groups", ScanPlan::paper_efsm(GroupCount::Two)),
    ] {
        let dump = MirrorScene::for_plan(plan, WIDTH, ROWS).dump(plan);
        let host = reference::decode_dump(plan, &dump).unwrap();
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

        let script = session::script(plan, &dump, true).unwrap();
        let replies = run_firmware(&elf, &dir, None, &script.requests, "fw-link.bin");
        let carried = session::check_replies(&script, &replies)
            .unwrap_or_else(|e| panic!("{name}: the firmware's answers: {e}"));
        assert_eq!(carried, host, "{name}: candidates carried by the protocol");
        say(&format!(
            "ok   - {name}: protocol session on the Cortex-A9, {} requests ({} bad inputs refused), same candidates",
            script.expect.len(),
            session::BAD_INPUTS
        ));
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The camera's link to the host under QEMU.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Wire {
    /// UART1 (`run-qemu.sh --serve-uart`): the UART's bytes on a TCP port of 127.0.0.1.
    Uart,
    /// GEM0 and TCP/IP at 10.0.2.15:7070 (`run-qemu.sh --serve-net`): QEMU's user networking
    /// forwards a port of 127.0.0.1 to it.
    Ethernet,
}

impl Wire {
    fn option(self) -> &'static str {
        match self {
            Wire::Uart => "--serve-uart",
            Wire::Ethernet => "--serve-net",
        }
    }

    /// The console line the firmware prints once it serves on this link.
    fn ready_line(self) -> &'static str {
        match self {
            Wire::Uart => "SERVE UART1 ",
            Wire::Ethernet => "SERVE NET 10.0.2.15:7070 ",
        }
    }

    fn name(self) -> &'static str {
        match self {
            Wire::Uart => "the UART",
            Wire::Ethernet => "Ethernet",
        }
    }
}

/// The firmware serving the protocol on `wire` under QEMU, reached on a TCP port of
/// 127.0.0.1. QEMU is killed when this is dropped, a failed assertion included.
struct QemuCamera {
    qemu: Child,
    port: u16,
    wire: Wire,
    /// QEMU's console lines after the ready line (a panic report, say).
    console: mpsc::Receiver<String>,
}

impl QemuCamera {
    /// Starts QEMU and waits until the firmware says it serves: bytes sent before are lost
    /// (QEMU's UART model drops what arrives while RX is disabled, as the silicon does; TCP
    /// has no listener yet).
    fn start(elf: &Path, wire: Wire) -> QemuCamera {
        let started = Instant::now();
        // A free port (another process could take it before QEMU does: QEMU then fails and
        // says so below).
        let port = TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .expect("a free port")
            .port();
        let mut qemu = Command::new("bash")
            .arg(firmware_dir().join("scripts/run-qemu.sh"))
            .args([wire.option(), &port.to_string()])
            .arg(elf)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run-qemu.sh starts");
        let stdout = qemu.stdout.take().unwrap();
        let (tx, console) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut camera = QemuCamera {
            qemu,
            port,
            wire,
            console,
        };
        let deadline = Instant::now() + Duration::from_secs(30);
        let mut seen = String::new();
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match camera.console.recv_timeout(left) {
                Ok(line) if line.starts_with(wire.ready_line()) => {
                    say(&format!(
                        "ok   - firmware serving on {} at {} after {:.1} s",
                        wire.name(),
                        camera.url(),
                        started.elapsed().as_secs_f64()
                    ));
                    return camera;
                }
                Ok(line) => {
                    seen.push_str(&line);
                    seen.push('\n');
                }
                Err(e) => {
                    let _ = camera.qemu.kill();
                    let mut stderr = String::new();
                    if let Some(mut err) = camera.qemu.stderr.take() {
                        let _ = err.read_to_string(&mut stderr);
                    }
                    panic!(
                        "the firmware did not report {} ready ({e:?}):\n{seen}{stderr}",
                        wire.name()
                    );
                }
            }
        }
    }

    fn url(&self) -> String {
        format!("tcp://127.0.0.1:{}", self.port)
    }

    fn connect(&self) -> Client<Box<dyn fsm_protocol::transport::Link>> {
        Client::connect(&self.url(), Duration::from_secs(30))
            .unwrap_or_else(|e| panic!("{}: {e}{}", self.url(), self.console_tail()))
    }

    /// What QEMU printed since it got ready (the firmware prints nothing while serving: a
    /// line here is a panic or CPU exception report).
    fn console_tail(&self) -> String {
        let lines: Vec<String> = self.console.try_iter().collect();
        if lines.is_empty() {
            String::new()
        } else {
            format!("\nQEMU console:\n{}", lines.join("\n"))
        }
    }
}

impl Drop for QemuCamera {
    fn drop(&mut self) {
        // run-qemu.sh exec'd QEMU (no --timeout): the child is QEMU itself.
        let _ = self.qemu.kill();
        let _ = self.qemu.wait();
    }
}

/// Scans `rows` rows of the mirror scene through `client`; checks the candidates against the
/// host's decode, byte for byte. Returns the seconds the scan took (plan upload included).
/// Measured here: 27 to 54 kB/s up through QEMU's UART model (its 64-byte FIFO refilled by
/// QEMU's main loop), i.e. 4 to 5 EFSM or 1 to 1.5 BFSM rows of 24 pixels a second; a board
/// at 115,200 baud moves 11.5 kB/s. Ethernet's figures are QEMU's too, not a board's.
fn scan(
    camera: &QemuCamera,
    client: &mut Client<Box<dyn fsm_protocol::transport::Link>>,
    name: &str,
    plan: &ScanPlan,
    rows: u32,
) -> f64 {
    let dump = &MirrorScene::for_plan(plan, WIDTH, rows).dump(plan);
    let host = reference::decode_dump(plan, dump).unwrap();
    let mut received = Vec::new();
    let t = Instant::now();
    let summary = client
        .scan_dump(
            plan,
            dump,
            "scene.dump",
            RowOutput::Candidates,
            &mut received,
        )
        .unwrap_or_else(|e| {
            panic!(
                "{name}: scan over {}: {e}{}",
                camera.wire.name(),
                camera.console_tail()
            )
        });
    let secs = t.elapsed().as_secs_f64();
    if let Err(d) = reference::compare(&host, &received) {
        panic!(
            "{name}: firmware over {} and host candidates differ: {d}",
            camera.wire.name()
        );
    }
    assert_eq!(received, host);
    assert_eq!(summary.rows, rows);
    let census = reference::census(&host).unwrap();
    assert!(census.by_count[2] + census.by_count[3] > 0, "{census}");
    say(&format!(
        "ok   - {name} over {}: {rows} rows x {WIDTH} pixels bit-identical to the host decode; \
         {:.2} s, {:.1} rows/s, {:.0} bytes/s up (dump {} bytes), {} bytes of candidates down (QEMU's, not a board's)",
        camera.wire.name(),
        secs,
        rows as f64 / secs,
        dump.len() as f64 / secs,
        dump.len(),
        received.len()
    ));
    secs
}

/// What both links must do first: a fresh camera's info; the mirror scene scanned with the
/// two-group EFSM plan (`ROWS` rows) and BFSM (`bfsm_rows`), byte for byte; garbage between
/// delimiters refused as one bad frame, the camera still serving. Returns the client, with the
/// EFSM plan loaded, and that plan.
fn scans_and_garbage(
    camera: &QemuCamera,
    bfsm_rows: u32,
) -> (Client<Box<dyn fsm_protocol::transport::Link>>, ScanPlan) {
    let mut client = camera.connect();
    let info = client.hello().unwrap();
    assert_eq!(info.max_width as usize, limits::MAX_WIDTH);
    assert_eq!(info.candidate_capacity as usize, limits::CANDIDATE_CAPACITY);
    assert_eq!(info.plan_fingerprint, None);

    let efsm = ScanPlan::paper_efsm(GroupCount::Two);
    scan(camera, &mut client, "EFSM two groups", &efsm, ROWS);
    scan(
        camera,
        &mut client,
        "BFSM",
        &ScanPlan::paper_bfsm(),
        bfsm_rows,
    );
    client.upload_plan(efsm).unwrap();

    client
        .send_raw(RequestKind::Hello, &[0, 0xde, 0xad, 0xbe, 0xef, 0x17, 0])
        .unwrap();
    match client.receive(RequestKind::Hello).unwrap() {
        Response::Error(DeviceError::Frame(_)) => {}
        other => panic!("garbage answered with {other:?}"),
    }
    assert_eq!(
        client.hello().unwrap().plan_fingerprint,
        Some(efsm.fingerprint())
    );
    (client, efsm)
}

/// The first half of the frame that uploads `plan`: what a host cut off mid-request sent.
fn half_plan_upload(plan: &ScanPlan) -> Vec<u8> {
    let bytes = plan.to_bytes();
    let upload = frame::encode_vec(&Request::UploadPlan {
        plan: &bytes,
        fingerprint: plan.fingerprint(),
    })
    .unwrap();
    upload[..upload.len() / 2].to_vec()
}

#[test]
fn host_client_scans_through_the_firmware_uart_under_qemu() {
    let Some(elf) = setup_or_skip("host_client_scans_through_the_firmware_uart_under_qemu") else {
        return;
    };
    let _one = QEMU_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let camera = QemuCamera::start(&elf, Wire::Uart);
    // BFSM's rows are five times longer (770 frames): 8 rows keep the test under a minute.
    let (mut client, efsm) = scans_and_garbage(&camera, 8);

    // A host cut off inside a frame: half a plan upload, then the connection closes. The
    // UART cannot see the close. A host that comes at once finds the half frame ended by its
    // request's leading delimiter: a damaged frame, answered with an error before its own.
    let half = half_plan_upload(&efsm);
    client.send_raw(RequestKind::UploadPlan, &half).unwrap();
    drop(client);
    let mut client = camera.connect();
    match client.hello() {
        Err(ClientError::Device { request, message }) => {
            assert_eq!(request, RequestKind::Hello);
            assert!(message.contains("frame"), "{message}");
        }
        other => panic!("a half frame and then Hello: expected a frame error, got {other:?}"),
    }
    match client.receive(RequestKind::Hello).unwrap() {
        Response::Info(info) => assert_eq!(info.plan_fingerprint, Some(efsm.fingerprint())),
        other => panic!("Hello answered with {other:?}"),
    }
    // The frame time-out (2 s of silence inside a frame) ends the session and drops the half
    // frame: a host that comes later is answered as if nothing had happened.
    client.send_raw(RequestKind::UploadPlan, &half).unwrap();
    drop(client);
    std::thread::sleep(Duration::from_millis(3000));

    let mut client = camera.connect();
    let info = client
        .hello()
        .unwrap_or_else(|e| panic!("hello after a half frame: {e}{}", camera.console_tail()));
    assert_eq!(
        info.plan_fingerprint,
        Some(efsm.fingerprint()),
        "the plan stays loaded from one connection to the next"
    );
    scan(
        &camera,
        &mut client,
        "EFSM two groups, after garbage and a half frame",
        &efsm,
        8,
    );
    say("ok   - garbage refused, a half frame dropped after the frame time-out, the next host served");
    drop(client);
    let console = camera.console_tail();
    assert!(
        console.is_empty(),
        "the firmware printed while serving:{console}"
    );
}

#[test]
fn host_client_scans_through_the_firmware_ethernet_under_qemu() {
    let Some(elf) = setup_or_skip("host_client_scans_through_the_firmware_ethernet_under_qemu")
    else {
        return;
    };
    let _one = QEMU_LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let camera = QemuCamera::start(&elf, Wire::Ethernet);
    let (mut client, efsm) = scans_and_garbage(&camera, ROWS);

    // A host that leaves inside a frame: half a plan upload, then the connection closes.
    // Unlike a UART, TCP tells the firmware: the session ends with the half frame, and the
    // next connection is answered as if nothing had happened, with the plan still loaded.
    client
        .send_raw(RequestKind::UploadPlan, &half_plan_upload(&efsm))
        .unwrap();
    drop(client);
    let mut client = camera.connect();
    let info = client
        .hello()
        .unwrap_or_else(|e| panic!("hello after a half frame: {e}{}", camera.console_tail()));
    assert_eq!(info.plan_fingerprint, Some(efsm.fingerprint()));
    scan(
        &camera,
        &mut client,
        "EFSM two groups, after garbage and a half frame",
        &efsm,
        8,
    );
    say("ok   - garbage refused, a connection closed mid-frame, the next host served");
    drop(client);
    let console = camera.console_tail();
    assert!(
        console.is_empty(),
        "the firmware printed while serving:{console}"
    );
}
