//! The camera emulator (the firmware loop behind TCP on 127.0.0.1, or a serial port) driven by
//! the host's client library: upload a plan, scan the rows of a dump, receive the candidate
//! rows, and compare them with the host's decode of the same dump, byte for byte. Then every
//! kind of bad input, each answered with an error while the camera keeps serving.

use std::time::Duration;

use fsm_core::wire::candidates::{self, CandidateHeader};
use fsm_core::wire::row_dump::{self, RowDumpHeader};
use fsm_core::wire::HEADER_LEN;
use fsm_core::{
    CodeEnsemblePlan, GroupCount, LineScanPlan, MethodPlan, MicroPhaseShiftPlan, PhaseShiftPlan,
    ScanPlan,
};
use fsm_firmware::emulator::{self, Emulator};
use fsm_firmware::limits;
use fsm_firmware::reference;
use fsm_firmware::scene::MirrorScene;
use fsm_protocol::client::{Client, ClientError};
use fsm_protocol::frame::{self, FrameError};
use fsm_protocol::{DeviceError, DeviceState, Request, RequestKind, Response, RowOutput, ScanSpec};

const TIMEOUT: Duration = Duration::from_secs(60);

fn scan_and_compare(
    client: &mut Client<impl std::io::Read + std::io::Write>,
    plan: &ScanPlan,
    dump: &[u8],
) {
    let mut received = Vec::new();
    let summary = client
        .scan_dump(
            plan,
            dump,
            "scene.dump",
            RowOutput::Candidates,
            &mut received,
        )
        .expect("scan through the camera");
    let expected = reference::decode_dump(plan, dump).expect("host decode");
    if let Err(d) = reference::compare(&expected, &received) {
        panic!("camera and host differ: {d}");
    }
    assert_eq!(received, expected);
    assert_eq!(summary.fingerprint, plan.fingerprint());
    assert_eq!(summary.bytes, expected.len() as u64);
    // Candidates were found at all (the comparison is not one of empty files).
    let census = reference::census(&received).unwrap();
    assert!(census.by_count[2] + census.by_count[3] > 0, "{census}");
}

#[test]
fn scans_through_the_emulator_match_the_host_decode() {
    let camera = Emulator::spawn("127.0.0.1:0").unwrap();
    let mut client = Client::connect(&camera.url(), TIMEOUT).unwrap();
    let info = client.hello().unwrap();
    assert_eq!(info.max_width as usize, limits::MAX_WIDTH);
    assert_eq!(info.max_row_samples as usize, limits::MAX_ROW_SAMPLES);
    assert_eq!(info.candidate_capacity as usize, limits::CANDIDATE_CAPACITY);
    assert_eq!(info.plan_fingerprint, None);
    for plan in [
        ScanPlan::paper_bfsm(),
        ScanPlan::paper_efsm(GroupCount::Two),
    ] {
        let dump = MirrorScene::for_plan(plan, 24, 4).dump(plan);
        scan_and_compare(&mut client, &plan, &dump);

        // Raw rows for host-side decode: the camera streams back exactly the dump.
        let mut raw = Vec::new();
        client
            .scan_dump(plan, &dump, "scene.dump", RowOutput::Raw, &mut raw)
            .unwrap();
        assert_eq!(raw, dump);
    }
    // The plan stays loaded for the next connection.
    drop(client);
    let mut again = Client::connect(&camera.url(), TIMEOUT).unwrap();
    assert_eq!(
        again.hello().unwrap().plan_fingerprint,
        Some(ScanPlan::paper_efsm(GroupCount::Two).fingerprint())
    );
}

