//! The messages: what the host asks ([`Request`]) and what the camera answers ([`Response`]).
//!
//! Every request gets exactly one response, in order. Byte fields borrow from the received
//! frame, so neither side copies a row to read it. The byte layouts of plans, row-dump records
//! and candidate records are `fsm_core::wire`'s: this protocol only carries them.

use core::fmt;

use serde::{Deserialize, Serialize};

use crate::frame::FrameError;

/// What the host sends.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Request<'a> {
    /// Who are you and how much can you take? Answered by [`Response::Info`].
    Hello,
    /// Load a plan of any method: its canonical bytes (`MethodPlan::to_bytes`: an FSM plan's
    /// 80, a baseline's 32 or 96) and the fingerprint the host computed
    /// (`MethodPlan::fingerprint`). The camera recomputes the fingerprint from the bytes it
    /// received and loads the plan only if the two agree; answered by
    /// [`Response::PlanAccepted`] with that fingerprint. A rejected plan leaves the loaded one
    /// in place.
    UploadPlan {
        /// `MethodPlan::to_bytes()`: 80 bytes (FSM), 32 or 96 (the baselines).
        plan: &'a [u8],
        /// `MethodPlan::fingerprint()` of those bytes, as the host computed it.
        fingerprint: u64,
    },
    /// Start a scan with the loaded plan; answered by [`Response::ScanStarted`].
    StartScan(ScanSpec),
    /// One temporal row, as the sensor delivers it: a `fsm_core::wire::row_dump` record
    /// (row index, `W·M` samples, CRC) of the scan's geometry. Answered by
    /// [`Response::CandidateRow`] or [`Response::RawRow`] (see [`RowOutput`]).
    Row {
        /// The row-dump record.
        record: &'a [u8],
    },
    /// End the scan; answered by [`Response::ScanEnded`].
    EndScan,
}

/// The scan the host starts: the rows that will follow and what the camera sends back.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScanSpec {
    /// Fingerprint of the plan the rows were captured with; must be the loaded plan's.
    pub fingerprint: u64,
    /// Pixels per row `W`.
    pub width: u32,
    /// Rows in the scan `H`.
    pub height: u32,
    /// Sensor bit depth, 1–16.
    pub bit_depth: u8,
    /// Candidates (decoded on the camera) or raw rows (decoded by the host).
    pub output: RowOutput,
}

/// What the camera sends for each row.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum RowOutput {
    /// Candidate records (`fsm_core::wire::candidates`), decoded on the camera.
    Candidates,
    /// Row-dump records (`fsm_core::wire::row_dump`), for decoding on the host.
    Raw,
}

/// What the camera sends.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Response<'a> {
    /// Answer to [`Request::Hello`].
    Info(DeviceInfo),
    /// The plan is loaded; its fingerprint as the camera computed it.
    PlanAccepted {
        /// CRC-64 of the plan bytes the camera received.
        fingerprint: u64,
    },
    /// The scan started. `header` is the 64-byte header of the stream that follows:
    /// `CandidateHeader` for [`RowOutput::Candidates`], `RowDumpHeader` for [`RowOutput::Raw`],
    /// so header + records is a complete candidate file or row dump.
    ScanStarted {
        /// The 64 header bytes.
        header: &'a [u8],
    },
    /// The candidates of one row: a `fsm_core::wire::candidates` record.
    CandidateRow {
        /// The candidate record.
        record: &'a [u8],
    },
    /// One raw row: a `fsm_core::wire::row_dump` record.
    RawRow {
        /// The row-dump record.
        record: &'a [u8],
    },
    /// The scan ended after this many rows were answered.
    ScanEnded {
        /// Rows answered with a [`Response::CandidateRow`] or [`Response::RawRow`].
        rows: u32,
    },
    /// The request was refused; nothing it asked for was applied.
    Error(DeviceError<'a>),
}

