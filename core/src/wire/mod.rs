//! Byte formats that cross a boundary (SPEC §6): little-endian, versioned, CRC-checked.
//!
//! | format | module | who writes it | who reads it |
//! |---|---|---|---|
//! | scan plan, 80 bytes, and its fingerprints ([`PlanIdentity`]) | [`plan`] | host | camera, every file header |
//! | raw temporal rows of a scan, with the fingerprint of the patterns shown | [`row_dump`] | camera, simulator | `fsm decode` |
//! | candidate rows | [`candidates`] | camera, `fsm decode` | `fsm scan`, tests |
//!
//! Readers never return part of a record as if it were whole: a short buffer, a wrong magic,
//! an unknown version, a bad CRC or an out-of-range field is an error that names the format,
//! the field and, for records, the row.

pub mod candidates;
pub mod plan;
pub mod row_dump;

use core::fmt;

use crate::plan::PlanError;

/// CRC-64 (XZ) of plan fingerprints.
const CRC64: crc::Crc<u64> = crc::Crc::<u64>::new(&crc::CRC_64_XZ);

/// CRC-32 (ISO-HDLC, the zlib/PNG one) of `bytes`: every stored or transmitted record.
///
/// `crc32fast` computes it with the carry-less multiply instructions where the build allows
/// (and, on the host, where the CPU has them: the host enables its `std` feature, which
/// detects them at run time) and with slice-by-16 tables elsewhere; every path gives the
/// same checksum. A BFSM dump row is 1.2 MB of samples per 768-pixel row: the table checked
/// it at about 3 GB/s, a sixth of a pixel's decode budget at 2 Mpx/s.
pub fn crc32(bytes: &[u8]) -> u32 {
    crc32fast::hash(bytes)
}

/// [`crc32`] of `parts` one after the other.
pub fn crc32_parts(parts: &[&[u8]]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    for p in parts {
        h.update(p);
    }
    h.finalize()
}

/// CRC-64 (XZ) of `bytes`: plan fingerprints.
pub fn crc64(bytes: &[u8]) -> u64 {
    CRC64.checksum(bytes)
}

/// Bytes every pattern fingerprint's input starts with, before the method's 2-byte tag; no
/// plan's bytes start so, so a pattern fingerprint never equals a plan fingerprint by design.
const PATTERN_PREFIX: &[u8; 6] = b"FRAMES";

/// The fingerprint of a pattern sequence: CRC-64/XZ of `FRAMES`, the method's 2-byte `tag`,
/// then `fields`, the little-endian values the frames depend on (and nothing the decoder
/// alone reads).
pub fn pattern_fingerprint(tag: &[u8; 2], fields: &[u8]) -> u64 {
    let mut digest = CRC64.digest();
    digest.update(PATTERN_PREFIX);
    digest.update(tag);
    digest.update(fields);
    digest.finalize()
}

/// The fingerprints a plan gives the files of its captures.
///
/// Row dumps and image stacks carry `patterns`: they record what was shown, so any plan with
/// the same patterns decodes them, with any decoder settings. Candidate files carry `plan`:
/// they record a decode, which depends on every setting.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct PlanIdentity {
    /// Fingerprint of the pattern sequence (the frames, in order).
    pub patterns: u64,
    /// Fingerprint of the whole plan: patterns and decoder settings.
    pub plan: u64,
    /// The plan fingerprint files written before plan version 2 carry, if it has one
    /// ([`ScanPlan::legacy_fingerprint`](crate::plan::ScanPlan::legacy_fingerprint)).
    pub legacy_plan: Option<u64>,
}

impl PlanIdentity {
    /// Whether a file stating plan fingerprint `f` was made with this plan.
    pub fn has_plan_fingerprint(&self, f: u64) -> bool {
        f == self.plan || self.legacy_plan == Some(f)
    }
}

