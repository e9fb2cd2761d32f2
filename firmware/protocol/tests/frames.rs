//! Frames and messages: round trips, the documented tags, and rejection of every damaged frame
//! (property tests over arbitrary messages, damage and bytes).

use fsm_protocol::frame::{self, max_frame_len, FrameError, FrameReader};
use fsm_protocol::message::*;
use proptest::prelude::*;

/// Everything a message may hold, owned, so that strategies can make it.
#[derive(Clone, Debug)]
enum Owned {
    Request(u8, Vec<u8>, u64, u32, u32, u8, bool),
    Response(u8, Vec<u8>, u64, u32, String, u8),
}

fn with_message<R>(o: &Owned, f: impl FnOnce(&dyn Fn(&mut [u8]) -> usize, Checker) -> R) -> R {
    match o {
        Owned::Request(tag, bytes, fp, w, h, depth, raw) => {
            let request = match tag % 5 {
                0 => Request::Hello,
                1 => Request::UploadPlan {
                    plan: bytes,
                    fingerprint: *fp,
                },
                2 => Request::StartScan(ScanSpec {
                    fingerprint: *fp,
                    width: *w,
                    height: *h,
                    bit_depth: *depth,
                    output: if *raw {
                        RowOutput::Raw
                    } else {
                        RowOutput::Candidates
                    },
                }),
                3 => Request::Row { record: bytes },
                _ => Request::EndScan,
            };
            let enc = move |out: &mut [u8]| frame::encode(&request, out).unwrap();
            f(&enc, Checker::Request(request))
        }
        Owned::Response(tag, bytes, fp, n, text, small) => {
            let error = match small % 6 {
                0 => DeviceError::Frame(FrameError::Crc {
                    stored: *n,
                    computed: !*n,
                }),
                1 => DeviceError::PlanInvalid { reason: text },
                2 => DeviceError::RowLength {
                    row: (n % 2 == 0).then_some(*n),
                    expected: *n,
                    got: n.wrapping_add(1),
                },
                3 => DeviceError::PlanFingerprint {
                    stated: *fp,
                    computed: !*fp,
                },
                4 => DeviceError::ScanField {
                    field: text,
                    value: *n,
                },
                _ => DeviceError::State {
                    request: RequestKind::Row,
                    state: DeviceState::Idle,
                },
            };
            let response = match tag % 7 {
                0 => Response::Info(DeviceInfo {
                    protocol_version: *small,
                    max_width: *n,
                    max_row_samples: n.wrapping_mul(3),
                    max_table_floats: *n / 2,
                    candidate_capacity: *small as u16 * 3,
                    max_frame_len: *n,
                    plan_fingerprint: (fp % 2 == 0).then_some(*fp),
                }),
                1 => Response::PlanAccepted { fingerprint: *fp },
                2 => Response::ScanStarted { header: bytes },
                3 => Response::CandidateRow { record: bytes },
                4 => Response::RawRow { record: bytes },
                5 => Response::ScanEnded { rows: *n },
                _ => Response::Error(error),
            };
            let enc = move |out: &mut [u8]| frame::encode(&response, out).unwrap();
            f(&enc, Checker::Response(response))
        }
    }
}

#[derive(Debug)]
enum Checker<'a> {
    Request(Request<'a>),
    Response(Response<'a>),
}

impl Checker<'_> {
    fn check(&self, message: &[u8]) -> bool {
        match self {
            Checker::Request(r) => frame::decode::<Request>(message).as_ref() == Ok(r),
            Checker::Response(r) => frame::decode::<Response>(message).as_ref() == Ok(r),
        }
    }
}

fn owned() -> impl Strategy<Value = Owned> {
    let bytes = prop::collection::vec(any::<u8>(), 0..700);
    prop_oneof![
        (
            any::<u8>(),
            bytes.clone(),
            any::<u64>(),
            any::<u32>(),
            any::<u32>(),
            any::<u8>(),
            any::<bool>()
        )
            .prop_map(|(a, b, c, d, e, f, g)| Owned::Request(a, b, c, d, e, f, g)),
        (
            any::<u8>(),
            bytes,
            any::<u64>(),
            any::<u32>(),
            "[a-z_ ]{0,40}",
            any::<u8>()
        )
            .prop_map(|(a, b, c, d, e, f)| Owned::Response(a, b, c, d, e, f)),
    ]
}

