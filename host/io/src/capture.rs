//! A scan's captured data, from either source the camera can deliver — a stack of images or a
//! row dump — as batches of temporal rows (SPEC §1) for the line decoder.
//!
//! Memory: a stack is read in bands of camera rows sized by a budget (re-reading the files
//! for each band), a dump record by record in batches of a few rows; either way the samples
//! held at once are one batch, never the whole scan unless it fits the budget.

use std::io::Read;
use std::path::{Path, PathBuf};

use crate::dump::{band_rows, DumpError, DumpReader};
use crate::error::{Error, Result};
use crate::plan_file::MethodPlan;
use crate::stack::Stack;

/// What to do with a dump record that fails its check (CRC, row index, a repeated row) or
/// rows the file does not hold (it ends early).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BadRows {
    /// Refuse the capture with the error that names the file, record and row.
    #[default]
    Refuse,
    /// Decode every good row; the bad or missing ones get no candidates and the flag
    /// [`fsm_core::PixelFlags::NO_DATA`], and are listed ([`BadRecord`]).
    Skip,
}

/// A dump record that was skipped ([`BadRows::Skip`]), or the end of a short file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BadRecord {
    /// 0-based record number (none for a good record that came too late, after a bad one
    /// had given its row up).
    pub record: Option<u32>,
    /// The row the record's bytes claim, when it is where a dump in row order has it (record
    /// `r` claiming row `r`): that row is then given up at once instead of waited for.
    pub row_hint: Option<u32>,
    /// The error, naming the file, record, offset and row.
    pub error: String,
}

/// Where the captured rows come from.
#[derive(Clone, Debug)]
pub enum Capture {
    /// A folder of images.
    Stack(Stack),
    /// A row-dump file (header already checked against the plan and the file length).
    Dump {
        /// The file.
        path: PathBuf,
        /// Pixels per row.
        width: u32,
        /// Rows.
        height: u32,
        /// Sensor bit depth.
        bit_depth: u8,
        /// Frames per row.
        frames: usize,
        /// What a bad record does.
        bad_rows: BadRows,
    },
}

/// Rows of samples, each sample-major (`frame·W + x`), with their camera row indices.
#[derive(Clone, Debug, Default)]
pub struct RowBatch {
    /// Camera row of each row in the batch.
    pub rows: Vec<u32>,
    /// `rows.len() · M · W` samples.
    pub samples: Vec<u16>,
    /// Dump records skipped while the batch was read ([`BadRows::Skip`]).
    pub bad: Vec<BadRecord>,
}

impl Capture {
    /// Opens and checks a stack of images against `plan`.
    pub fn open_stack(
        dir: &Path,
        plan: impl Into<MethodPlan>,
        bit_depth: Option<u8>,
    ) -> Result<Self> {
        Ok(Capture::Stack(Stack::open(dir, plan, bit_depth)?))
    }

    /// Opens and checks a row dump against `plan` (header, fingerprint, frames, and length
    /// unless bad rows are skipped: a short file then only misses its last rows).
    pub fn open_dump(
        path: &Path,
        plan: impl Into<MethodPlan>,
        bit_depth: Option<u8>,
        bad_rows: BadRows,
    ) -> Result<Self> {
        let reader = DumpReader::open_with(path, bad_rows == BadRows::Skip)?;
        reader.check(plan, bit_depth)?;
        let h = reader.header();
        Ok(Capture::Dump {
            path: path.to_path_buf(),
            width: h.width,
            height: h.height,
            bit_depth: h.bit_depth,
            frames: h.frames as usize,
            bad_rows,
        })
    }

    /// Pixels per row.
    pub fn width(&self) -> u32 {
        match self {
            Capture::Stack(s) => s.width(),
            Capture::Dump { width, .. } => *width,
        }
    }

    /// Rows.
    pub fn height(&self) -> u32 {
        match self {
            Capture::Stack(s) => s.height(),
            Capture::Dump { height, .. } => *height,
        }
    }

    /// Sensor bit depth.
    pub fn bit_depth(&self) -> u8 {
        match self {
            Capture::Stack(s) => s.bit_depth(),
            Capture::Dump { bit_depth, .. } => *bit_depth,
        }
    }

    /// Samples of one temporal row, `M·W`.
    pub fn row_len(&self) -> usize {
        match self {
            Capture::Stack(s) => s.row_len(),
            Capture::Dump { width, frames, .. } => *width as usize * frames,
        }
    }

    /// The whole capture's size as `u16` samples, bytes.
    pub fn samples_bytes(&self) -> u64 {
        self.row_len() as u64 * 2 * self.height() as u64
    }

