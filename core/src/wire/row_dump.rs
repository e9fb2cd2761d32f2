//! Row dumps: the raw temporal rows of a scan, as a camera streams them instead of images.
//!
//! A dump is a 64-byte header followed by one fixed-length record per camera row, so it can be
//! read and decoded one row at a time in constant memory. Little-endian throughout.
//!
//! Header:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | `[u8; 8]` | magic `FSMROWS\0` |
//! | 8 | u16 | version, 2 |
//! | 10 | u16 | header length, 64 |
//! | 12 | u8 | sensor bit depth, 1–16 |
//! | 13 | `[u8; 3]` | reserved, 0 |
//! | 16 | u64 | pattern fingerprint ([`ScanPlan::pattern_fingerprint`]); in version 1, the plan fingerprint |
//! | 24 | u32 | width `W` (pixels per row) |
//! | 28 | u32 | height `H` (rows in the scan) |
//! | 32 | u32 | frames `M` per row (the plan's whole sequence, references included) |
//! | 36 | `[u8; 24]` | reserved, 0 |
//! | 60 | u32 | CRC-32 of bytes 0–59 |
//!
//! Record (`8 + 2·W·M` bytes), in any row order:
//!
//! | offset | type | field |
//! |---|---|---|
//! | 0 | u32 | row index `y < H` |
//! | 4 | `[u16; W·M]` | samples, sample-major: frame `i`, pixel `x` at `i·W + x` (the line decoder's input) |
//! | 4 + 2·W·M | u32 | CRC-32 of the row index and the samples |
//!
//! Version 1 differs only in the fingerprint: it named the whole plan, decoder settings
//! included, so a version-1 dump decodes only with the plan it was recorded with
//! ([`RecordedWith::Plan`]). Both versions are read; version 2 is written.

use super::PlanIdentity;
use super::{
    begin_header, check_record, open_header, seal_header, seal_record, WireError, Writer,
    HEADER_LEN,
};
use crate::plan::ScanPlan;

/// Magic bytes of a row dump.
pub const MAGIC: [u8; 8] = *b"FSMROWS\0";
/// Version this build writes (it also reads version 1).
pub const VERSION: u16 = 2;

const WHAT: &str = "row dump";

/// What the rows of a dump were captured with: the header's fingerprint and its meaning.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RecordedWith {
    /// The pattern sequence's fingerprint (version 2): any plan that shows these patterns
    /// decodes the dump, whatever its decoder settings.
    Patterns(u64),
    /// The whole plan's fingerprint (version 1): only that plan decodes the dump.
    Plan(u64),
}

impl RecordedWith {
    /// The fingerprint the header holds.
    pub fn fingerprint(self) -> u64 {
        match self {
            RecordedWith::Patterns(f) | RecordedWith::Plan(f) => f,
        }
    }

    /// The header field's name, for messages.
    pub fn field(self) -> &'static str {
        match self {
            RecordedWith::Patterns(_) => "pattern_fingerprint",
            RecordedWith::Plan(_) => "plan_fingerprint",
        }
    }

    /// Whether a plan of identity `plan` may decode rows recorded so.
    pub fn admits(self, plan: &PlanIdentity) -> bool {
        match self {
            RecordedWith::Patterns(f) => f == plan.patterns,
            RecordedWith::Plan(f) => plan.has_plan_fingerprint(f),
        }
    }
}

/// The header of a row dump.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RowDumpHeader {
    /// Sensor bit depth, 1–16.
    pub bit_depth: u8,
    /// The fingerprint of what the rows were captured with (the format version follows it).
    pub recorded_with: RecordedWith,
    /// Pixels per row.
    pub width: u32,
    /// Rows in the scan.
    pub height: u32,
    /// Frames per row.
    pub frames: u32,
}

impl RowDumpHeader {
    /// The header of a dump of `plan`'s frames.
    pub fn for_plan(plan: &ScanPlan, width: u32, height: u32, bit_depth: u8) -> Self {
        Self::for_patterns(
            plan.pattern_fingerprint(),
            plan.sequence_len(),
            width,
            height,
            bit_depth,
        )
    }