/// What the camera can do: its limits, set by its statically sized buffers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct DeviceInfo {
    /// [`crate::PROTOCOL_VERSION`] of the camera.
    pub protocol_version: u8,
    /// Most pixels per row.
    pub max_width: u32,
    /// Most samples per row, `W·M` (frames times pixels).
    pub max_row_samples: u32,
    /// Most floats of decoder tables (`Decoder::tables_len`) a plan may need.
    pub max_table_floats: u32,
    /// Most candidates per pixel (the `capacity` of its candidate headers).
    pub candidate_capacity: u16,
    /// Longest request frame it receives, delimiter included.
    pub max_frame_len: u32,
    /// Fingerprint of the loaded plan, if any.
    pub plan_fingerprint: Option<u64>,
}

/// Why the camera refused a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum DeviceError<'a> {
    /// The request's frame was damaged or not understood.
    Frame(FrameError),
    /// The request is of a kind that needs another state first (e.g. a row before
    /// `StartScan`, a plan upload during a scan).
    State {
        /// The request.
        request: RequestKind,
        /// What the camera is doing.
        state: DeviceState,
    },
    /// The plan bytes have no method's plan length (80 for FSM, 32 or 96 for the baselines).
    PlanLength {
        /// Bytes received.
        got: u32,
    },
    /// The plan bytes do not decode to a valid plan; `reason` says which field.
    PlanInvalid {
        /// `fsm_core`'s message.
        reason: &'a str,
    },
    /// The fingerprint the host stated is not the one of the bytes received.
    PlanFingerprint {
        /// What the host sent.
        stated: u64,
        /// What the camera computed from the plan bytes.
        computed: u64,
    },
    /// The plan's decoder tables do not fit in the camera's memory.
    PlanTooLarge {
        /// Floats the tables need.
        table_floats: u32,
        /// Floats the camera has.
        max: u32,
    },
    /// `StartScan` names another plan than the loaded one.
    PlanMismatch {
        /// Fingerprint in the request.
        requested: u64,
        /// Fingerprint of the loaded plan.
        loaded: u64,
    },
    /// A scan field is out of range (`width`, `height`, `bit_depth`).
    ScanField {
        /// The field.
        field: &'a str,
        /// Its value.
        value: u32,
    },
    /// Rows of this geometry do not fit in the camera's memory.
    ScanTooLarge {
        /// Pixels per row requested.
        width: u32,
        /// Frames per row of the plan.
        frames: u32,
        /// Most pixels per row.
        max_width: u32,
        /// Most samples per row.
        max_row_samples: u32,
    },
    /// A row record of the wrong length for this scan.
    RowLength {
        /// Row index in the record, if it had 4 bytes.
        row: Option<u32>,
        /// Bytes a record of this scan has.
        expected: u32,
        /// Bytes received.
        got: u32,
    },
    /// A row record whose CRC does not match its bytes.
    RowCorrupt {
        /// Row index in the record (itself unverified).
        row: u32,
        /// CRC in the record.
        stored: u32,
        /// CRC of the bytes received.
        computed: u32,
    },
    /// A row index at or past the scan's height.
    RowOutOfRange {
        /// Row index in the record.
        row: u32,
        /// Rows in the scan.
        height: u32,
    },
    /// The row could not be decoded or encoded (`fsm_core`'s message).
    Decode {
        /// Row index, if known.
        row: Option<u32>,
        /// What the decoder said.
        reason: &'a str,
    },
}

/// The kinds of [`Request`], for error reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[allow(missing_docs)]
pub enum RequestKind {
    Hello,
    UploadPlan,
    StartScan,
    Row,
    EndScan,
}

/// What the camera is doing, for error reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum DeviceState {
    /// No plan loaded.
    NoPlan,
    /// A plan is loaded, no scan is running.
    Idle,
    /// A scan is running.
    Scanning,
}

impl Request<'_> {
    /// The kind of this request.
    pub fn kind(&self) -> RequestKind {
        match self {
            Request::Hello => RequestKind::Hello,
            Request::UploadPlan { .. } => RequestKind::UploadPlan,
            Request::StartScan(_) => RequestKind::StartScan,
            Request::Row { .. } => RequestKind::Row,
            Request::EndScan => RequestKind::EndScan,
        }
    }
}

