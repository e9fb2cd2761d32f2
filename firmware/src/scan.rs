//! The loop body: one row-dump record in, that row's candidate record out.
//!
//! A thin layer over `fsm_core`: the record is checked and unpacked by
//! `wire::row_dump::decode_record`, decoded by `Decoder::decode_row`, and packed by
//! `wire::candidates::encode_record`, so the bytes are the ones `fsm decode` writes on the host.

use core::fmt;

use fsm_core::wire::candidates::{self, CandidateHeader};
use fsm_core::wire::row_dump::{self, RowDumpHeader};
use fsm_core::wire::WireError;
use fsm_core::{Decoder, Row, RowError, ScanPlan};

use crate::limits::{Pixel, CANDIDATE_CAPACITY, LANES, MAX_ROW_SAMPLES, MAX_WIDTH};

/// The geometry of a scan and the headers of its two kinds of streams.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Scan {
    /// Header of the rows coming in (and of raw rows going out).
    pub rows: RowDumpHeader,
    /// Header of the candidate records going out.
    pub candidates: CandidateHeader,
}

/// Why a scan's geometry is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScanError {
    /// A field out of range: `width`, `height` or `bit_depth`.
    Field {
        /// The field.
        field: &'static str,
        /// Its value.
        value: u32,
    },
    /// Rows of this size do not fit in the camera's buffers.
    TooLarge {
        /// Pixels per row.
        width: u32,
        /// Frames per row.
        frames: u32,
    },
}

impl Scan {
    /// A scan of `plan` with rows of `width` pixels, `height` rows and `bit_depth`-bit samples,
    /// if the camera's buffers hold such rows.
    pub fn new(plan: &ScanPlan, width: u32, height: u32, bit_depth: u8) -> Result<Self, ScanError> {
        let field = |field, value| Err(ScanError::Field { field, value });
        if width == 0 {
            return field("width", 0);
        }
        if height == 0 {
            return field("height", 0);
        }
        if !(1..=16).contains(&bit_depth) {
            return field("bit_depth", bit_depth as u32);
        }
        let frames = plan.sequence_len();
        let samples = (width as usize).checked_mul(frames);
        if width as usize > MAX_WIDTH || samples.is_none_or(|s| s > MAX_ROW_SAMPLES) {
            return Err(ScanError::TooLarge {
                width,
                frames: frames as u32,
            });
        }
        Ok(Scan {
            rows: RowDumpHeader::for_plan(plan, width, height, bit_depth),
            candidates: CandidateHeader {
                capacity: CANDIDATE_CAPACITY as u16,
                plan_fingerprint: plan.fingerprint(),
                width,
                height,
            },
        })
    }

    /// The scan of a row dump's header, checked against `plan`.
    pub fn of_dump(plan: &ScanPlan, header: &RowDumpHeader) -> Result<Self, DumpError> {
        header.check_plan(plan).map_err(DumpError::Wire)?;
        Scan::new(plan, header.width, header.height, header.bit_depth).map_err(DumpError::Scan)
    }

    /// Bytes of one incoming row-dump record.
    pub fn record_len(&self) -> usize {
        // Bounded by MAX_ROW_SAMPLES in `new`.
        8 + 2 * self.rows.samples_per_row()
    }
}

/// Why a row dump cannot be scanned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DumpError {
    /// The dump's header or a record breaks the format (or names another plan).
    Wire(WireError),
    /// Its rows do not fit.
    Scan(ScanError),
    /// The records do not fill the dump: `len` bytes after the header, records of `record_len`.
    Length {
        /// Bytes after the header.
        len: usize,
        /// Bytes per record.
        record_len: usize,
    },
    /// A row failed.
    Row(RowFailure),
}

/// Why a row record was refused; nothing was written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RowFailure {
    /// The record does not have this scan's record length.
    Length {
        /// Row index in the record, if it has 4 bytes.
        row: Option<u32>,
        /// Bytes a record has.
        expected: usize,
        /// Bytes received.
        got: usize,
    },
    /// The record breaks the row-dump format (CRC, row range).
    Wire(WireError),
    /// The decoder refused the row.
    Decode {
        /// Row index.
        row: u32,
        /// What the decoder said.
        error: RowError,
    },
    /// The row's output record could not be written (a buffer smaller than the scan needs).
    Output {
        /// Row index.
        row: u32,
        /// What the encoder said.
        error: WireError,
    },
}

impl fmt::Display for ScanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ScanError::Field { field, value } => {
                write!(f, "field {field} has the invalid value {value}")
            }
            ScanError::TooLarge { width, frames } => write!(
                f,
                "rows of {width} pixels x {frames} frames do not fit (at most {MAX_WIDTH} pixels \
                 and {MAX_ROW_SAMPLES} samples per row)"
            ),
        }
    }
}

