//! The camera's protocol loop under arbitrary input (property tests): it never panics, answers
//! every frame it receives with exactly one response, and applies nothing a damaged frame or
//! a refused request carried.

use std::sync::Mutex;

use fsm_core::wire::HEADER_LEN;
use fsm_core::{GroupCount, ScanPlan};
use fsm_firmware::device::{Device, Replay};
use fsm_firmware::memory::HostStorage;
use fsm_firmware::scene::MirrorScene;
use fsm_protocol::frame::{self, FrameReader};
use fsm_protocol::{Request, Response, RowOutput, ScanSpec};
use proptest::prelude::*;

/// One set of camera buffers (15 MB) shared by the cases.
static STORAGE: Mutex<Option<HostStorage>> = Mutex::new(None);

/// Serves `input` with a fresh camera; returns every response, as `Debug` text.
fn serve(input: &[u8]) -> Vec<String> {
    let mut guard = STORAGE.lock().unwrap_or_else(|e| e.into_inner());
    let storage = guard.get_or_insert_with(HostStorage::default);
    let mut device = Device::new(storage.memory());
    let mut link = Replay::new(input, Vec::new());
    let report = device.serve(&mut link).unwrap();
    let mut reader = FrameReader::new(vec![0u8; link.output.len() + 1]);
    let mut out = Vec::new();
    let mut at = 0;
    while at < link.output.len() {
        let (taken, done) = reader.push(&link.output[at..]);
        at += taken;
        if let Some(done) = done {
            done.expect("the camera's frames check");
            let r: Response = frame::decode(reader.message()).expect("a response");
            out.push(format!("{r:?}"));
        }
    }
    assert_eq!(out.len() as u32, report.requests);
    out
}

/// Frames (non-empty) a receiver sees in `bytes`.
fn frames_in(bytes: &[u8]) -> usize {
    let mut reader = FrameReader::new(vec![0u8; bytes.len() + 1]);
    let (mut at, mut n) = (0, 0);
    while at < bytes.len() {
        let (taken, done) = reader.push(&bytes[at..]);
        at += taken;
        n += done.is_some() as usize;
    }
    n
}

/// A request made from arbitrary parts.
fn request(kind: u8, bytes: &[u8], fingerprint: u64, w: u32, h: u32, depth: u8) -> Request<'_> {
    match kind % 5 {
        0 => Request::Hello,
        1 => Request::UploadPlan {
            plan: bytes,
            fingerprint,
        },
        2 => Request::StartScan(ScanSpec {
            fingerprint,
            width: w,
            height: h,
            bit_depth: depth,
            output: if w.is_multiple_of(2) {
                RowOutput::Candidates
            } else {
                RowOutput::Raw
            },
        }),
        3 => Request::Row { record: bytes },
        _ => Request::EndScan,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn arbitrary_bytes_get_one_answer_per_frame(bytes in prop::collection::vec(any::<u8>(), 0..3000)) {
        let answers = serve(&bytes);
        prop_assert_eq!(answers.len(), frames_in(&bytes));
        for a in &answers {
            prop_assert!(a.starts_with("Error(Frame("), "{}", a);
        }
    }

    #[test]
    fn arbitrary_requests_get_one_answer_each(
        parts in prop::collection::vec(
            (any::<u8>(), prop::collection::vec(any::<u8>(), 0..200), any::<u64>(), 0u32..40, 0u32..5, 0u8..18),
            1..12
        )
    ) {
        let mut input = Vec::new();
        for (kind, bytes, fp, w, h, d) in &parts {
            input.extend(frame::encode_vec(&request(*kind, bytes, *fp, *w, *h, *d)).unwrap());
        }
        let answers = serve(&input);
        prop_assert_eq!(answers.len(), parts.len());
        // Random plan bytes are never accepted (a valid plan with a matching CRC-64 is
        // astronomically unlikely), so nothing that needs a plan succeeds.
        for a in &answers {
            prop_assert!(a.starts_with("Info") || a.starts_with("Error("), "{}", a);
        }
    }

    /// With a real plan and scan, rows of arbitrary length or content are refused, and the
    /// right row still decodes afterwards.
    #[test]
    fn arbitrary_rows_in_a_real_scan(rows in prop::collection::vec(prop::collection::vec(any::<u8>(), 0..3000), 1..4)) {
        let plan = ScanPlan::paper_efsm(GroupCount::One);
        let dump = MirrorScene::for_plan(plan, 8, 2).dump(plan);
        let len = (dump.len() - HEADER_LEN) / 2;
        let good = &dump[HEADER_LEN..HEADER_LEN + len];
        let bytes = plan.to_bytes();
        let mut input = Vec::new();
        let mut push = |r: &Request<'_>| input.extend(frame::encode_vec(r).unwrap());
        push(&Request::UploadPlan { plan: &bytes, fingerprint: plan.fingerprint() });
        push(&Request::StartScan(ScanSpec {
            fingerprint: plan.fingerprint(), width: 8, height: 2, bit_depth: 12,
            output: RowOutput::Candidates,
        }));
        for r in &rows {
            push(&Request::Row { record: r });
        }
        push(&Request::Row { record: good });
        let answers = serve(&input);
        prop_assert_eq!(answers.len(), rows.len() + 3);
        prop_assert!(answers[0].starts_with("PlanAccepted"));
        prop_assert!(answers[1].starts_with("ScanStarted"));
        for a in &answers[2..2 + rows.len()] {
            prop_assert!(a.starts_with("Error(Row"), "{}", a);
        }
        prop_assert!(answers[rows.len() + 2].starts_with("CandidateRow"));
    }
}
