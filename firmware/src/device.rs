//! The camera's side of the link: requests in, one response each out (`fsm-protocol`).
//!
//! The camera takes a plan of any method (`fsm_core::MethodPlan`: BFSM, EFSM or a baseline
//! the paper compares them with) and decodes its rows into the same candidate records.
//!
//! [`Device::serve`] reads bytes from a [`Link`] until it closes, answers every frame, and
//! never gives up on bad input: a damaged frame, a plan whose fingerprint does not match its
//! bytes, a row of the wrong length or with a bad CRC is answered with
//! [`Response::Error`] and nothing of it is applied. The loaded plan survives the link (a new
//! connection finds it in place); a scan does not.

use core::fmt::Write as _;

use fsm_core::methods::wire::PLAN_LENGTHS;
use fsm_core::{MethodDecoder, MethodPlan};
use fsm_protocol::frame::{self, FrameReader};
use fsm_protocol::{
    DeviceError, DeviceInfo, DeviceState, Request, Response, RowOutput, PROTOCOL_VERSION,
};

use crate::batch::Sink;
use crate::limits::{CANDIDATE_CAPACITY, LANES, MAX_ROW_SAMPLES};
use crate::memory::Memory;
use crate::scan::{self, NoProbe, RowBuffers, RowFailure, Scan, ScanError};

/// What the device waits for when it reads: a link may give up on a half-sent frame sooner
/// than on a quiet host, and hand the camera to another host only between frames.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Waiting {
    /// The start of the next request: no frame is half received.
    NextFrame,
    /// The rest of a frame whose first bytes arrived.
    RestOfFrame,
}

/// A byte stream to the host (TCP in the emulator, a UART or a replayed stream on the target).
pub trait Link {
    /// The link's error.
    type Error;
    /// Reads at least one byte, or returns 0 when the link is closed. An error (a time-out
    /// included) ends [`Device::serve`]; the loaded plan stays, the scan does not.
    fn read(&mut self, buf: &mut [u8], waiting: Waiting) -> Result<usize, Self::Error>;
    /// Sends all of `bytes`.
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), Self::Error>;
}

/// A recorded request stream as the link: reads come from `input` (e.g. frames placed in RAM
/// by QEMU's loader), responses go to a [`Sink`] (e.g. a semihosting file).
pub struct Replay<'a, S> {
    input: &'a [u8],
    at: usize,
    /// Where the responses went.
    pub output: S,
}

impl<'a, S> Replay<'a, S> {
    /// Replays `input`, answering into `output`.
    pub fn new(input: &'a [u8], output: S) -> Self {
        Replay {
            input,
            at: 0,
            output,
        }
    }
}

impl<S: Sink> Link for Replay<'_, S> {
    type Error = S::Error;

    fn read(&mut self, buf: &mut [u8], _: Waiting) -> Result<usize, S::Error> {
        let n = buf.len().min(self.input.len() - self.at);
        buf[..n].copy_from_slice(&self.input[self.at..self.at + n]);
        self.at += n;
        Ok(n)
    }

    fn write_all(&mut self, bytes: &[u8]) -> Result<(), S::Error> {
        self.output.write(bytes)
    }
}

/// What one served link saw.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SessionReport {
    /// Frames received (well-formed or not).
    pub requests: u32,
    /// Requests answered with an error.
    pub errors: u32,
    /// Rows answered with a record.
    pub rows: u32,
}

/// The camera: its buffers and its loaded plan.
pub struct Device<'m> {
    memory: Memory<'m>,
    plan: Option<MethodPlan>,
}

/// Sizes of the buffers, for checks and for [`DeviceInfo`].
#[derive(Clone, Copy)]
struct Capacity {
    tables: usize,
    scratch: usize,
    samples: usize,
    width: usize,
    frame: usize,
}

/// What a request leads to.
enum Outcome<'r> {
    Reply(Response<'r>),
    /// A valid plan to load; the reply follows once its tables are built.
    Load(MethodPlan),
}

impl<'m> Device<'m> {
    /// A camera with these buffers and no plan.
    pub fn new(memory: Memory<'m>) -> Self {
        Device { memory, plan: None }
    }

    /// The loaded plan.
    pub fn plan(&self) -> Option<&MethodPlan> {
        self.plan.as_ref()
    }

    fn capacity(&self) -> Capacity {
        let m = &self.memory;
        Capacity {
            tables: m.tables.len(),
            scratch: m.scratch.len(),
            // A row arrives whole in `rx` (a raw row leaves whole from `record`); only a
            // slice of it is unpacked into `samples` (`scan::decode_row`).
            samples: (m.record.len().saturating_sub(8) / 2).min(MAX_ROW_SAMPLES),
            width: m.pixels.len(),
            // The leading delimiter is an empty frame; the buffer holds the rest but the end.
            frame: m.rx.len() + 2,
        }
    }

