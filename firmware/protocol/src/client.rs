//! The host side: a client that talks to a camera (or its emulator) over any [`Link`].
//!
//! What `fsm upload` and `fsm camera` call:
//!
//! ```no_run
//! use std::time::Duration;
//! use fsm_core::ScanPlan;
//! use fsm_protocol::client::Client;
//!
//! let plan = ScanPlan::paper_bfsm();
//! let mut camera = Client::connect("tcp://127.0.0.1:7070", Duration::from_secs(30))?;
//! let info = camera.hello()?;
//! let fingerprint = camera.upload_plan(&plan)?; // == plan.fingerprint(), checked
//! // Any method's plan: the baselines' too.
//! camera.upload_plan(fsm_core::LineScanPlan::paper())?;
//! # let _ = (info, fingerprint);
//! # Ok::<(), fsm_protocol::client::ClientError>(())
//! ```

use std::fmt;
use std::fs;
use std::io::{self, Read, Write};
use std::path::Path;
use std::time::Duration;

use fsm_core::wire::candidates::{self, CandidateHeader};
use fsm_core::wire::row_dump::{self, RowDumpHeader};
use fsm_core::wire::{PlanIdentity, WireError, HEADER_LEN};
use fsm_core::MethodPlan;

use crate::frame::{self, FrameError, FrameReader};
use crate::message::{DeviceInfo, Request, RequestKind, Response, RowOutput, ScanSpec};
use crate::transport::{AddressError, DeviceAddress, Link};
use crate::PROTOCOL_VERSION;

/// Longest response frame the client accepts (a candidate row of 2048 pixels with 255
/// candidates each is about 8 MiB; raw rows are bounded by the camera's row memory).
pub const MAX_RESPONSE_FRAME: usize = 64 << 20;

/// Why a conversation with the camera failed.
#[derive(Debug)]
pub enum ClientError {
    /// The device address does not parse.
    Address(AddressError),
    /// The link failed (or timed out) while doing `context`.
    Io {
        /// What the client was doing.
        context: String,
        /// The error.
        source: io::Error,
    },
    /// The camera sent nothing for the link's read time-out (or did not take what was sent
    /// within its write time-out) while the client was doing `context`.
    TimedOut {
        /// What the client was doing.
        context: String,
        /// The time-out, when the client set it.
        after: Option<Duration>,
    },
    /// The camera closed the link before answering `request`.
    Closed {
        /// The unanswered request.
        request: RequestKind,
    },
    /// The camera's answer to `request` arrived damaged.
    Frame {
        /// The request.
        request: RequestKind,
        /// What was wrong with the answer.
        error: FrameError,
    },
    /// The camera refused `request`.
    Device {
        /// The request.
        request: RequestKind,
        /// The camera's error, rendered.
        message: String,
    },
    /// The camera answered `request` with a message of another kind.
    Unexpected {
        /// The request.
        request: RequestKind,
        /// The answer's kind.
        got: &'static str,
    },
    /// The camera speaks another protocol version.
    Version {
        /// The camera's version.
        device: u8,
    },
    /// The camera acknowledged a plan with another fingerprint than the one uploaded.
    Acknowledgement {
        /// Fingerprint of the plan sent.
        sent: u64,
        /// Fingerprint acknowledged.
        acked: u64,
    },
    /// Bytes in a file or from the camera break a `fsm_core::wire` format.
    Wire {
        /// Where: a file path, or "camera".
        source: String,
        /// What is wrong.
        error: WireError,
    },
    /// The camera answered another number of rows than were sent.
    RowCount {
        /// Rows sent.
        sent: u32,
        /// Rows the camera reports.
        answered: u32,
    },
}