/// Every frame the reader completes in `stream`, fed in chunks of `chunk` bytes.
fn frames(stream: &[u8], chunk: usize, capacity: usize) -> Vec<Result<Vec<u8>, FrameError>> {
    let mut reader = FrameReader::new(vec![0u8; capacity]);
    let mut out = Vec::new();
    for piece in stream.chunks(chunk.max(1)) {
        let mut at = 0;
        while at < piece.len() {
            let (taken, done) = reader.push(&piece[at..]);
            at += taken;
            match done {
                Some(Ok(())) => out.push(Ok(reader.message().to_vec())),
                Some(Err(e)) => out.push(Err(e)),
                None => {}
            }
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn messages_round_trip_in_any_chunking(o in owned(), chunk in 1usize..64) {
        with_message(&o, |encode, checker| {
            let mut buf = vec![0u8; 4096];
            let n = encode(&mut buf);
            let frame = &buf[..n];
            prop_assert_eq!(frame[0], 0);
            prop_assert_eq!(frame[n - 1], 0);
            prop_assert!(!frame[1..n - 1].contains(&0), "COBS leaves no zero inside a frame");
            let got = frames(frame, chunk, 4096);
            prop_assert_eq!(got.len(), 1);
            let message = got[0].as_ref().expect("frame checks");
            prop_assert!(checker.check(message), "decoded message differs");
            Ok(())
        })?;
    }

    #[test]
    fn a_flipped_bit_is_never_accepted(o in owned(), at in any::<prop::sample::Index>(), bit in 0u8..8) {
        with_message(&o, |encode, _| {
            let mut buf = vec![0u8; 4096];
            let n = encode(&mut buf);
            let mut frame = buf[..n].to_vec();
            // Damage the frame's content (not its delimiters).
            let i = 1 + at.index(n - 2);
            frame[i] ^= 1 << bit;
            for f in frames(&frame, 4096, 4096) {
                prop_assert!(f.is_err(), "damaged frame accepted: {:?}", f);
            }
            Ok(())
        })?;
    }

    #[test]
    fn a_truncated_frame_is_rejected_and_the_next_one_survives(
        o in owned(), cut in any::<prop::sample::Index>()
    ) {
        with_message(&o, |encode, checker| {
            let mut buf = vec![0u8; 4096];
            let n = encode(&mut buf);
            let frame = &buf[..n];
            // A frame cut short (between its leading delimiter and its end), then the whole
            // frame again: the first is rejected, the second decodes.
            // At least one content byte is lost (n - 1 would keep the whole content).
            let keep = 2 + cut.index(n - 3);
            let mut stream = frame[..keep].to_vec();
            stream.extend_from_slice(frame);
            let got = frames(&stream, 4096, 4096);
            prop_assert_eq!(got.len(), 2, "{:?}", got);
            prop_assert!(got[0].is_err());
            prop_assert!(checker.check(got[1].as_ref().expect("second frame checks")));
            Ok(())
        })?;
    }

    #[test]
    fn dropped_or_inserted_bytes_are_never_accepted(
        o in owned(), at in any::<prop::sample::Index>(), byte in 1u8..=255, insert in any::<bool>()
    ) {
        with_message(&o, |encode, _| {
            let mut buf = vec![0u8; 4096];
            let n = encode(&mut buf);
            let mut frame = buf[..n].to_vec();
            let i = 1 + at.index(n - 2);
            if insert {
                frame.insert(i, byte);
            } else {
                frame.remove(i);
            }
            for f in frames(&frame, 4096, 4096) {
                prop_assert!(f.is_err(), "damaged frame accepted: {:?}", f);
            }
            Ok(())
        })?;
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..2000), chunk in 1usize..300, cap in 1usize..600) {
        for f in frames(&bytes, chunk, cap).into_iter().flatten() {
            // Whatever checks must still decode safely (or be refused).
            let _ = frame::decode::<Request>(&f);
            let _ = frame::decode::<Response>(&f);
        }
    }

    #[test]
    fn arbitrary_message_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..300)) {
        let _ = frame::decode::<Request>(&bytes);
        let _ = frame::decode::<Response>(&bytes);
        // Wrapped in a valid frame (right CRC and version), arbitrary content is still either
        // a message or refused.
        let mut content = vec![fsm_protocol::PROTOCOL_VERSION];
        content.extend_from_slice(&bytes);
        let crc = fsm_core::wire::crc32(&content).to_le_bytes();
        content.extend_from_slice(&crc);
        let mut enc = vec![0u8; content.len() + content.len() / 254 + 2];
        let n = cobs::encode(&content, &mut enc);
        if let Ok(message) = frame::open(&mut enc[..n]) {
            prop_assert_eq!(message, &bytes[..]);
            let _ = frame::decode::<Request>(message);
            let _ = frame::decode::<Response>(message);
        }
    }

    #[test]
    fn frames_fit_their_bound(len in 0usize..3000) {
        let record = vec![0xA5u8; len];
        let mut buf = vec![0u8; max_frame_len(len + 8)];
        let n = frame::encode(&Request::Row { record: &record }, &mut buf).unwrap();
        prop_assert!(n <= buf.len());
        // One byte short of what it needs: refused, not truncated.
        let mut short = vec![0u8; n - 1];
        prop_assert_eq!(
            frame::encode(&Request::Row { record: &record }, &mut short),
            Err(FrameError::TooLong { limit: (n - 1) as u32 })
        );
    }
}

