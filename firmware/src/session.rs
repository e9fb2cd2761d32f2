//! A recorded host ⇄ camera session (host only): the request frames a host sends to scan a
//! row dump — with, on request, one of each kind of bad input first — and the check of the
//! camera's recorded answers, which rebuilds the candidate file from them.
//!
//! This is how the protocol side of the firmware runs under QEMU without a network: the
//! request stream is placed in RAM, the firmware answers into a semihosting file
//! (`fw-link.bin`), and [`check_replies`] reads that file.

use fsm_core::wire::row_dump::RowDumpHeader;
use fsm_core::wire::HEADER_LEN;
use fsm_core::MethodPlan;
use fsm_protocol::frame::{self, FrameReader};
use fsm_protocol::{Request, Response, RowOutput, ScanSpec};

/// What the camera must answer to one request.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Expect {
    /// `Info`.
    Info,
    /// `PlanAccepted` with this fingerprint.
    PlanAccepted(u64),
    /// An `Error` whose `Debug` form starts with this (e.g. `RowLength { row: Some(1)`).
    Error(String),
    /// `ScanStarted` (its header starts the candidate file).
    ScanStarted,
    /// `CandidateRow` (appended to the candidate file).
    CandidateRow,
    /// `ScanEnded` with this many rows.
    ScanEnded(u32),
}

/// The request frames of a session and what each must be answered with.
#[derive(Clone, Debug)]
pub struct Script {
    /// Every request frame, in order.
    pub requests: Vec<u8>,
    /// One entry per request.
    pub expect: Vec<Expect>,
}

impl Script {
    fn send(&mut self, request: &Request<'_>, expect: Expect) {
        self.requests
            .extend(frame::encode_vec(request).expect("request encodes"));
        self.expect.push(expect);
    }

    fn send_bytes(&mut self, bytes: &[u8], expect: Expect) {
        self.requests.extend_from_slice(bytes);
        self.expect.push(expect);
    }
}

/// Bad inputs a session with `bad_input` sends, each answered with an error.
pub const BAD_INPUTS: u32 = 6;

/// The session that scans `dump` with `plan` (any method's); with `bad_input`, first a row
/// before any plan, a plan with a wrong fingerprint, a plan with a reserved byte set, a
/// corrupted frame, a row of the wrong length and a row with a bad CRC ([`BAD_INPUTS`]), each
/// of which must be answered with an error.
pub fn script(plan: impl Into<MethodPlan>, dump: &[u8], bad_input: bool) -> Result<Script, String> {
    let plan: MethodPlan = plan.into();
    let header = RowDumpHeader::decode(dump).map_err(|e| e.to_string())?;
    plan.check_row_dump(&header).map_err(|e| e.to_string())?;
    let len = header.record_len().ok_or("row dump: rows too large")?;
    let body = &dump[HEADER_LEN..];
    if body.is_empty() || !body.len().is_multiple_of(len) {
        return Err(format!(
            "row dump: {} bytes of records is not a whole, non-zero number of {len}-byte records",
            body.len()
        ));
    }
    let records: Vec<&[u8]> = body.chunks_exact(len).collect();
    let plan_bytes = plan.to_bytes();
    let fingerprint = plan.fingerprint();
    let mut s = Script {
        requests: Vec::new(),
        expect: Vec::new(),
    };
    s.send(&Request::Hello, Expect::Info);
    if bad_input {
        s.send(
            &Request::Row { record: records[0] },
            Expect::Error("State { request: Row, state: NoPlan }".into()),
        );
        s.send(
            &Request::UploadPlan {
                plan: &plan_bytes,
                fingerprint: fingerprint ^ 0x8000,
            },
            Expect::Error(format!(
                "PlanFingerprint {{ stated: {}, computed: {fingerprint} }}",
                fingerprint ^ 0x8000
            )),
        );
        // Every method's plan ends with reserved bytes, which must be 0.
        let mut reserved = plan_bytes.to_vec();
        *reserved.last_mut().expect("plan bytes") = 1;
        s.send(
            &Request::UploadPlan {
                plan: &reserved,
                fingerprint,
            },
            Expect::Error("PlanInvalid { reason: \"".into()),
        );
        let mut corrupted = frame::encode_vec(&Request::UploadPlan {
            plan: &plan_bytes,
            fingerprint,
        })
        .expect("request encodes");
        let at = corrupted.len() / 2;
        corrupted[at] ^= 0x04;
        s.send_bytes(&corrupted, Expect::Error("Frame(".into()));
    }
    s.send(
        &Request::UploadPlan {
            plan: &plan_bytes,
            fingerprint,
        },
        Expect::PlanAccepted(fingerprint),
    );
    let spec = ScanSpec {
        fingerprint,
        width: header.width,
        height: header.height,
        bit_depth: header.bit_depth,
        output: RowOutput::Candidates,
    };
    s.send(&Request::StartScan(spec), Expect::ScanStarted);
    if bad_input {
        let short = &records[0][..len - 1];
        s.send(
            &Request::Row { record: short },
            Expect::Error(format!(
                "RowLength {{ row: Some(0), expected: {len}, got: {} }}",
                len - 1
            )),
        );
        let mut damaged = records[0].to_vec();
        damaged[4] ^= 0x01;
        s.send(
            &Request::Row { record: &damaged },
            Expect::Error("RowCorrupt { row: 0,".into()),
        );
    }
    for r in &records {
        s.send(&Request::Row { record: r }, Expect::CandidateRow);
    }
    s.send(&Request::EndScan, Expect::ScanEnded(records.len() as u32));
    Ok(s)
}