#[test]
fn every_baselines_plan_uploads_and_scans_through_the_emulator() {
    let camera = Emulator::spawn("127.0.0.1:0").unwrap();
    let mut client = Client::connect(&camera.url(), TIMEOUT).unwrap();
    let plans: [MethodPlan; 4] = [
        PhaseShiftPlan::for_projector(96).into(),
        MicroPhaseShiftPlan::spread(96, 16.0, 4.0, 7).into(),
        LineScanPlan {
            projector_columns: 96,
            ..LineScanPlan::paper()
        }
        .into(),
        CodeEnsemblePlan::for_projector(96).into(),
    ];
    for plan in plans {
        let dump = MirrorScene::for_plan(plan, 20, 3).dump(plan);
        let mut received = Vec::new();
        let summary = client
            .scan_dump(
                plan,
                &dump,
                "scene.dump",
                RowOutput::Candidates,
                &mut received,
            )
            .unwrap_or_else(|e| panic!("{}: {e}", plan.name()));
        let expected = reference::decode_dump(plan, &dump).unwrap();
        if let Err(d) = reference::compare(&expected, &received) {
            panic!("{}: camera and host differ: {d}", plan.name());
        }
        assert_eq!(received, expected);
        assert_eq!(summary.fingerprint, plan.fingerprint());
        let header = CandidateHeader::decode(&received).unwrap();
        assert_eq!(header.plan_fingerprint, plan.fingerprint());
        let census = reference::census(&received).unwrap();
        assert!(census.by_count[1..].iter().sum::<usize>() > 0, "{census}");
        assert_eq!(
            client.hello().unwrap().plan_fingerprint,
            Some(plan.fingerprint())
        );
        // Raw rows: the camera streams back exactly the dump.
        let mut raw = Vec::new();
        client
            .scan_dump(plan, &dump, "scene.dump", RowOutput::Raw, &mut raw)
            .unwrap();
        assert_eq!(raw, dump);
    }

    // A baseline plan that breaks its rules is refused naming the field, the loaded one kept.
    let loaded = client.hello().unwrap().plan_fingerprint;
    let bad = PhaseShiftPlan {
        steps: 2,
        ..PhaseShiftPlan::for_projector(96)
    };
    let bytes = bad.to_bytes();
    let e = answer(
        &mut client,
        &Request::UploadPlan {
            plan: &bytes,
            fingerprint: bad.fingerprint(),
        },
    );
    assert!(e.starts_with("PlanInvalid") && e.contains("steps"), "{e}");
    // Bytes of no method's length, and a baseline's bytes with an unknown tag.
    let e = answer(
        &mut client,
        &Request::UploadPlan {
            plan: &bytes[..31],
            fingerprint: 0,
        },
    );
    assert_eq!(e, format!("{:?}", DeviceError::PlanLength { got: 31 }));
    let mut untagged = bytes;
    untagged[..2].copy_from_slice(b"XX");
    let e = answer(
        &mut client,
        &Request::UploadPlan {
            plan: &untagged,
            fingerprint: 0,
        },
    );
    assert!(e.starts_with("PlanInvalid") && e.contains("tag"), "{e}");
    assert_eq!(client.hello().unwrap().plan_fingerprint, loaded);
    // A scan that names another plan than the baseline loaded is refused.
    let e = answer(
        &mut client,
        &Request::StartScan(ScanSpec {
            fingerprint: ScanPlan::paper_bfsm().fingerprint(),
            width: 4,
            height: 1,
            bit_depth: 12,
            output: RowOutput::Candidates,
        }),
    );
    assert!(e.starts_with("PlanMismatch"), "{e}");
}

/// The error the camera answers `request` with (sent as raw bytes).
fn answer_to_bytes<L: std::io::Read + std::io::Write>(
    client: &mut Client<L>,
    kind: RequestKind,
    bytes: &[u8],
) -> String {
    client.send_raw(kind, bytes).unwrap();
    match client.receive(kind).unwrap() {
        Response::Error(e) => format!("{e:?}"),
        other => panic!("expected an error, got {other:?}"),
    }
}

fn answer<L: std::io::Read + std::io::Write>(
    client: &mut Client<L>,
    request: &Request<'_>,
) -> String {
    match client.request(request).unwrap() {
        Response::Error(e) => format!("{e:?}"),
        other => panic!("expected an error to {request:?}, got {other:?}"),
    }
}