#[test]
fn wrong_version_is_refused() {
    let mut content = vec![fsm_protocol::PROTOCOL_VERSION + 1, 0];
    let crc = fsm_core::wire::crc32(&content).to_le_bytes();
    content.extend_from_slice(&crc);
    let mut enc = vec![0u8; 16];
    let n = cobs::encode(&content, &mut enc);
    assert_eq!(
        frame::open(&mut enc[..n]),
        Err(FrameError::Version {
            got: fsm_protocol::PROTOCOL_VERSION + 1,
            supported: fsm_protocol::PROTOCOL_VERSION
        })
    );
}

/// The tags of the crate docs' tables.
#[test]
fn documented_tags() {
    fn tag<T: serde::Serialize>(m: &T) -> u8 {
        let mut buf = [0u8; 256];
        let n = frame::encode(m, &mut buf).unwrap();
        let mut reader = FrameReader::new([0u8; 256]);
        let (_, lead) = reader.push(&buf[..n]);
        assert_eq!(lead, None);
        let (_, done) = reader.push(&buf[1..n]);
        assert_eq!(done, Some(Ok(())));
        reader.message()[0]
    }
    let spec = ScanSpec {
        fingerprint: 1,
        width: 2,
        height: 3,
        bit_depth: 12,
        output: RowOutput::Raw,
    };
    let requests = [
        Request::Hello,
        Request::UploadPlan {
            plan: &[1; 64],
            fingerprint: 5,
        },
        Request::StartScan(spec),
        Request::Row { record: &[1, 2] },
        Request::EndScan,
    ];
    for (i, r) in requests.iter().enumerate() {
        assert_eq!(tag(r) as usize, i, "{r:?}");
    }
    let info = DeviceInfo {
        protocol_version: 1,
        max_width: 1,
        max_row_samples: 1,
        max_table_floats: 1,
        candidate_capacity: 1,
        max_frame_len: 1,
        plan_fingerprint: None,
    };
    let responses = [
        Response::Info(info),
        Response::PlanAccepted { fingerprint: 1 },
        Response::ScanStarted { header: &[1] },
        Response::CandidateRow { record: &[1] },
        Response::RawRow { record: &[1] },
        Response::ScanEnded { rows: 1 },
        Response::Error(DeviceError::Frame(FrameError::Cobs)),
    ];
    for (i, r) in responses.iter().enumerate() {
        assert_eq!(tag(r) as usize, i, "{r:?}");
    }
    let errors = [
        DeviceError::Frame(FrameError::Message),
        DeviceError::State {
            request: RequestKind::Row,
            state: DeviceState::NoPlan,
        },
        DeviceError::PlanLength { got: 1 },
        DeviceError::PlanInvalid { reason: "x" },
        DeviceError::PlanFingerprint {
            stated: 1,
            computed: 2,
        },
        DeviceError::PlanTooLarge {
            table_floats: 1,
            max: 1,
        },
        DeviceError::PlanMismatch {
            requested: 1,
            loaded: 2,
        },
        DeviceError::ScanField {
            field: "width",
            value: 0,
        },
        DeviceError::ScanTooLarge {
            width: 1,
            frames: 1,
            max_width: 1,
            max_row_samples: 1,
        },
        DeviceError::RowLength {
            row: None,
            expected: 1,
            got: 2,
        },
        DeviceError::RowCorrupt {
            row: 1,
            stored: 1,
            computed: 2,
        },
        DeviceError::RowOutOfRange { row: 1, height: 1 },
        DeviceError::Decode {
            row: Some(1),
            reason: "x",
        },
    ];
    for (i, e) in errors.iter().enumerate() {
        let mut buf = [0u8; 256];
        let n = frame::encode(&Response::Error(*e), &mut buf).unwrap();
        let mut content = buf[1..n - 1].to_vec();
        let len = cobs::decode_in_place(&mut content).unwrap();
        // version, Response tag 6, then the error's tag.
        assert_eq!(&content[..3], &[1, 6, i as u8], "{e:?} (len {len})");
    }
    let frame_errors = [
        FrameError::TooLong { limit: 1 },
        FrameError::Cobs,
        FrameError::TooShort { len: 1 },
        FrameError::Crc {
            stored: 1,
            computed: 2,
        },
        FrameError::Version {
            got: 2,
            supported: 1,
        },
        FrameError::Message,
    ];
    for (i, e) in frame_errors.iter().enumerate() {
        let mut buf = [0u8; 16];
        let bytes = postcard::to_slice(e, &mut buf).unwrap();
        assert_eq!(bytes[0] as usize, i, "{e:?}");
    }
}

