//! The loop body: one row-dump record in, that row's candidate record out.
//!
//! A thin layer over `fsm_core`: the record is checked by `wire::row_dump::decode_record`,
//! unpacked and decoded slice by slice of pixels (`MethodDecoder::decode_row_lanes`: every
//! method's decoder is per pixel, FSM's and the baselines' alike, so a slice's candidates are
//! the whole row's), and packed by
//! `wire::candidates::encode_record`, so the bytes are the ones `fsm decode` writes on the host.
//! Only a slice's samples are ever unpacked ([`crate::limits::SLICE_SAMPLES`]): a 4096-pixel BFSM
//! row needs its 6.3 MB record, not that again as samples.

use core::fmt;

use fsm_core::wire::candidates::{self, CandidateHeader};
use fsm_core::wire::row_dump::{self, RowDumpHeader, RowRecord};
use fsm_core::wire::WireError;
use fsm_core::{MethodDecoder, MethodPlan, Row, RowError};

use crate::limits::{Pixel, CANDIDATE_CAPACITY, LANES, MAX_FRAMES, MAX_ROW_SAMPLES, MAX_WIDTH};

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
    /// A scan of `plan` (any method's) with rows of `width` pixels, `height` rows and
    /// `bit_depth`-bit samples, if the camera's buffers hold such rows.
    pub fn new(
        plan: impl Into<MethodPlan>,
        width: u32,
        height: u32,
        bit_depth: u8,
    ) -> Result<Self, ScanError> {
        let plan: MethodPlan = plan.into();
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
        let frames = plan.frame_count();
        let samples = (width as usize).checked_mul(frames);
        if width as usize > MAX_WIDTH
            || frames > MAX_FRAMES
            || samples.is_none_or(|s| s > MAX_ROW_SAMPLES)
        {
            return Err(ScanError::TooLarge {
                width,
                frames: frames as u32,
            });
        }
        Ok(Scan {
            rows: plan.row_dump_header(width, height, bit_depth),
            candidates: CandidateHeader {
                capacity: CANDIDATE_CAPACITY as u16,
                plan_fingerprint: plan.fingerprint(),
                width,
                height,
            },
        })
    }

    /// The scan of a row dump's header, checked against `plan`.
    pub fn of_dump(plan: impl Into<MethodPlan>, header: &RowDumpHeader) -> Result<Self, DumpError> {
        let plan: MethodPlan = plan.into();
        plan.check_row_dump(header).map_err(DumpError::Wire)?;
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
                "rows of {width} pixels x {frames} frames do not fit (at most {MAX_WIDTH} pixels, \
                 {MAX_FRAMES} frames and {MAX_ROW_SAMPLES} samples per row)"
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
    /// Decode pixel by pixel (`MethodDecoder::decode_pixel`, same results as `decode_row`) and call
    /// [`Probe::before`] and [`Probe::after`] around each pixel.
    const PER_PIXEL: bool;
    /// Just before pixel `x` is decoded.
    fn before(&mut self, _x: usize) {}
    /// Just after pixel `x` was decoded into `pixel`.
    fn after(&mut self, _x: usize, _pixel: &Pixel) {}
    /// Just before a slice of a row is decoded in one call (`PER_PIXEL` false).
    fn before_row(&mut self) {}
    /// Just after a slice of a row was decoded in one call (`PER_PIXEL` false).
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
    /// `MethodPlan::scratch_len_lanes` floats or more (none for a baseline).
    pub scratch: &'a mut [f32],
    /// The samples of a slice of the row: `M` (frames per row) or more; a slice is as many
    /// pixels as fit, a multiple of [`LANES`] when more than that fit.
    pub samples: &'a mut [u16],
    /// `W` pixels or more.
    pub pixels: &'a mut [Pixel],
}

/// Checks one row-dump record against the scan (length, CRC, row range): its row index and
/// samples, still bytes.
pub fn check_row<'r>(scan: &Scan, record: &'r [u8]) -> Result<RowRecord<'r>, RowFailure> {
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
    row_dump::decode_record(&scan.rows, record).map_err(RowFailure::Wire)
}

/// Pixels per slice for rows of `width` pixels and `frames` frames in `samples` samples of
/// room: all that fit, rounded down to whole lanes when more than one lane fits. `None` when
/// not even one pixel fits.
pub fn slice_width(width: usize, frames: usize, samples: usize) -> Option<usize> {
    let fit = samples / frames.max(1);
    let fit = if fit >= LANES { fit - fit % LANES } else { fit };
    (fit > 0).then(|| fit.min(width))
}

/// Unpacks pixels `x0..x0 + n` of a row of `width` pixels into `out` (`M·n` samples,
/// sample-major: `out[i·n + x]`), a frame's range at a time.
fn unpack_slice(
    record: &RowRecord<'_>,
    width: usize,
    x0: usize,
    n: usize,
    out: &mut [u16],
) -> Result<(), WireError> {
    if n == width {
        // The whole row: its samples are already sample-major, one copy.
        return record.copy_range_to(0, out);
    }
    for (i, frame) in out.chunks_exact_mut(n).enumerate() {
        record.copy_range_to(i * width + x0, frame)?;
    }
    Ok(())
}