#[test]
fn bad_input_is_answered_with_an_error_and_the_camera_keeps_serving() {
    let camera = Emulator::spawn("127.0.0.1:0").unwrap();
    let mut c = Client::connect(&camera.url(), TIMEOUT).unwrap();
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let other = ScanPlan::paper_efsm(GroupCount::One);
    let scene = MirrorScene::for_plan(plan, 12, 3);
    let dump = scene.dump(plan);
    let header = RowDumpHeader::decode(&dump).unwrap();
    let record_len = header.record_len().unwrap();
    let record = |y: usize| &dump[HEADER_LEN + y * record_len..HEADER_LEN + (y + 1) * record_len];

    // A row before any plan.
    let e = answer(&mut c, &Request::Row { record: record(0) });
    assert_eq!(
        e,
        format!(
            "{:?}",
            DeviceError::State {
                request: RequestKind::Row,
                state: DeviceState::NoPlan
            }
        )
    );

    // A plan whose stated fingerprint is not the one of its bytes: refused, not loaded.
    let bytes = plan.to_bytes();
    let e = answer(
        &mut c,
        &Request::UploadPlan {
            plan: &bytes,
            fingerprint: plan.fingerprint() ^ 1,
        },
    );
    assert_eq!(
        e,
        format!(
            "{:?}",
            DeviceError::PlanFingerprint {
                stated: plan.fingerprint() ^ 1,
                computed: plan.fingerprint()
            }
        )
    );
    assert_eq!(c.hello().unwrap().plan_fingerprint, None);
    // The client's upload names the refusal.
    let mut tampered = plan.to_bytes();
    // levels.amplitude 0.5 -> 0.4: a different, still valid plan.
    tampered[28..32].copy_from_slice(&0.4f32.to_le_bytes());
    let e = answer(
        &mut c,
        &Request::UploadPlan {
            plan: &tampered,
            fingerprint: plan.fingerprint(),
        },
    );
    assert!(e.starts_with("PlanFingerprint"), "{e}");

    // Plan bytes of the wrong length, and bytes that are no valid plan.
    let e = answer(
        &mut c,
        &Request::UploadPlan {
            plan: &bytes[..63],
            fingerprint: plan.fingerprint(),
        },
    );
    assert_eq!(e, format!("{:?}", DeviceError::PlanLength { got: 63 }));
    let mut invalid = plan.to_bytes();
    invalid[33] = 7; // window
    let e = answer(
        &mut c,
        &Request::UploadPlan {
            plan: &invalid,
            fingerprint: 0,
        },
    );
    assert!(e.contains("PlanInvalid") && e.contains("window"), "{e}");
    assert_eq!(c.hello().unwrap().plan_fingerprint, None);

    // The right plan is accepted and acknowledged with its fingerprint.
    assert_eq!(c.upload_plan(plan).unwrap(), plan.fingerprint());

    // A corrupted frame (a plan upload with one bit flipped) is refused and not applied.
    let other_bytes = other.to_bytes();
    let mut framed = frame::encode_vec(&Request::UploadPlan {
        plan: &other_bytes,
        fingerprint: other.fingerprint(),
    })
    .unwrap();
    let at = framed.len() / 2;
    framed[at] ^= 0x10;
    let e = answer_to_bytes(&mut c, RequestKind::UploadPlan, &framed);
    assert!(
        e.starts_with("Frame(Crc") || e.starts_with("Frame(Cobs"),
        "{e}"
    );
    assert_eq!(
        c.hello().unwrap().plan_fingerprint,
        Some(plan.fingerprint()),
        "the corrupted upload changed the plan"
    );
    // A truncated frame: refused; the next frame is served.
    let whole = frame::encode_vec(&Request::Hello).unwrap();
    let mut cut = whole[..whole.len() - 3].to_vec();
    cut.push(0);
    let e = answer_to_bytes(&mut c, RequestKind::Hello, &cut);
    assert!(e.starts_with("Frame("), "{e}");
    // Garbage without a delimiter longer than the receive buffer, then a delimiter.
    let mut garbage = vec![0x5Au8; limits::MAX_REQUEST_FRAME + 100];
    garbage.push(0);
    let e = answer_to_bytes(&mut c, RequestKind::Hello, &garbage);
    assert_eq!(
        e,
        format!(
            "{:?}",
            DeviceError::Frame(FrameError::TooLong {
                limit: limits::MAX_REQUEST_FRAME as u32
            })
        )
    );
    // A frame of another protocol version.
    let mut content = vec![fsm_protocol::PROTOCOL_VERSION + 1, 0];
    content.extend_from_slice(&fsm_core::wire::crc32(&content.clone()).to_le_bytes());
    let mut enc = vec![0u8; 16];
    let n = cobs::encode(&content, &mut enc);
    enc.truncate(n);
    enc.push(0);
    let e = answer_to_bytes(&mut c, RequestKind::Hello, &enc);
    assert!(e.starts_with("Frame(Version"), "{e}");

    // A scan of another plan is refused; this plan's scan starts.
    let spec = ScanSpec {
        fingerprint: other.fingerprint(),
        width: header.width,
        height: header.height,
        bit_depth: header.bit_depth,
        output: RowOutput::Candidates,
    };
    let e = answer(&mut c, &Request::StartScan(spec));
    assert!(e.starts_with("PlanMismatch"), "{e}");
    let e = answer(
        &mut c,
        &Request::StartScan(ScanSpec {
            fingerprint: plan.fingerprint(),
            width: 0,
            ..spec
        }),
    );
    assert!(e.contains("ScanField") && e.contains("width"), "{e}");
    let e = answer(
        &mut c,
        &Request::StartScan(ScanSpec {
            fingerprint: plan.fingerprint(),
            width: limits::MAX_WIDTH as u32 + 1,
            ..spec
        }),
    );
    assert!(e.starts_with("ScanTooLarge"), "{e}");
    let head = c
        .start_scan(&ScanSpec {
            fingerprint: plan.fingerprint(),
            ..spec
        })
        .unwrap();
    let cand_header = CandidateHeader::decode(&head).unwrap();

    // A row of the wrong length: the error names the row.
    let short = &record(1)[..record_len - 2];
    let e = answer(&mut c, &Request::Row { record: short });
    assert_eq!(
        e,
        format!(
            "{:?}",
            DeviceError::RowLength {
                row: Some(1),
                expected: record_len as u32,
                got: record_len as u32 - 2
            }
        )
    );
    // A row whose samples were damaged (its CRC no longer matches).
    let mut damaged = record(2).to_vec();
    damaged[100] ^= 1;
    let e = answer(&mut c, &Request::Row { record: &damaged });
    assert!(e.starts_with("RowCorrupt { row: 2"), "{e}");
    // A row past the scan's height (a well-formed record of a taller scan).
    let tall = RowDumpHeader {
        height: 10,
        ..header
    };
    let r = row_dump::decode_record(&header, record(0)).unwrap();
    let mut samples = vec![0u16; r.len()];
    r.copy_to(&mut samples).unwrap();
    let mut outside = vec![0u8; record_len];
    row_dump::encode_record(&tall, 7, &samples, &mut outside).unwrap();
    let e = answer(&mut c, &Request::Row { record: &outside });
    assert_eq!(
        e,
        format!("{:?}", DeviceError::RowOutOfRange { row: 7, height: 3 })
    );
    // A plan upload during the scan.
    let e = answer(
        &mut c,
        &Request::UploadPlan {
            plan: &other_bytes,
            fingerprint: other.fingerprint(),
        },
    );
    assert!(e.contains("Scanning"), "{e}");

    // After all that, rows decode exactly as on the host.
    let expected = reference::decode_dump(plan, &dump).unwrap();
    let mut at = HEADER_LEN;
    for y in 0..3 {
        let got = c.send_row(record(y)).unwrap().to_vec();
        let want = candidates::decode_record(&cand_header, &expected[at..]).unwrap();
        assert_eq!(got, expected[at..at + want.len]);
        at += want.len;
    }
    assert_eq!(c.end_scan().unwrap(), 3);
    let e = answer(&mut c, &Request::EndScan);
    assert!(e.contains("Idle"), "{e}");
    // And a whole scan through the high-level call still matches.
    scan_and_compare(&mut c, &plan, &dump);
    // The client reports the camera's refusals as errors that name them.
    let err = c
        .start_scan(&ScanSpec {
            fingerprint: 42,
            ..spec
        })
        .unwrap_err();
    assert!(
        matches!(
            err,
            ClientError::Device {
                request: RequestKind::StartScan,
                ..
            }
        ),
        "{err}"
    );
    assert!(
        err.to_string().contains("plan 000000000000002a requested"),
        "{err}"
    );
}

/// The same camera behind a serial port (a pseudo-terminal pair), reached by its path.
#[test]
fn serial_port_link() {
    use serialport::{SerialPort, TTYPort};
    let (master, slave) = match TTYPort::pair() {
        Ok(p) => p,
        Err(e) => {
            eprintln!("SKIP serial_port_link: no pseudo-terminal ({e})");
            return;
        }
    };
    let path = slave.name().expect("pty path");
    let mut master = master;
    master.set_timeout(emulator::POLL).unwrap();
    let timeouts = emulator::Timeouts {
        idle: None,
        ..emulator::Timeouts::default()
    };
    let server = std::thread::spawn(move || emulator::serve_stream(master, timeouts));
    let mut client = Client::connect(&format!("{path}@115200"), TIMEOUT).unwrap();
    drop(slave);
    let plan = ScanPlan::paper_efsm(GroupCount::One);
    let dump = MirrorScene::for_plan(plan, 16, 2).dump(plan);
    scan_and_compare(&mut client, &plan, &dump);
    drop(client);
    // The camera side sees the port close (an I/O error on a pty) and returns.
    let _ = server.join().unwrap();
}