impl fmt::Display for RowFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            RowFailure::Length { row, expected, got } => {
                if let Some(row) = row {
                    write!(f, "row {row}: ")?;
                }
                write!(f, "record of {got} bytes, expected {expected}")
            }
            RowFailure::Wire(e) => write!(f, "{e}"),
            RowFailure::Decode { row, error } => write!(f, "row {row}: {error}"),
            RowFailure::Output { row, error } => write!(f, "row {row}: {error}"),
        }
    }
}

impl fmt::Display for DumpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DumpError::Wire(e) => write!(f, "{e}"),
            DumpError::Scan(e) => write!(f, "scan refused: {e}"),
            DumpError::Length { len, record_len } => write!(
                f,
                "row dump: {len} bytes of records is not a whole number of {record_len}-byte records"
            ),
            DumpError::Row(e) => write!(f, "{e}"),
        }
    }
}

/// Per-pixel measurement around the decoder (the firmware benchmark); [`NoProbe`] decodes
/// the row with one `decode_row` call.
pub trait Probe {
    /// Decode pixel by pixel (`Decoder::decode_pixel`, same results as `decode_row`) and call
    /// [`Probe::before`] and [`Probe::after`] around each pixel.
    const PER_PIXEL: bool;
    /// Just before pixel `x` is decoded.
    fn before(&mut self, _x: usize) {}
    /// Just after pixel `x` was decoded into `pixel`.
    fn after(&mut self, _x: usize, _pixel: &Pixel) {}
    /// Just before a row is decoded in one call (`PER_PIXEL` false).
    fn before_row(&mut self) {}
    /// Just after a row was decoded in one call (`PER_PIXEL` false).
    fn after_row(&mut self) {}
    /// After the decoder's tables were built, before the first row.
    fn tables_built(&mut self) {}
    /// After a row's record of `len` bytes was written (whatever `PER_PIXEL` says).
    fn end_row(&mut self, _row: u32, _len: usize) {}
}

/// No measurement.
pub struct NoProbe;

impl Probe for NoProbe {
    const PER_PIXEL: bool = false;
}

/// The buffers one row needs.
pub struct RowBuffers<'a> {
    /// `Decoder::scratch_len` floats or more.
    pub scratch: &'a mut [f32],
    /// `W·M` samples or more.
    pub samples: &'a mut [u16],
    /// `W` pixels or more.
    pub pixels: &'a mut [Pixel],
}

/// Checks and unpacks one row-dump record into `buffers.samples`; returns its row index.
pub fn unpack_row(scan: &Scan, record: &[u8], samples: &mut [u16]) -> Result<u32, RowFailure> {
    let expected = scan.record_len();
    if record.len() != expected {
        let row = record
            .get(..4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
        return Err(RowFailure::Length {
            row,
            expected,
            got: record.len(),
        });
    }
    let checked = row_dump::decode_record(&scan.rows, record).map_err(RowFailure::Wire)?;
    let n = scan.rows.samples_per_row();
    checked
        .copy_to(&mut samples[..n])
        .map_err(RowFailure::Wire)?;
    Ok(checked.row)
}

/// Decodes one row-dump record and writes its candidate record into `out`; returns the row
/// index and the record's length.
pub fn decode_row<P: Probe>(
    decoder: &Decoder<'_>,
    scan: &Scan,
    record: &[u8],
    buffers: &mut RowBuffers<'_>,
    out: &mut [u8],
    probe: &mut P,
) -> Result<(u32, usize), RowFailure> {
    let row = unpack_row(scan, record, buffers.samples)?;
    let width = scan.rows.width as usize;
    let n = scan.rows.samples_per_row();
    let frames = Row {
        frames: &buffers.samples[..n],
        width,
        bit_depth: scan.rows.bit_depth,
        column_limits: None,
    };
    let pixels = &mut buffers.pixels[..width];
    let decoded = if P::PER_PIXEL {
        pixels.iter_mut().enumerate().try_for_each(|(x, pixel)| {
            probe.before(x);
            decoder.decode_pixel(&frames, x, buffers.scratch, pixel)?;
            probe.after(x, pixel);
            Ok(())
        })
    } else {
        probe.before_row();
        let decoded =
            decoder.decode_row_lanes::<LANES, CANDIDATE_CAPACITY>(&frames, buffers.scratch, pixels);
        probe.after_row();
        decoded
    };
    decoded.map_err(|error| RowFailure::Decode { row, error })?;
    let len =
        candidates::encode_record(&scan.candidates, row, pixels, out).map_err(RowFailure::Wire)?;
    Ok((row, len))
}

/// Checks one row-dump record and writes it again, as the camera streams a raw row from its
/// sample memory (for decoding on the host); returns the row index and the record's length.
pub fn raw_row(
    scan: &Scan,
    record: &[u8],
    samples: &mut [u16],
    out: &mut [u8],
) -> Result<(u32, usize), RowFailure> {
    let row = unpack_row(scan, record, samples)?;
    let n = scan.rows.samples_per_row();
    let len =
        row_dump::encode_record(&scan.rows, row, &samples[..n], out).map_err(RowFailure::Wire)?;
    Ok((row, len))
}