    /// The header of a dump of `frames` frames per row whose patterns have the fingerprint
    /// `patterns`: any method's plan (`crate::methods::MethodPlan::row_dump_header`).
    pub fn for_patterns(
        patterns: u64,
        frames: usize,
        width: u32,
        height: u32,
        bit_depth: u8,
    ) -> Self {
        RowDumpHeader {
            bit_depth,
            recorded_with: RecordedWith::Patterns(patterns),
            width,
            height,
            frames: frames as u32,
        }
    }

    /// The 64 header bytes, in the version [`RowDumpHeader::recorded_with`] implies (so a
    /// version-1 header is copied as it was read).
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let mut out = [0u8; HEADER_LEN];
        let version = match self.recorded_with {
            RecordedWith::Patterns(_) => VERSION,
            RecordedWith::Plan(_) => 1,
        };
        let mut w = begin_header(&MAGIC, version, &mut out);
        w.u8(self.bit_depth);
        w.put(&[0; 3]);
        w.u64(self.recorded_with.fingerprint());
        w.u32(self.width);
        w.u32(self.height);
        w.u32(self.frames);
        seal_header(&mut out);
        out
    }

    /// Reads and checks a header (magic, version, CRC, field ranges).
    pub fn decode(bytes: &[u8]) -> Result<Self, WireError> {
        let (version, mut r) = open_header(WHAT, &MAGIC, VERSION, bytes)?;
        let bit_depth = r.u8();
        let _reserved: [u8; 3] = r.take();
        let fingerprint = r.u64();
        let header = RowDumpHeader {
            bit_depth,
            recorded_with: match version {
                1 => RecordedWith::Plan(fingerprint),
                _ => RecordedWith::Patterns(fingerprint),
            },
            width: r.u32(),
            height: r.u32(),
            frames: r.u32(),
        };
        let field = |field: &'static str, value: u64| WireError::Field {
            what: WHAT,
            field,
            value,
        };
        if !(1..=16).contains(&header.bit_depth) {
            return Err(field("bit_depth", header.bit_depth as u64));
        }
        if header.width == 0 {
            return Err(field("width", 0));
        }
        if header.frames == 0 {
            return Err(field("frames", 0));
        }
        if header.record_len().is_none() {
            return Err(field("width", header.width as u64));
        }
        Ok(header)
    }

    /// Checks that the dump was made with `plan`'s patterns (or, for a version-1 dump, with
    /// `plan` itself).
    pub fn check_plan(&self, plan: &ScanPlan) -> Result<(), WireError> {
        self.check_identity(&plan.identity(), plan.sequence_len())
    }

    /// Checks that the dump was made with the patterns of a plan of identity `plan` and
    /// `frames` frames per row: any method's plan (`crate::methods::MethodPlan::check_row_dump`).
    pub fn check_identity(&self, plan: &PlanIdentity, frames: usize) -> Result<(), WireError> {
        if !self.recorded_with.admits(plan) {
            return Err(WireError::Field {
                what: WHAT,
                field: self.recorded_with.field(),
                value: self.recorded_with.fingerprint(),
            });
        }
        if self.frames as usize != frames {
            return Err(WireError::Field {
                what: WHAT,
                field: "frames",
                value: self.frames as u64,
            });
        }
        Ok(())
    }

    /// Samples per record, `W·M`.
    pub fn samples_per_row(&self) -> usize {
        self.width as usize * self.frames as usize
    }

    /// Bytes of one record, or `None` if it would not fit in memory addresses.
    pub fn record_len(&self) -> Option<usize> {
        (self.width as usize)
            .checked_mul(self.frames as usize)?
            .checked_mul(2)?
            .checked_add(8)
    }
}

/// One decoded record: its row index and its samples, still little-endian bytes.
#[derive(Clone, Copy, Debug)]
pub struct RowRecord<'a> {
    /// Camera row.
    pub row: u32,
    samples: &'a [u8],
}