    /// What [`Request::Hello`] is answered with.
    pub fn info(&self) -> DeviceInfo {
        info(&self.capacity(), self.plan.as_ref())
    }

    /// Serves `link` until it closes (returns what it saw) or fails (returns its error).
    pub fn serve<L: Link>(&mut self, link: &mut L) -> Result<SessionReport, L::Error> {
        let capacity = self.capacity();
        let Memory {
            tables,
            scratch,
            samples,
            pixels,
            record,
            rx,
            tx,
        } = &mut self.memory;
        let plan = &mut self.plan;
        let mut reader = FrameReader::new(&mut **rx);
        let mut chunk = [0u8; 512];
        let (mut at, mut len) = (0usize, 0usize);
        let mut session: Option<Session> = None;
        let mut report = SessionReport::default();
        let mut loaded: Option<u64> = None;
        loop {
            // The decoder of the loaded plan borrows the tables until the next plan is loaded.
            // Tables already built for this plan (an earlier connection) are reused as they are.
            if let Some(p) = *plan {
                if MethodDecoder::from_tables(&p, &tables[..]).is_err() {
                    let _ = p.build_tables(&mut tables[..]);
                }
            }
            let decoder = match *plan {
                Some(p) => match MethodDecoder::from_tables(&p, &tables[..]) {
                    Ok(d) => Some(d),
                    Err(e) => {
                        // Cannot happen for a plan that passed `check_plan`; refuse it anyway.
                        *plan = None;
                        if loaded.take().is_some() {
                            let mut text = Text::new();
                            let _ = write!(text, "{e}");
                            let error = DeviceError::PlanInvalid { reason: &text };
                            report.errors += 1;
                            send(link, tx, &Response::Error(error))?;
                        }
                        None
                    }
                },
                None => None,
            };
            if let Some(fingerprint) = loaded.take() {
                send(link, tx, &Response::PlanAccepted { fingerprint })?;
            }
            let next = loop {
                if at == len {
                    at = 0;
                    let waiting = if reader.in_frame() {
                        Waiting::RestOfFrame
                    } else {
                        Waiting::NextFrame
                    };
                    len = link.read(&mut chunk, waiting)?;
                    if len == 0 {
                        return Ok(report);
                    }
                }
                let (taken, done) = reader.push(&chunk[at..len]);
                at += taken;
                let Some(done) = done else { continue };
                report.requests += 1;
                let mut text = Text::new();
                let request = done.and_then(|()| frame::decode::<Request>(reader.message()));
                let outcome = match request {
                    Err(e) => Outcome::Reply(Response::Error(DeviceError::Frame(e))),
                    Ok(request) => {
                        let mut work = RowBuffers {
                            scratch: &mut scratch[..],
                            samples: &mut samples[..],
                            pixels: &mut pixels[..],
                        };
                        handle(
                            request,
                            decoder.as_ref(),
                            &mut session,
                            &capacity,
                            &mut work,
                            &mut record[..],
                            &mut text,
                        )
                    }
                };
                match outcome {
                    Outcome::Reply(response) => {
                        match response {
                            Response::Error(_) => report.errors += 1,
                            Response::CandidateRow { .. } | Response::RawRow { .. } => {
                                report.rows += 1
                            }
                            _ => {}
                        }
                        send(link, tx, &response)?;
                    }
                    Outcome::Load(p) => break p,
                }
            };
            loaded = Some(next.fingerprint());
            *plan = Some(next);
        }
    }
}

/// Room for an error message from `fsm_core`.
type Text = heapless::String<192>;

fn info(capacity: &Capacity, plan: Option<&MethodPlan>) -> DeviceInfo {
    DeviceInfo {
        protocol_version: PROTOCOL_VERSION,
        max_width: capacity.width as u32,
        max_row_samples: capacity.samples as u32,
        max_table_floats: capacity.tables as u32,
        candidate_capacity: CANDIDATE_CAPACITY as u16,
        max_frame_len: capacity.frame as u32,
        plan_fingerprint: plan.map(MethodPlan::fingerprint),
    }
}

/// A running scan: its geometry, what it sends back, how many rows it answered.
#[derive(Clone, Copy, Debug)]
struct Session {
    scan: Scan,
    output: RowOutput,
    answered: u32,
}

fn state(decoder: Option<&MethodDecoder<'_>>, session: &Option<Session>) -> DeviceState {
    match (decoder, session) {
        (None, _) => DeviceState::NoPlan,
        (Some(_), None) => DeviceState::Idle,
        (Some(_), Some(_)) => DeviceState::Scanning,
    }
}