impl fmt::Display for RequestKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            RequestKind::Hello => "Hello",
            RequestKind::UploadPlan => "UploadPlan",
            RequestKind::StartScan => "StartScan",
            RequestKind::Row => "Row",
            RequestKind::EndScan => "EndScan",
        })
    }
}

impl fmt::Display for DeviceState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            DeviceState::NoPlan => "no plan is loaded",
            DeviceState::Idle => "no scan is running",
            DeviceState::Scanning => "a scan is running",
        })
    }
}

/// One line per field, as `fsm camera info` prints them: `protocol version   1`, …, `loaded plan
/// 0123456789abcdef` (or `none`); no newline at the end. The alternate form (`{:#}`, `fsm
/// upload`'s) is one line: `camera protocol 1, up to 2048 pixels per row, 8 candidates per pixel`.
impl fmt::Display for DeviceInfo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if f.alternate() {
            return write!(
                f,
                "camera protocol {}, up to {} pixels per row, {} candidates per pixel",
                self.protocol_version, self.max_width, self.candidate_capacity
            );
        }
        writeln!(f, "protocol version   {}", self.protocol_version)?;
        writeln!(f, "max pixels per row {}", self.max_width)?;
        writeln!(f, "max row samples    {}", self.max_row_samples)?;
        writeln!(f, "max table floats   {}", self.max_table_floats)?;
        writeln!(f, "candidates/pixel   {}", self.candidate_capacity)?;
        writeln!(f, "max frame bytes    {}", self.max_frame_len)?;
        match self.plan_fingerprint {
            Some(fingerprint) => write!(f, "loaded plan        {fingerprint:016x}"),
            None => write!(f, "loaded plan        none"),
        }
    }
}

impl fmt::Display for DeviceError<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            DeviceError::Frame(e) => write!(f, "request frame rejected: {e}"),
            DeviceError::State { request, state } => {
                write!(f, "{request} refused: {state}")
            }
            DeviceError::PlanLength { got } => {
                write!(
                    f,
                    "plan: {got} bytes received, a plan has 80 (FSM), 32 (phase shift, line \
                     scanning, Code Ensemble) or 96 (Micro Phase Shifting)"
                )
            }
            DeviceError::PlanInvalid { reason } => write!(f, "plan rejected: {reason}"),
            DeviceError::PlanFingerprint { stated, computed } => write!(
                f,
                "plan rejected: fingerprint {stated:016x} stated, the bytes received have {computed:016x}"
            ),
            DeviceError::PlanTooLarge { table_floats, max } => write!(
                f,
                "plan rejected: its decoder tables need {table_floats} floats, the camera has {max}"
            ),
            DeviceError::PlanMismatch { requested, loaded } => write!(
                f,
                "scan refused: plan {requested:016x} requested, plan {loaded:016x} is loaded"
            ),
            DeviceError::ScanField { field, value } => {
                write!(f, "scan refused: field {field} has the invalid value {value}")
            }
            DeviceError::ScanTooLarge {
                width,
                frames,
                max_width,
                max_row_samples,
            } => write!(
                f,
                "scan refused: rows of {width} pixels x {frames} frames do not fit \
                 (at most {max_width} pixels and {max_row_samples} samples per row)"
            ),
            DeviceError::RowLength { row, expected, got } => match row {
                Some(row) => write!(
                    f,
                    "row {row}: record of {got} bytes, this scan's records have {expected}"
                ),
                None => write!(
                    f,
                    "row record of {got} bytes, this scan's records have {expected}"
                ),
            },
            DeviceError::RowCorrupt {
                row,
                stored,
                computed,
            } => write!(
                f,
                "row {row}: record corrupted (CRC stored {stored:08x}, computed {computed:08x})"
            ),
            DeviceError::RowOutOfRange { row, height } => {
                write!(f, "row {row} is outside the scan's height {height}")
            }
            DeviceError::Decode {
                row: Some(row),
                reason,
            } => write!(f, "row {row}: {reason}"),
            DeviceError::Decode { row: None, reason } => write!(f, "row: {reason}"),
        }
    }
}