/// Decodes one row-dump record and writes its candidate record into `out`; returns the row
/// index and the record's length. The row is unpacked and decoded slice by slice
/// ([`slice_width`]); the candidates do not depend on the slices.
pub fn decode_row<P: Probe>(
    decoder: &MethodDecoder<'_>,
    scan: &Scan,
    record: &[u8],
    buffers: &mut RowBuffers<'_>,
    out: &mut [u8],
    probe: &mut P,
) -> Result<(u32, usize), RowFailure> {
    let record = check_row(scan, record)?;
    let row = record.row;
    let width = scan.rows.width as usize;
    let frames = scan.rows.samples_per_row() / width;
    let Some(slice) = slice_width(width, frames, buffers.samples.len()) else {
        return Err(RowFailure::Output {
            row,
            error: WireError::BufferTooSmall {
                what: "row slice samples",
                needed: frames,
                got: buffers.samples.len(),
            },
        });
    };
    let pixels = &mut buffers.pixels[..width];
    let mut x0 = 0;
    while x0 < width {
        let n = slice.min(width - x0);
        let samples = &mut buffers.samples[..n * frames];
        // A checked record holds every frame of the row.
        unpack_slice(&record, width, x0, n, samples)
            .map_err(|error| RowFailure::Output { row, error })?;
        let frames = Row {
            frames: samples,
            width: n,
            bit_depth: scan.rows.bit_depth,
            column_limits: None,
        };
        let pixels = &mut pixels[x0..x0 + n];
        let decoded = if P::PER_PIXEL {
            pixels.iter_mut().enumerate().try_for_each(|(x, pixel)| {
                probe.before(x0 + x);
                decoder.decode_pixel(&frames, x, buffers.scratch, pixel)?;
                probe.after(x0 + x, pixel);
                Ok(())
            })
        } else {
            probe.before_row();
            let decoded = decoder.decode_row_lanes::<LANES, CANDIDATE_CAPACITY>(
                &frames,
                buffers.scratch,
                pixels,
            );
            probe.after_row();
            decoded
        };
        decoded.map_err(|error| RowFailure::Decode { row, error })?;
        x0 += n;
    }
    let len =
        candidates::encode_record(&scan.candidates, row, pixels, out).map_err(RowFailure::Wire)?;
    Ok((row, len))
}