/// Checks uploaded plan bytes of any method: length, validity, canonical form, the stated
/// fingerprint, and that the camera's buffers hold its tables and scratch (a baseline needs
/// neither).
fn check_plan<'r>(
    bytes: &[u8],
    stated: u64,
    capacity: &Capacity,
    text: &'r mut Text,
) -> Result<MethodPlan, DeviceError<'r>> {
    if !PLAN_LENGTHS.contains(&bytes.len()) {
        return Err(DeviceError::PlanLength {
            got: bytes.len() as u32,
        });
    }
    let plan = match MethodPlan::from_bytes(bytes) {
        Ok(p) => p,
        Err(e) => {
            let _ = write!(text, "{e}");
            return Err(DeviceError::PlanInvalid { reason: text });
        }
    };
    if plan.to_bytes()[..] != bytes[..] {
        return Err(DeviceError::PlanInvalid {
            reason: "plan: bytes are not in canonical form",
        });
    }
    let computed = plan.fingerprint();
    if computed != stated {
        return Err(DeviceError::PlanFingerprint { stated, computed });
    }
    let tables = plan.tables_len();
    if tables > capacity.tables {
        return Err(DeviceError::PlanTooLarge {
            table_floats: tables as u32,
            max: capacity.tables as u32,
        });
    }
    let scratch = plan.scratch_len_lanes::<LANES>();
    if scratch > capacity.scratch {
        let _ = write!(
            text,
            "plan: decoder scratch of {scratch} floats, the camera has {}",
            capacity.scratch
        );
        return Err(DeviceError::PlanInvalid { reason: text });
    }
    Ok(plan)
}

/// The protocol's error for a refused row; messages go to `text`.
fn row_error<'r>(e: RowFailure, text: &'r mut Text) -> DeviceError<'r> {
    use fsm_core::wire::WireError;
    match e {
        RowFailure::Length { row, expected, got } => DeviceError::RowLength {
            row,
            expected: expected as u32,
            got: got as u32,
        },
        RowFailure::Wire(WireError::RecordCrc {
            row,
            stored,
            computed,
            ..
        }) => DeviceError::RowCorrupt {
            row,
            stored,
            computed,
        },
        RowFailure::Wire(WireError::RowOutOfRange { row, height, .. }) => {
            DeviceError::RowOutOfRange { row, height }
        }
        RowFailure::Wire(other) => {
            let _ = write!(text, "{other}");
            DeviceError::Decode {
                row: None,
                reason: text,
            }
        }
        RowFailure::Decode { row, error } => {
            let _ = write!(text, "{error}");
            DeviceError::Decode {
                row: Some(row),
                reason: text,
            }
        }
        RowFailure::Output { row, error } => {
            let _ = write!(text, "{error}");
            DeviceError::Decode {
                row: Some(row),
                reason: text,
            }
        }
    }
}