/// `fsm camera info` prints a camera's limits as `DeviceInfo`'s `Display`, a line per field;
/// `fsm upload` its alternate form, one line.
#[test]
fn device_info_prints_a_line_per_field() {
    let mut info = DeviceInfo {
        protocol_version: 1,
        max_width: 2048,
        max_row_samples: 1 << 20,
        max_table_floats: 65536,
        candidate_capacity: 8,
        max_frame_len: 4200,
        plan_fingerprint: Some(0xab),
    };
    let text = info.to_string();
    assert_eq!(text.lines().count(), 7, "{text}");
    assert!(text.starts_with("protocol version   1\nmax pixels per row 2048\n"));
    assert!(text.contains("\ncandidates/pixel   8\n"), "{text}");
    assert!(
        text.ends_with("loaded plan        00000000000000ab"),
        "{text}"
    );
    info.plan_fingerprint = None;
    assert!(info.to_string().ends_with("loaded plan        none"));
    assert_eq!(
        format!("{info:#}"),
        "camera protocol 1, up to 2048 pixels per row, 8 candidates per pixel"
    );
}

/// A conversation with a camera that fails names the camera: `fsm upload` and `fsm camera`
/// print the error as it is. (Port 1 of the loopback address has no listener.)
#[cfg(feature = "std")]
#[test]
fn a_device_names_itself_in_its_errors() {
    use fsm_protocol::client::Device;
    let device = Device::new("tcp://127.0.0.1:1", std::time::Duration::from_secs(2));
    let e = device.info().unwrap_err().to_string();
    assert!(e.starts_with("tcp://127.0.0.1:1: connecting to"), "{e}");
    let missing = std::path::Path::new("no-such-dump.fsmd");
    let plan = fsm_core::ScanPlan::paper_bfsm();
    let output = RowOutput::Candidates;
    let e = device.scan_dump_file(plan, missing, output, &mut Vec::new());
    let e = e.unwrap_err().to_string();
    assert!(
        e.starts_with("tcp://127.0.0.1:1: reading no-such-dump.fsmd: "),
        "{e}"
    );
}

/// `fsm camera scan` ends with a line of what the camera answered.
#[cfg(feature = "std")]
#[test]
fn a_scan_summary_says_what_was_scanned() {
    use fsm_protocol::client::{Device, ScanSummary};
    let device = Device::new("tcp://10.0.0.5:7070", std::time::Duration::from_secs(1));
    let summary = ScanSummary {
        fingerprint: 0xab,
        rows: 480,
        bytes: 123_456,
    };
    let (dump, out) = (
        std::path::Path::new("scan.dump"),
        std::path::Path::new("c.fsmc"),
    );
    assert_eq!(
        summary.report(&device, dump, out),
        "tcp://10.0.0.5:7070: 480 rows of scan.dump scanned (plan 00000000000000ab), 123456 bytes -> c.fsmc"
    );
}