/// Checks the recorded answers against the script; returns the candidate file they carry
/// (the `ScanStarted` header and every `CandidateRow` record).
pub fn check_replies(script: &Script, replies: &[u8]) -> Result<Vec<u8>, String> {
    let mut reader = FrameReader::new(vec![0u8; replies.len().max(1)]);
    let mut at = 0;
    let mut candidates = Vec::new();
    let mut n = 0;
    while at < replies.len() {
        let (taken, done) = reader.push(&replies[at..]);
        at += taken;
        let Some(done) = done else { continue };
        done.map_err(|e| format!("answer {n}: {e}"))?;
        let response: Response =
            frame::decode(reader.message()).map_err(|e| format!("answer {n}: {e}"))?;
        let expect = script
            .expect
            .get(n)
            .ok_or_else(|| format!("answer {n}: more answers than requests ({response:?})"))?;
        let fits = match (expect, &response) {
            (Expect::Info, Response::Info(_)) => true,
            (Expect::PlanAccepted(f), Response::PlanAccepted { fingerprint }) => f == fingerprint,
            (Expect::Error(prefix), Response::Error(e)) => format!("{e:?}").starts_with(prefix),
            (Expect::ScanStarted, Response::ScanStarted { header }) => {
                candidates.extend_from_slice(header);
                true
            }
            (Expect::CandidateRow, Response::CandidateRow { record }) => {
                candidates.extend_from_slice(record);
                true
            }
            (Expect::ScanEnded(rows), Response::ScanEnded { rows: got }) => rows == got,
            _ => false,
        };
        if !fits {
            return Err(format!(
                "answer {n}: expected {expect:?}, the camera answered {response:?}"
            ));
        }
        n += 1;
    }
    if reader.pending() != 0 {
        return Err(format!(
            "the answers end inside a frame ({} bytes)",
            reader.pending()
        ));
    }
    if n != script.expect.len() {
        return Err(format!("{n} answers to {} requests", script.expect.len()));
    }
    Ok(candidates)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::{Device, Replay};
    use crate::memory::HostStorage;
    use crate::reference;
    use crate::scene::MirrorScene;
    use fsm_core::{GroupCount, LineScanPlan, ScanPlan};

    /// The recorded session, replayed through the device on the host, gives the host's
    /// candidates; a wrong answer is caught.
    #[test]
    fn replayed_session_gives_the_host_candidates() {
        let plan = ScanPlan::paper_efsm(GroupCount::One);
        let dump = MirrorScene::for_plan(plan, 10, 3).dump(plan);
        let s = script(plan, &dump, true).unwrap();
        let mut storage = HostStorage::default();
        let mut device = Device::new(storage.memory());
        let mut link = Replay::new(&s.requests, Vec::new());
        let report = device.serve(&mut link).unwrap();
        assert_eq!(report.errors, BAD_INPUTS);
        assert_eq!(report.rows, 3);
        let candidates = check_replies(&s, &link.output).unwrap();
        assert_eq!(candidates, reference::decode_dump(plan, &dump).unwrap());

        // The answers of another session do not pass.
        let plain = script(plan, &dump, false).unwrap();
        let e = check_replies(&plain, &link.output).unwrap_err();
        assert!(e.starts_with("answer 1: expected PlanAccepted"), "{e}");
        // Nor do truncated answers.
        let e = check_replies(&s, &link.output[..link.output.len() - 3]).unwrap_err();
        assert!(e.contains("end inside a frame"), "{e}");
    }

    /// A baseline's session too: its plan uploaded, its rows decoded as the host decodes them.
    #[test]
    fn a_baselines_session_gives_the_host_candidates() {
        let plan = LineScanPlan {
            projector_columns: 48,
            ..LineScanPlan::paper()
        };
        let dump = MirrorScene::for_plan(plan, 12, 3).dump(plan);
        let s = script(plan, &dump, true).unwrap();
        let mut storage = HostStorage::default();
        let mut device = Device::new(storage.memory());
        let mut link = Replay::new(&s.requests, Vec::new());
        let report = device.serve(&mut link).unwrap();
        assert_eq!((report.errors, report.rows), (BAD_INPUTS, 3));
        let candidates = check_replies(&s, &link.output).unwrap();
        let host = reference::decode_dump(plan, &dump).unwrap();
        assert_eq!(candidates, host);
        assert!(reference::census(&host).unwrap().by_count[1] > 0);
    }
}