impl fmt::Display for ClientError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ClientError::Address(e) => write!(f, "{e}"),
            ClientError::Io { context, source } => write!(f, "{context}: {source}"),
            ClientError::TimedOut { context, after } => match after {
                Some(t) => write!(f, "{context}: timed out after {:.1} s", t.as_secs_f64()),
                None => write!(f, "{context}: timed out"),
            },
            ClientError::Closed { request } => {
                write!(f, "the camera closed the link before answering {request}")
            }
            ClientError::Frame { request, error } => {
                write!(f, "the camera's answer to {request} is damaged: {error}")
            }
            ClientError::Device { request, message } => {
                write!(f, "the camera refused {request}: {message}")
            }
            ClientError::Unexpected { request, got } => {
                write!(f, "the camera answered {request} with {got}")
            }
            ClientError::Version { device } => write!(
                f,
                "the camera speaks protocol version {device}, this host version {PROTOCOL_VERSION}"
            ),
            ClientError::Acknowledgement { sent, acked } => write!(
                f,
                "plan {sent:016x} uploaded, the camera acknowledged {acked:016x}"
            ),
            ClientError::Wire { source, error } => write!(f, "{source}: {error}"),
            ClientError::RowCount { sent, answered } => write!(
                f,
                "{sent} rows sent, the camera reports {answered} answered"
            ),
        }
    }
}

impl std::error::Error for ClientError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ClientError::Io { source, .. } => Some(source),
            ClientError::Address(e) => Some(e),
            _ => None,
        }
    }
}

/// The kind of a response, for error messages.
pub fn response_kind(response: &Response<'_>) -> &'static str {
    match response {
        Response::Info(_) => "Info",
        Response::PlanAccepted { .. } => "PlanAccepted",
        Response::ScanStarted { .. } => "ScanStarted",
        Response::CandidateRow { .. } => "CandidateRow",
        Response::RawRow { .. } => "RawRow",
        Response::ScanEnded { .. } => "ScanEnded",
        Response::Error(_) => "Error",
    }
}

/// What a scan of a row dump produced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScanSummary {
    /// Fingerprint of the plan the camera acknowledged.
    pub fingerprint: u64,
    /// Rows sent and answered.
    pub rows: u32,
    /// Bytes written: the 64-byte header and every record.
    pub bytes: u64,
}

impl ScanSummary {
    /// What `fsm camera scan` says once `device`'s answers to the rows of `dump` are in
    /// `out`: `ADDR: 480 rows of scan.dump scanned (plan …), 123456 bytes -> out.fsmc`.
    pub fn report(&self, device: &Device, dump: &Path, out: &Path) -> String {
        format!(
            "{}: {} rows of {} scanned (plan {:016x}), {} bytes -> {}",
            device.address,
            self.rows,
            dump.display(),
            self.fingerprint,
            self.bytes,
            out.display()
        )
    }
}

/// One request/response conversation with a camera.
pub struct Client<L> {
    link: L,
    reader: FrameReader<Vec<u8>>,
    chunk: Vec<u8>,
    /// Unread received bytes: `chunk[at..len]`.
    at: usize,
    len: usize,
    /// The link's read and write time-out, for messages.
    timeout: Option<Duration>,
    /// The fingerprints of the plan this client last uploaded: a raw scan's header carries
    /// its pattern fingerprint.
    uploaded: Option<PlanIdentity>,
}

impl Client<Box<dyn Link>> {
    /// Connects to `address` (`tcp://host:port`, a serial port path, or `path@baud`); reads
    /// wait at most `timeout` for the camera's next bytes.
    pub fn connect(address: &str, timeout: Duration) -> Result<Self, ClientError> {
        let parsed = DeviceAddress::parse(address).map_err(ClientError::Address)?;
        let context = format!("connecting to {parsed}");
        let link = parsed.open(timeout).map_err(|source| match source.kind() {
            io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock => ClientError::TimedOut {
                context,
                after: Some(timeout),
            },
            _ => ClientError::Io { context, source },
        })?;
        let mut client = Client::new(link);
        client.timeout = Some(timeout);
        Ok(client)
    }
}

impl<L: Read + Write> Client<L> {
    /// A client over an open link.
    pub fn new(link: L) -> Self {
        Client {
            link,
            // Zeroed allocation: pages are only touched as frames fill them.
            reader: FrameReader::new(vec![0u8; MAX_RESPONSE_FRAME]),
            chunk: vec![0u8; 64 << 10],
            at: 0,
            len: 0,
            timeout: None,
            uploaded: None,
        }
    }