fn handle<'r>(
    request: Request<'_>,
    decoder: Option<&MethodDecoder<'_>>,
    session: &mut Option<Session>,
    capacity: &Capacity,
    work: &mut RowBuffers<'_>,
    record: &'r mut [u8],
    text: &'r mut Text,
) -> Outcome<'r> {
    let refuse = |e| Outcome::Reply(Response::Error(e));
    let wrong_state = DeviceError::State {
        request: request.kind(),
        state: state(decoder, session),
    };
    match request {
        Request::Hello => {
            let plan = decoder.map(MethodDecoder::plan);
            Outcome::Reply(Response::Info(info(capacity, plan.as_ref())))
        }
        Request::UploadPlan { plan, fingerprint } => {
            if session.is_some() {
                return refuse(wrong_state);
            }
            match check_plan(plan, fingerprint, capacity, text) {
                Ok(plan) => Outcome::Load(plan),
                Err(e) => refuse(e),
            }
        }
        Request::StartScan(spec) => {
            let (Some(decoder), None) = (decoder, &session) else {
                return refuse(wrong_state);
            };
            let plan = decoder.plan();
            let loaded = plan.fingerprint();
            if spec.fingerprint != loaded {
                return refuse(DeviceError::PlanMismatch {
                    requested: spec.fingerprint,
                    loaded,
                });
            }
            let too_large = DeviceError::ScanTooLarge {
                width: spec.width,
                frames: plan.frame_count() as u32,
                max_width: capacity.width as u32,
                max_row_samples: capacity.samples as u32,
            };
            let scan = match Scan::new(plan, spec.width, spec.height, spec.bit_depth) {
                Ok(s)
                    if s.rows.width as usize <= capacity.width
                        && s.rows.samples_per_row() <= capacity.samples
                        && s.record_len() <= record.len() =>
                {
                    s
                }
                Ok(_) | Err(ScanError::TooLarge { .. }) => return refuse(too_large),
                Err(ScanError::Field { field, value }) => {
                    return refuse(DeviceError::ScanField { field, value })
                }
            };
            let header = match spec.output {
                RowOutput::Candidates => scan.candidates.encode(),
                RowOutput::Raw => scan.rows.encode(),
            };
            *session = Some(Session {
                scan,
                output: spec.output,
                answered: 0,
            });
            record[..header.len()].copy_from_slice(&header);
            Outcome::Reply(Response::ScanStarted {
                header: &record[..header.len()],
            })
        }
        Request::Row { record: input } => {
            let (Some(decoder), Some(s)) = (decoder, session.as_mut()) else {
                return refuse(wrong_state);
            };
            let result = match s.output {
                RowOutput::Candidates => {
                    scan::decode_row(decoder, &s.scan, input, work, record, &mut NoProbe)
                }
                RowOutput::Raw => scan::raw_row(&s.scan, input, record),
            };
            match result {
                Ok((_, len)) => {
                    s.answered += 1;
                    let record = &record[..len];
                    Outcome::Reply(match s.output {
                        RowOutput::Candidates => Response::CandidateRow { record },
                        RowOutput::Raw => Response::RawRow { record },
                    })
                }
                Err(e) => refuse(row_error(e, text)),
            }
        }
        Request::EndScan => match session.take() {
            Some(s) => Outcome::Reply(Response::ScanEnded { rows: s.answered }),
            None => refuse(wrong_state),
        },
    }
}

/// Sends `response`; one that does not fit the frame buffer (none does not, with the
/// buffers of `limits`) is replaced by an error saying so.
fn send<L: Link>(link: &mut L, tx: &mut [u8], response: &Response<'_>) -> Result<(), L::Error> {
    let n = match frame::encode(response, tx) {
        Ok(n) => n,
        Err(e) => {
            let error = Response::Error(DeviceError::Frame(e));
            match frame::encode(&error, tx) {
                Ok(n) => n,
                Err(_) => return Ok(()),
            }
        }
    };
    link.write_all(&tx[..n])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::memory::HostStorage;
    use fsm_core::{Decoder, GroupCount, ScanPlan};
    use fsm_protocol::frame::FrameReader;

    /// Answers of a device with `tables` floats of table memory to `requests`.
    fn answers(tables: usize, requests: &[Request<'_>]) -> Vec<String> {
        let mut storage = HostStorage::default();
        let mut m = storage.memory();
        m.tables = &mut m.tables[..tables];
        let mut device = Device::new(m);
        let mut input = Vec::new();
        for r in requests {
            input.extend(frame::encode_vec(r).unwrap());
        }
        let mut link = Replay::new(&input, Vec::new());
        device.serve(&mut link).unwrap();
        let mut reader = FrameReader::new(vec![0u8; 1 << 16]);
        let mut out = Vec::new();
        let mut at = 0;
        while at < link.output.len() {
            let (taken, done) = reader.push(&link.output[at..]);
            at += taken;
            if let Some(done) = done {
                done.unwrap();
                let r: Response = frame::decode(reader.message()).unwrap();
                out.push(format!("{r:?}"));
            }
        }
        out
    }

    #[test]
    fn a_plan_whose_tables_do_not_fit_is_refused_and_the_old_one_kept() {
        let small = ScanPlan::paper_efsm(GroupCount::One);
        let big = ScanPlan::paper_bfsm();
        let (sb, bb) = (small.to_bytes(), big.to_bytes());
        let room = Decoder::tables_len(&small);
        assert!(Decoder::tables_len(&big) > room);
        let got = answers(
            room,
            &[
                Request::UploadPlan {
                    plan: &sb,
                    fingerprint: small.fingerprint(),
                },
                Request::UploadPlan {
                    plan: &bb,
                    fingerprint: big.fingerprint(),
                },
                Request::Hello,
            ],
        );
        assert_eq!(
            got[0],
            format!(
                "{:?}",
                Response::PlanAccepted {
                    fingerprint: small.fingerprint()
                }
            )
        );
        assert_eq!(
            got[1],
            format!(
                "{:?}",
                Response::Error(DeviceError::PlanTooLarge {
                    table_floats: Decoder::tables_len(&big) as u32,
                    max: room as u32
                })
            )
        );
        assert!(
            got[2].contains(&format!("plan_fingerprint: Some({})", small.fingerprint())),
            "{}",
            got[2]
        );
    }
}