    /// The source, for messages.
    pub fn describe(&self) -> String {
        match self {
            Capture::Stack(s) => format!("image stack {}", s.dir().display()),
            Capture::Dump { path, .. } => format!("row dump {}", path.display()),
        }
    }

    /// Reads the samples of camera row `y` into `samples` (length [`Capture::row_len`]).
    pub fn read_row(&self, y: u32, samples: &mut [u16]) -> Result<()> {
        if y >= self.height() {
            return Err(Error::Usage(format!(
                "row {y} is outside the {} rows of the {}",
                self.height(),
                self.describe()
            )));
        }
        match self {
            Capture::Stack(s) => Ok(s.read_band(y..y + 1, samples)?),
            Capture::Dump { path, .. } => {
                let mut row = Vec::with_capacity(samples.len());
                DumpReader::open(path)?.find_row(y, &mut row)?;
                samples.copy_from_slice(&row);
                Ok(())
            }
        }
    }

    /// Batches of rows within `budget_bytes` of samples: bands of consecutive rows for a
    /// stack (never more than the stack's own size at once); for a dump, records in file
    /// order, at most `max_dump_rows` at a time.
    pub fn batches(&self, budget_bytes: u64, max_dump_rows: u32) -> Result<RowBatches<'_>> {
        let row_bytes = self.row_len() as u64 * 2;
        let budget = match self {
            // Never hold more than the stack's own size: an 8-bit stack widened to the
            // decoder's u16 samples is read in (at least) two bands.
            Capture::Stack(stack) => budget_bytes.min(stack.own_bytes()),
            Capture::Dump { .. } => budget_bytes,
        };
        let rows = band_rows(budget, row_bytes, self.height());
        Ok(match self {
            Capture::Stack(stack) => RowBatches::Stack {
                stack,
                next: 0,
                rows,
            },
            Capture::Dump { path, bad_rows, .. } => RowBatches::from_dump(
                DumpReader::open_with(path, *bad_rows == BadRows::Skip)?.boxed(),
                rows.min(max_dump_rows),
                *bad_rows,
            ),
        })
    }
}

/// An iterator-like source of [`RowBatch`]es (see [`Capture::batches`]).
#[allow(clippy::large_enum_variant)] // one per decode
pub enum RowBatches<'a> {
    /// Bands of a stack.
    Stack {
        /// The stack.
        stack: &'a Stack,
        /// First row of the next band.
        next: u32,
        /// Rows per band.
        rows: u32,
    },
    /// Records of a dump.
    Dump {
        /// The open dump (a file, or bytes in memory).
        reader: DumpReader<Box<dyn Read + Send + 'a>>,
        /// Rows per batch.
        rows: u32,
        /// What a bad record does.
        bad_rows: BadRows,
        /// The input ended early (skipping bad rows): no more records.
        ended: bool,
    },
}

impl<'a> RowBatches<'a> {
    /// Batches of at most `rows` records from a dump (file or memory) already checked against
    /// the plan.
    pub fn from_dump(
        reader: DumpReader<Box<dyn Read + Send + 'a>>,
        rows: u32,
        bad_rows: BadRows,
    ) -> Self {
        RowBatches::Dump {
            reader,
            rows: rows.max(1),
            bad_rows,
            ended: false,
        }
    }

    /// What a bad dump record does ([`BadRows::Refuse`] for a stack, which has no records).
    pub fn bad_rows(&self) -> BadRows {
        match self {
            RowBatches::Stack { .. } => BadRows::Refuse,
            RowBatches::Dump { bad_rows, .. } => *bad_rows,
        }
    }

    /// Pixels per row.
    pub fn width(&self) -> u32 {
        match self {
            RowBatches::Stack { stack, .. } => stack.width(),
            RowBatches::Dump { reader, .. } => reader.header().width,
        }
    }

    /// Rows of the scan.
    pub fn height(&self) -> u32 {
        match self {
            RowBatches::Stack { stack, .. } => stack.height(),
            RowBatches::Dump { reader, .. } => reader.header().height,
        }
    }

    /// Sensor bit depth.
    pub fn bit_depth(&self) -> u8 {
        match self {
            RowBatches::Stack { stack, .. } => stack.bit_depth(),
            RowBatches::Dump { reader, .. } => reader.header().bit_depth,
        }
    }

    /// Samples of one temporal row, `M·W`.
    pub fn row_len(&self) -> usize {
        match self {
            RowBatches::Stack { stack, .. } => stack.row_len(),
            RowBatches::Dump { reader, .. } => reader.header().samples_per_row(),
        }
    }

    /// Most rows a batch holds.
    pub fn rows_per_batch(&self) -> u32 {
        match self {
            RowBatches::Stack { rows, .. } | RowBatches::Dump { rows, .. } => *rows,
        }
    }