    /// A link error while doing `context`; a time-out (`TimedOut`, or `WouldBlock` from a
    /// socket's read time-out) is reported as one.
    fn io_error(&self, context: String, source: io::Error) -> ClientError {
        match source.kind() {
            io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock => ClientError::TimedOut {
                context,
                after: self.timeout,
            },
            _ => ClientError::Io { context, source },
        }
    }

    /// The link, e.g. to send raw bytes in tests.
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.link
    }

    /// Sends `request` and returns the camera's answer, which may be [`Response::Error`].
    pub fn request(&mut self, request: &Request<'_>) -> Result<Response<'_>, ClientError> {
        let kind = request.kind();
        let bytes = frame::encode_vec(request).map_err(|error| ClientError::Frame {
            request: kind,
            error,
        })?;
        self.send_raw(kind, &bytes)?;
        self.receive(kind)
    }

    /// Sends bytes as they are (a frame, or anything else) for `request`'s sake.
    pub fn send_raw(&mut self, request: RequestKind, bytes: &[u8]) -> Result<(), ClientError> {
        self.link
            .write_all(bytes)
            .and_then(|_| self.link.flush())
            .map_err(|source| self.io_error(format!("sending {request}"), source))
    }

    /// Waits for the next response (to `request`).
    pub fn receive(&mut self, request: RequestKind) -> Result<Response<'_>, ClientError> {
        loop {
            if self.at == self.len {
                self.at = 0;
                self.len = 0;
                let n = loop {
                    match self.link.read(&mut self.chunk) {
                        Ok(n) => break n,
                        Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                        Err(source) => {
                            return Err(self
                                .io_error(format!("waiting for the answer to {request}"), source))
                        }
                    }
                };
                if n == 0 {
                    return Err(ClientError::Closed { request });
                }
                self.len = n;
            }
            let (taken, done) = self.reader.push(&self.chunk[self.at..self.len]);
            self.at += taken;
            match done {
                None => continue,
                Some(Err(error)) => return Err(ClientError::Frame { request, error }),
                Some(Ok(())) => break,
            }
        }
        frame::decode(self.reader.message()).map_err(|error| ClientError::Frame { request, error })
    }

    /// Asks the camera for its limits; checks its protocol version.
    pub fn hello(&mut self) -> Result<DeviceInfo, ClientError> {
        match self.request(&Request::Hello)? {
            Response::Info(info) if info.protocol_version != PROTOCOL_VERSION => {
                Err(ClientError::Version {
                    device: info.protocol_version,
                })
            }
            Response::Info(info) => Ok(info),
            other => Err(answer_error(RequestKind::Hello, &other)),
        }
    }

    /// Uploads `plan`, of any method (its canonical bytes, `fsm_core::methods::wire`);
    /// returns the fingerprint the camera acknowledged, which is checked to be
    /// `plan.fingerprint()`.
    pub fn upload_plan(&mut self, plan: impl Into<MethodPlan>) -> Result<u64, ClientError> {
        let plan: MethodPlan = plan.into();
        let bytes = plan.to_bytes();
        let sent = plan.fingerprint();
        let request = Request::UploadPlan {
            plan: &bytes,
            fingerprint: sent,
        };
        match self.request(&request)? {
            Response::PlanAccepted { fingerprint } if fingerprint == sent => {
                self.uploaded = Some(plan.identity());
                Ok(fingerprint)
            }
            Response::PlanAccepted { fingerprint } => Err(ClientError::Acknowledgement {
                sent,
                acked: fingerprint,
            }),
            other => Err(answer_error(RequestKind::UploadPlan, &other)),
        }
    }

    /// Starts a scan; returns the 64-byte header of the stream that follows, checked against
    /// `spec`.
    pub fn start_scan(&mut self, spec: &ScanSpec) -> Result<[u8; HEADER_LEN], ClientError> {
        let uploaded = self.uploaded;
        let header = match self.request(&Request::StartScan(*spec))? {
            Response::ScanStarted { header } => header,
            other => return Err(answer_error(RequestKind::StartScan, &other)),
        };
        let camera = |error| ClientError::Wire {
            source: "camera's scan header".into(),
            error,
        };
        let field = |field, value: u64| {
            camera(WireError::Field {
                what: "scan header",
                field,
                value,
            })
        };
        let (width, height) = match spec.output {
            RowOutput::Candidates => {
                let h = CandidateHeader::decode(header).map_err(camera)?;
                if h.plan_fingerprint != spec.fingerprint {
                    return Err(field("plan_fingerprint", h.plan_fingerprint));
                }
                (h.width, h.height)
            }
            RowOutput::Raw => {
                let h = RowDumpHeader::decode(header).map_err(camera)?;
                if h.bit_depth != spec.bit_depth {
                    return Err(field("bit_depth", h.bit_depth as u64));
                }
                // Raw rows name the patterns shown; checked when this client uploaded the
                // plan (another session's plan is known by its plan fingerprint alone).
                let known = uploaded.filter(|id| id.plan == spec.fingerprint);
                if known.is_some_and(|id| !h.recorded_with.admits(&id)) {
                    let r = h.recorded_with;
                    return Err(field(r.field(), r.fingerprint()));
                }
                (h.width, h.height)
            }
        };
        if width != spec.width {
            return Err(field("width", width as u64));
        }
        if height != spec.height {
            return Err(field("height", height as u64));
        }
        let mut out = [0u8; HEADER_LEN];
        out.copy_from_slice(&header[..HEADER_LEN]);
        Ok(out)
    }

    /// Sends one row-dump record; returns the camera's record for it (a candidate record,
    /// or a row-dump record for raw output).
    pub fn send_row(&mut self, record: &[u8]) -> Result<&[u8], ClientError> {
        match self.request(&Request::Row { record })? {
            Response::CandidateRow { record } | Response::RawRow { record } => Ok(record),
            other => Err(answer_error(RequestKind::Row, &other)),
        }
    }

    /// Ends the scan; returns the rows the camera answered.
    pub fn end_scan(&mut self) -> Result<u32, ClientError> {
        match self.request(&Request::EndScan)? {
            Response::ScanEnded { rows } => Ok(rows),
            other => Err(answer_error(RequestKind::EndScan, &other)),
        }
    }

    /// Scans a row dump through the camera: uploads `plan`, starts a scan of the dump's
    /// geometry, sends every record in file order and writes the header and each answered
    /// record to `out` — a candidate file (or, for [`RowOutput::Raw`], a row dump) that is
    /// byte for byte what `fsm decode` writes for the same rows. Every record the camera
    /// returns is checked with `fsm_core::wire` before it is written.
    pub fn scan_dump(
        &mut self,
        plan: impl Into<MethodPlan>,
        dump: &[u8],
        dump_name: &str,
        output: RowOutput,
        out: &mut dyn Write,
    ) -> Result<ScanSummary, ClientError> {
        let wire = |error| ClientError::Wire {
            source: dump_name.to_string(),
            error,
        };
        let plan: MethodPlan = plan.into();
        let header = RowDumpHeader::decode(dump).map_err(wire)?;
        plan.check_row_dump(&header).map_err(wire)?;
        let record_len = header.record_len().ok_or(wire(WireError::Field {
            what: "row dump",
            field: "width",
            value: header.width as u64,
        }))?;
        let body = &dump[HEADER_LEN..];
        if !body.len().is_multiple_of(record_len) {
            return Err(wire(WireError::Truncated {
                what: "row dump",
                needed: (body.len() / record_len + 1) * record_len + HEADER_LEN,
                got: dump.len(),
            }));
        }
        // Every record is checked before anything is sent.
        for record in body.chunks_exact(record_len) {
            row_dump::decode_record(&header, record).map_err(wire)?;
        }

        let fingerprint = self.upload_plan(plan)?;
        let spec = ScanSpec {
            fingerprint,
            width: header.width,
            height: header.height,
            bit_depth: header.bit_depth,
            output,
        };
        let stream_header = self.start_scan(&spec)?;
        let io = |source| ClientError::Io {
            context: "writing the scan output".into(),
            source,
        };
        out.write_all(&stream_header).map_err(io)?;
        let mut bytes = HEADER_LEN as u64;
        let mut rows = 0u32;
        for record in body.chunks_exact(record_len) {
            let answer = self.send_row(record)?;
            let camera = |error| ClientError::Wire {
                source: "camera".into(),
                error,
            };
            let len = match output {
                RowOutput::Candidates => {
                    let h = CandidateHeader::decode(&stream_header).map_err(camera)?;
                    candidates::decode_record(&h, answer).map_err(camera)?.len
                }
                RowOutput::Raw => {
                    let h = RowDumpHeader::decode(&stream_header).map_err(camera)?;
                    row_dump::decode_record(&h, answer).map_err(camera)?;
                    h.record_len().unwrap_or(usize::MAX)
                }
            };
            if len != answer.len() {
                return Err(camera(WireError::Field {
                    what: "camera record",
                    field: "length",
                    value: answer.len() as u64,
                }));
            }
            out.write_all(answer).map_err(io)?;
            bytes += answer.len() as u64;
            rows += 1;
        }
        let answered = self.end_scan()?;
        if answered != rows {
            return Err(ClientError::RowCount {
                sent: rows,
                answered,
            });
        }
        Ok(ScanSummary {
            fingerprint,
            rows,
            bytes,
        })
    }
}