impl RowRecord<'_> {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.samples.len() / 2
    }

    /// Whether the record holds no samples.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// Sample `i` (`i·W + x` for frame `i`, pixel `x`).
    pub fn sample(&self, i: usize) -> u16 {
        u16::from_le_bytes([self.samples[2 * i], self.samples[2 * i + 1]])
    }

    /// The samples in order (for appending them where they go, without clearing it first).
    pub fn codes(&self) -> impl ExactSizeIterator<Item = u16> + '_ {
        self.samples
            .chunks_exact(2)
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
    }

    /// Copies the samples into `out` (length [`RowRecord::len`]).
    pub fn copy_to(&self, out: &mut [u16]) -> Result<(), WireError> {
        if out.len() != self.len() {
            return Err(WireError::BufferTooSmall {
                what: WHAT,
                needed: self.len(),
                got: out.len(),
            });
        }
        self.copy_range_to(0, out)
    }

    /// Copies the samples `first..first + out.len()` into `out` (one frame's pixels of a
    /// row slice: one range check, not one per sample as [`RowRecord::sample`]); a range
    /// past the record is [`WireError::Truncated`], in bytes.
    pub fn copy_range_to(&self, first: usize, out: &mut [u16]) -> Result<(), WireError> {
        let end = first.saturating_add(out.len()).saturating_mul(2);
        let bytes = self
            .samples
            .get(first.saturating_mul(2)..end)
            .ok_or(WireError::Truncated {
                what: WHAT,
                needed: end,
                got: self.samples.len(),
            })?;
        for (o, b) in out.iter_mut().zip(bytes.chunks_exact(2)) {
            *o = u16::from_le_bytes([b[0], b[1]]);
        }
        Ok(())
    }
}

/// Writes the record of `row` with `samples` (`W·M` of them) into `out`; returns its length.
pub fn encode_record(
    header: &RowDumpHeader,
    row: u32,
    samples: &[u16],
    out: &mut [u8],
) -> Result<usize, WireError> {
    let len = header.record_len().ok_or(WireError::Field {
        what: WHAT,
        field: "width",
        value: header.width as u64,
    })?;
    if samples.len() != header.samples_per_row() {
        return Err(WireError::BufferTooSmall {
            what: WHAT,
            needed: header.samples_per_row(),
            got: samples.len(),
        });
    }
    if row >= header.height {
        return Err(WireError::RowOutOfRange {
            what: WHAT,
            row,
            height: header.height,
        });
    }
    let got = out.len();
    let out = out.get_mut(..len).ok_or(WireError::BufferTooSmall {
        what: WHAT,
        needed: len,
        got,
    })?;
    let mut w = Writer::new(&mut *out);
    w.u32(row);
    for &s in samples {
        w.u16(s);
    }
    seal_record(out, len);
    Ok(len)
}

/// Reads the record at the start of `bytes`, checking length, CRC and row range.
pub fn decode_record<'a>(
    header: &RowDumpHeader,
    bytes: &'a [u8],
) -> Result<RowRecord<'a>, WireError> {
    let len = header.record_len().ok_or(WireError::Field {
        what: WHAT,
        field: "width",
        value: header.width as u64,
    })?;
    if bytes.len() < len {
        return Err(WireError::Truncated {
            what: WHAT,
            needed: len,
            got: bytes.len(),
        });
    }
    let (row, rest) = bytes[..len].split_at(4);
    let (samples, crc) = rest.split_at(len - 8);
    let row = check_record_parts(header, row, samples, crc)?;
    Ok(RowRecord { row, samples })
}

/// Checks a record read in its three parts (so that its samples can be read straight to
/// where they are decoded): the row index's 4 bytes, the `2·W·M` bytes of the samples and the
/// CRC's 4 bytes. Checks lengths, CRC and row range; returns the row.
pub fn check_record_parts(
    header: &RowDumpHeader,
    row: &[u8],
    samples: &[u8],
    crc: &[u8],
) -> Result<u32, WireError> {
    let needed = 2 * header.samples_per_row();
    let (Ok(row_bytes), Ok(crc), true) = (
        <[u8; 4]>::try_from(row),
        <[u8; 4]>::try_from(crc),
        samples.len() == needed,
    ) else {
        return Err(WireError::Truncated {
            what: WHAT,
            needed: needed + 8,
            got: row.len() + samples.len() + crc.len(),
        });
    };
    let row = u32::from_le_bytes(row_bytes);
    check_record(
        WHAT,
        header.height,
        row,
        &[&row_bytes, samples],
        u32::from_le_bytes(crc),
    )
}