    /// Fills `batch` with the next rows; `false` when every row has been delivered.
    pub fn next_batch(&mut self, batch: &mut RowBatch) -> Result<bool, Error> {
        batch.rows.clear();
        batch.bad.clear();
        match self {
            RowBatches::Stack { stack, next, rows } => {
                let height = stack.height();
                if *next >= height {
                    return Ok(false);
                }
                let end = (*next + *rows).min(height);
                batch.rows.extend(*next..end);
                batch.samples.resize(batch.rows.len() * stack.row_len(), 0);
                stack.read_band(*next..end, &mut batch.samples)?;
                *next = end;
                Ok(true)
            }
            RowBatches::Dump {
                reader,
                rows,
                bad_rows,
                ended,
            } => {
                batch.samples.clear();
                while batch.rows.len() < *rows as usize && !*ended {
                    match reader.next_row(&mut batch.samples) {
                        Ok(Some(row)) => batch.rows.push(row),
                        Ok(None) => *ended = true,
                        Err(e) if *bad_rows == BadRows::Skip && e.spoils_one_record() => {
                            batch.bad.push(bad_record(&e));
                        }
                        Err(e @ DumpError::Truncated { .. }) if *bad_rows == BadRows::Skip => {
                            batch.bad.push(bad_record(&e));
                            *ended = true;
                        }
                        Err(e) => return Err(e.into()),
                    }
                }
                Ok(!batch.rows.is_empty() || !batch.bad.is_empty())
            }
        }
    }
}

/// A skipped record, with the row it gives up at once when that is safe (see
/// [`BadRecord::row_hint`]).
fn bad_record(e: &DumpError) -> BadRecord {
    let (record, row_hint) = match e {
        DumpError::Record { record, .. } | DumpError::Truncated { record, .. } => {
            (Some(*record), e.row().filter(|row| row == record))
        }
        DumpError::DuplicateRow { second, .. } => (Some(*second), None),
        _ => (None, None),
    };
    BadRecord {
        record,
        row_hint,
        error: e.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image_files::ImageFormat;
    use crate::patterns::{write_pattern_set, PatternOptions};
    use crate::progress::Progress;
    use fsm_core::{GroupCount, ScanPlan};

    fn stack(sixteen_bit: bool, dir: &Path) -> (ScanPlan, Capture) {
        let plan = ScanPlan::efsm(64, 16, GroupCount::One);
        let options = PatternOptions {
            width: None,
            height: 6,
            sixteen_bit,
            format: ImageFormat::Png,
            response: None,
        };
        write_pattern_set(&plan, &options, None, dir, false, &Progress::hidden()).unwrap();
        let capture = Capture::open_stack(dir, plan, None).unwrap();
        (plan, capture)
    }

    #[test]
    fn bands_never_exceed_the_stacks_own_size() {
        let dir = tempfile::tempdir().unwrap();
        let (_, wide) = stack(true, &dir.path().join("16"));
        assert_eq!(wide.batches(u64::MAX, 8).unwrap().rows_per_batch(), 6);
        // 8-bit samples widen to u16: two bands hold the stack's own size.
        let (_, narrow) = stack(false, &dir.path().join("8"));
        assert_eq!(narrow.batches(u64::MAX, 8).unwrap().rows_per_batch(), 3);
        let mut batches = narrow.batches(u64::MAX, 8).unwrap();
        let mut batch = RowBatch::default();
        let mut rows = Vec::new();
        while batches.next_batch(&mut batch).unwrap() {
            assert_eq!(batch.samples.len(), batch.rows.len() * narrow.row_len());
            rows.extend_from_slice(&batch.rows);
        }
        assert_eq!(rows, (0..6).collect::<Vec<_>>());
    }

    #[test]
    fn a_row_reads_the_same_from_a_stack_and_its_dump() {
        let dir = tempfile::tempdir().unwrap();
        let (plan, capture) = stack(true, &dir.path().join("s"));
        let Capture::Stack(s) = &capture else {
            unreachable!()
        };
        let dump = dir.path().join("s.dump");
        crate::dump::write_dump_from_stack(plan, s, &dump, 1 << 10, &Progress::hidden()).unwrap();
        let from_dump = Capture::open_dump(&dump, plan, None, BadRows::Refuse).unwrap();
        let mut a = vec![0u16; capture.row_len()];
        let mut b = vec![0u16; capture.row_len()];
        for y in [0, 3, 5] {
            capture.read_row(y, &mut a).unwrap();
            from_dump.read_row(y, &mut b).unwrap();
            assert_eq!(a, b);
        }
        assert!(capture.read_row(6, &mut a).is_err());
    }
}