fn answer_error(request: RequestKind, response: &Response<'_>) -> ClientError {
    match response {
        Response::Error(e) => ClientError::Device {
            request,
            message: e.to_string(),
        },
        other => ClientError::Unexpected {
            request,
            got: response_kind(other),
        },
    }
}

/// A camera as `fsm upload` and `fsm camera` address it: where it is (`tcp://host:port`, a
/// serial port path, `path@baud`) and how long to wait for each of its answers. Each call is
/// one conversation on a new link; its error names the camera ([`DeviceError`]), so that the
/// commands print it as it is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Device {
    /// The address, as given.
    pub address: String,
    /// How long to wait for each answer.
    pub timeout: Duration,
}

/// Why a conversation with a [`Device`] failed: `tcp://10.0.0.5:7070: connecting to …`.
#[derive(Debug)]
pub struct DeviceError {
    /// The camera's address, as given.
    pub address: String,
    /// What failed.
    pub error: ClientError,
}

impl fmt::Display for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.address, self.error)
    }
}

impl std::error::Error for DeviceError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        Some(&self.error)
    }
}

impl Device {
    /// The camera at `address`, answering within `timeout`.
    pub fn new(address: &str, timeout: Duration) -> Self {
        Device {
            address: address.to_owned(),
            timeout,
        }
    }