/// Checks one row-dump record and writes it again, as the camera streams a raw row from its
/// sample memory (for decoding on the host): the checked record's bytes are the record
/// `row_dump::encode_record` would write. Returns the row index and the record's length.
pub fn raw_row(scan: &Scan, record: &[u8], out: &mut [u8]) -> Result<(u32, usize), RowFailure> {
    let row = check_row(scan, record)?.row;
    let Some(out) = out.get_mut(..record.len()) else {
        return Err(RowFailure::Output {
            row,
            error: WireError::BufferTooSmall {
                what: "raw row record",
                needed: record.len(),
                got: out.len(),
            },
        });
    };
    out.copy_from_slice(record);
    Ok((row, record.len()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::limits::{MAX_FRAMES, SLICE_SAMPLES};
    use crate::reference;
    use crate::scene::MirrorScene;
    use fsm_core::wire::HEADER_LEN;
    use fsm_core::{
        CodeEnsemblePlan, GroupCount, LineScanPlan, MicroPhaseShiftPlan, PhaseShiftPlan, ScanPlan,
    };

    #[test]
    fn slices_are_whole_lanes_of_what_fits() {
        assert_eq!(slice_width(4096, 770, SLICE_SAMPLES), Some(340));
        assert_eq!(slice_width(100, 770, SLICE_SAMPLES), Some(100));
        assert_eq!(slice_width(50, 10, 4 * LANES * 10 + 9), Some(4 * LANES));
        assert_eq!(slice_width(50, 10, 3 * 10), Some(3.min(LANES)));
        assert_eq!(slice_width(50, 10, 9), None);
    }

    #[test]
    fn wide_rows_fit_and_wider_ones_are_refused_by_name() {
        let bfsm = ScanPlan::paper_bfsm();
        assert!(Scan::new(bfsm, 4096, 2, 12).is_ok());
        let refused = Scan::new(bfsm, 4097, 2, 12).unwrap_err();
        assert_eq!(
            refused,
            ScanError::TooLarge {
                width: 4097,
                frames: 770
            }
        );
        assert!(refused.to_string().contains("4097 pixels x 770 frames"));
        // A baseline's rows are held to the same buffers: line scanning shows a frame per
        // column, so a wide projector's rows are refused by name too.
        let wide = LineScanPlan {
            projector_columns: 65_535,
            ..LineScanPlan::paper()
        };
        assert!(Scan::new(LineScanPlan::paper(), 4096, 2, 12).is_ok());
        assert_eq!(
            Scan::new(wide, 1, 2, 12),
            Err(ScanError::TooLarge {
                width: 1,
                frames: 65_537
            })
        );
        // Every valid plan's rows fit a slice of one lane (MAX_FRAMES is a guard): the
        // largest, BFSM with N = 4096 (limits.rs), has far fewer frames.
        let mut largest = ScanPlan::paper_bfsm();
        largest.projector_columns = 8192;
        largest.band.period_columns = 16384;
        largest.band.count = 4096;
        largest.transform_size = 4096;
        let largest = largest.with_clean();
        assert_eq!(largest.validate(), Ok(()));
        assert!(largest.sequence_len() <= MAX_FRAMES);
    }

    /// The candidate file of a dump decoded with `slice` pixels per slice (the samples buffer
    /// sized for it).
    /// Decodes pixel by pixel (`MethodDecoder::decode_pixel`), as the benchmark does.
    struct EachPixel;

    impl Probe for EachPixel {
        const PER_PIXEL: bool = true;
    }

    fn decode_in_slices<P: Probe>(
        plan: &MethodPlan,
        dump: &[u8],
        slice: usize,
        probe: &mut P,
    ) -> Vec<u8> {
        let header = RowDumpHeader::decode(dump).unwrap();
        let scan = Scan::of_dump(plan, &header).unwrap();
        let frames = plan.frame_count();
        let mut tables = vec![0.0; plan.tables_len()];
        let decoder = MethodDecoder::new(plan, &mut tables).unwrap();
        let mut scratch = vec![0.0; plan.scratch_len_lanes::<LANES>()];
        let mut samples = vec![0u16; slice * frames];
        let mut pixels = vec![Pixel::new(); header.width as usize];
        let mut buffers = RowBuffers {
            scratch: &mut scratch,
            samples: &mut samples,
            pixels: &mut pixels,
        };
        let mut out = scan.candidates.encode().to_vec();
        let mut record = vec![0u8; scan.candidates.max_record_len().unwrap()];
        for input in dump[HEADER_LEN..].chunks_exact(scan.record_len()) {
            let (_, len) =
                decode_row(&decoder, &scan, input, &mut buffers, &mut record, probe).unwrap();
            out.extend_from_slice(&record[..len]);
        }
        out
    }

    #[test]
    fn a_row_decoded_in_slices_is_the_whole_row_decoded_on_the_host() {
        let line_scan = LineScanPlan {
            projector_columns: 96,
            ..LineScanPlan::paper()
        };
        let plans: [MethodPlan; 6] = [
            ScanPlan::paper_efsm(GroupCount::One).into(),
            ScanPlan::paper_efsm(GroupCount::Two).into(),
            PhaseShiftPlan::for_projector(96).into(),
            MicroPhaseShiftPlan::spread(96, 16.0, 4.0, 7).into(),
            CodeEnsemblePlan::for_projector(96).into(),
            line_scan.into(),
        ];
        for plan in plans {
            // 37 pixels: slices of 1, 3, one lane, two lanes, and a last slice cut short.
            let dump = MirrorScene::for_plan(plan, 37, 3).dump(plan);
            let host = reference::decode_dump(plan, &dump).unwrap();
            let census = reference::census(&host).unwrap();
            // FSM finds both lights of the mirror pixels; a baseline one light a pixel.
            let several = if plan.as_fsm().is_some() { 2 } else { 1 };
            assert!(
                census.by_count[several..].iter().sum::<usize>() > 0,
                "{}: {census:?}",
                plan.name()
            );
            for slice in [1, 3, LANES, 2 * LANES, 37] {
                let sliced = decode_in_slices(&plan, &dump, slice, &mut NoProbe);
                assert_eq!(reference::compare(&host, &sliced), Ok(()), "slice {slice}");
                assert_eq!(host, sliced, "slice {slice}");
                let each = decode_in_slices(&plan, &dump, slice, &mut EachPixel);
                assert_eq!(host, each, "slice {slice}, pixel by pixel");
            }
        }
    }

    #[test]
    fn a_raw_row_is_the_record_it_came_from() {
        let plan = ScanPlan::paper_efsm(GroupCount::Two);
        let dump = MirrorScene::for_plan(plan, 9, 2).dump(plan);
        let header = RowDumpHeader::decode(&dump).unwrap();
        let scan = Scan::of_dump(plan, &header).unwrap();
        let input = &dump[HEADER_LEN..HEADER_LEN + scan.record_len()];
        let mut out = vec![0u8; scan.record_len()];
        assert_eq!(raw_row(&scan, input, &mut out), Ok((0, input.len())));
        assert_eq!(out, input);
        // Damaged: refused by the CRC, nothing written.
        let mut bad = input.to_vec();
        bad[10] ^= 1;
        let mut out = vec![0u8; scan.record_len()];
        assert!(matches!(
            raw_row(&scan, &bad, &mut out),
            Err(RowFailure::Wire(WireError::RecordCrc { row: 0, .. }))
        ));
        assert!(out.iter().all(|&b| b == 0));
        // Too small an output buffer: named.
        let mut small = vec![0u8; 10];
        assert!(matches!(
            raw_row(&scan, input, &mut small),
            Err(RowFailure::Output { row: 0, .. })
        ));
    }
}