/// What is wrong with some bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // each field is the value the variant reports
pub enum WireError {
    /// Fewer bytes than the format needs.
    Truncated {
        what: &'static str,
        needed: usize,
        got: usize,
    },
    /// The bytes do not start with the format's magic.
    Magic { what: &'static str },
    /// A version this build does not read (it reads `1..=supported`).
    Version {
        what: &'static str,
        version: u16,
        supported: u16,
    },
    /// The header's CRC does not match its bytes.
    HeaderCrc {
        what: &'static str,
        stored: u32,
        computed: u32,
    },
    /// A record's CRC does not match its bytes.
    RecordCrc {
        what: &'static str,
        row: u32,
        stored: u32,
        computed: u32,
    },
    /// A field holds a value the format does not allow.
    Field {
        what: &'static str,
        field: &'static str,
        value: u64,
    },
    /// A record's row index is not below the header's height.
    RowOutOfRange {
        what: &'static str,
        row: u32,
        height: u32,
    },
    /// A decoded plan breaks a rule.
    Plan(PlanError),
    /// A decoded plan of a method FSM is compared with (`crate::baseline`) breaks one of its
    /// rules: the field, its value and the rule.
    Rule {
        what: &'static str,
        field: &'static str,
        value: f32,
        rule: &'static str,
    },
    /// The output buffer is too small.
    BufferTooSmall {
        what: &'static str,
        needed: usize,
        got: usize,
    },
}

impl fmt::Display for WireError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            WireError::Truncated { what, needed, got } => {
                write!(f, "{what}: truncated, {needed} bytes needed, {got} present")
            }
            WireError::Magic { what } => write!(f, "{what}: not this format (wrong magic bytes)"),
            WireError::Version { what, version, supported: 1 } => write!(
                f,
                "{what}: format version {version} is not supported (this build reads version 1)"
            ),
            WireError::Version { what, version, supported } => write!(
                f,
                "{what}: format version {version} is not supported (this build reads versions 1 to {supported})"
            ),
            WireError::HeaderCrc { what, stored, computed } => write!(
                f,
                "{what}: header CRC mismatch (stored {stored:08x}, computed {computed:08x})"
            ),
            WireError::RecordCrc { what, row, stored, computed } => write!(
                f,
                "{what}: record of row {row} is corrupted (CRC stored {stored:08x}, computed {computed:08x})"
            ),
            WireError::Field { what, field, value } => {
                write!(f, "{what}: field {field} has the invalid value {value}")
            }
            WireError::RowOutOfRange { what, row, height } => {
                write!(f, "{what}: row {row} is outside the image height {height}")
            }
            WireError::Plan(e) => write!(f, "scan plan: {e}"),
            WireError::Rule { what, field, value, rule } => {
                write!(f, "{what}: {field} = {value}: {rule}")
            }
            WireError::BufferTooSmall { what, needed, got } => {
                write!(f, "{what}: output buffer holds {got} bytes, {needed} needed")
            }
        }
    }
}

/// Little-endian reads from a slice whose length was checked beforehand (every plan's wire
/// form reads through it, the baselines' too: `crate::methods::wire`).
pub(crate) struct Reader<'a> {
    bytes: &'a [u8],
    pub(crate) at: usize,
}

impl<'a> Reader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes, at: 0 }
    }

    pub(crate) fn take<const N: usize>(&mut self) -> [u8; N] {
        let mut out = [0u8; N];
        out.copy_from_slice(&self.bytes[self.at..self.at + N]);
        self.at += N;
        out
    }

    pub(crate) fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }

    pub(crate) fn u16(&mut self) -> u16 {
        u16::from_le_bytes(self.take())
    }

    pub(crate) fn u32(&mut self) -> u32 {
        u32::from_le_bytes(self.take())
    }

    pub(crate) fn u64(&mut self) -> u64 {
        u64::from_le_bytes(self.take())
    }

    pub(crate) fn f32(&mut self) -> f32 {
        f32::from_le_bytes(self.take())
    }
}

/// Little-endian writes into a slice whose length was checked beforehand.
pub(crate) struct Writer<'a> {
    bytes: &'a mut [u8],
    pub(crate) at: usize,
}

impl<'a> Writer<'a> {
    pub(crate) fn new(bytes: &'a mut [u8]) -> Self {
        Writer { bytes, at: 0 }
    }

    pub(crate) fn put(&mut self, b: &[u8]) {
        self.bytes[self.at..self.at + b.len()].copy_from_slice(b);
        self.at += b.len();
    }