    /// Runs `talk` with a client connected to the camera, naming the camera in its error.
    fn talk<T>(
        &self,
        talk: impl FnOnce(&mut Client<Box<dyn Link>>) -> Result<T, ClientError>,
    ) -> Result<T, DeviceError> {
        Client::connect(&self.address, self.timeout)
            .and_then(|mut client| talk(&mut client))
            .map_err(|error| DeviceError {
                address: self.address.clone(),
                error,
            })
    }

    /// `fsm camera info`: the camera's protocol version, limits and loaded plan.
    pub fn info(&self) -> Result<DeviceInfo, DeviceError> {
        self.talk(|client| client.hello())
    }

    /// `fsm upload --plan P --device ADDR`: uploads `plan` and returns the acknowledged
    /// fingerprint (checked) and the camera's limits.
    pub fn upload(&self, plan: impl Into<MethodPlan>) -> Result<(u64, DeviceInfo), DeviceError> {
        self.talk(|client| {
            let info = client.hello()?;
            Ok((client.upload_plan(plan)?, info))
        })
    }

    /// `fsm camera scan`: scans the row dump at `dump_path` through the camera, writing the
    /// candidate file (or raw rows) to `out`. Making `out` whole or nothing (a staged file
    /// committed on success) is the caller's: the host has one atomic writer.
    pub fn scan_dump_file(
        &self,
        plan: impl Into<MethodPlan>,
        dump_path: &Path,
        output: RowOutput,
        out: &mut impl Write,
    ) -> Result<ScanSummary, DeviceError> {
        let dump = fs::read(dump_path).map_err(|source| DeviceError {
            address: self.address.clone(),
            error: ClientError::Io {
                context: format!("reading {}", dump_path.display()),
                source,
            },
        })?;
        let name = dump_path.display().to_string();
        self.talk(|client| {
            client.hello()?;
            client.scan_dump(plan, &dump, &name, output, out)
        })
    }
}