    pub(crate) fn u8(&mut self, v: u8) {
        self.put(&[v]);
    }

    pub(crate) fn u16(&mut self, v: u16) {
        self.put(&v.to_le_bytes());
    }

    pub(crate) fn u32(&mut self, v: u32) {
        self.put(&v.to_le_bytes());
    }

    pub(crate) fn u64(&mut self, v: u64) {
        self.put(&v.to_le_bytes());
    }

    pub(crate) fn f32(&mut self, v: f32) {
        self.put(&v.to_le_bytes());
    }
}

/// Length of the fixed file headers of [`row_dump`] and [`candidates`].
pub const HEADER_LEN: usize = 64;

/// Checks the magic, version (`1..=newest`), length and CRC shared by the 64-byte file
/// headers; returns the version and a reader positioned after the version and header-length
/// fields (offset 12).
fn open_header<'a>(
    what: &'static str,
    magic: &[u8; 8],
    newest: u16,
    bytes: &'a [u8],
) -> Result<(u16, Reader<'a>), WireError> {
    if bytes.len() < HEADER_LEN {
        return Err(WireError::Truncated {
            what,
            needed: HEADER_LEN,
            got: bytes.len(),
        });
    }
    if &bytes[..8] != magic {
        return Err(WireError::Magic { what });
    }
    let mut r = Reader::new(&bytes[..HEADER_LEN]);
    r.at = 8;
    let found = r.u16();
    if !(1..=newest).contains(&found) {
        return Err(WireError::Version {
            what,
            version: found,
            supported: newest,
        });
    }
    let len = r.u16();
    if len as usize != HEADER_LEN {
        return Err(WireError::Field {
            what,
            field: "header_len",
            value: len as u64,
        });
    }
    let stored = u32::from_le_bytes([bytes[60], bytes[61], bytes[62], bytes[63]]);
    let computed = crc32(&bytes[..60]);
    if stored != computed {
        return Err(WireError::HeaderCrc {
            what,
            stored,
            computed,
        });
    }
    Ok((found, r))
}

/// Writes magic, version and length, leaving the writer at offset 12; [`seal_header`] adds the
/// CRC once the rest is written.
fn begin_header<'a>(magic: &[u8; 8], version: u16, out: &'a mut [u8; HEADER_LEN]) -> Writer<'a> {
    out.fill(0);
    let mut w = Writer::new(out);
    w.put(magic);
    w.u16(version);
    w.u16(HEADER_LEN as u16);
    w
}

fn seal_header(out: &mut [u8; HEADER_LEN]) {
    let crc = crc32(&out[..60]);
    out[60..].copy_from_slice(&crc.to_le_bytes());
}

/// Bytes of a record's CRC-32, its last field in every format.
const RECORD_CRC_LEN: usize = 4;

/// Ends a record of `len` bytes written at the start of `out`: its last 4 bytes become the
/// CRC-32 of the bytes before them. The framing every record shares: row index first, CRC last.
fn seal_record(out: &mut [u8], len: usize) {
    let body = len - RECORD_CRC_LEN;
    let crc = crc32(&out[..body]);
    out[body..len].copy_from_slice(&crc.to_le_bytes());
}

/// The CRC-32 stored in the last 4 bytes of `record` (at least 4 long).
fn stored_crc(record: &[u8]) -> u32 {
    let n = record.len();
    u32::from_le_bytes([record[n - 4], record[n - 3], record[n - 2], record[n - 1]])
}

/// Checks a record's framing: the CRC-32 `stored` against its `parts` (the record's bytes
/// before the CRC, in order), then its `row` against the `height` of the scan. Returns the
/// row. The CRC comes first: a row index read from damaged bytes is not reported as out of
/// range.
fn check_record(
    what: &'static str,
    height: u32,
    row: u32,
    parts: &[&[u8]],
    stored: u32,
) -> Result<u32, WireError> {
    let computed = crc32_parts(parts);
    if stored != computed {
        return Err(WireError::RecordCrc {
            what,
            row,
            stored,
            computed,
        });
    }
    if row >= height {
        return Err(WireError::RowOutOfRange { what, row, height });
    }
    Ok(row)
}
