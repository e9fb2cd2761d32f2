//! Row dumps on disk: reading them record by record in constant memory, and writing them
//! (from a stack with `fsm convert`, or from any source of temporal rows).
//!
//! The bytes are [`fsm_core::wire::row_dump`]'s (64-byte header, fixed-length records with a
//! CRC-32 each); this module adds what a file needs around them: the whole file is checked
//! against its header's promise (`H` records, no byte more), every row must appear exactly
//! once, and every error names the file, the record, its byte offset and its row.

use std::collections::HashMap;
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use fsm_core::wire::row_dump::{self, RecordedWith, RowDumpHeader};
use fsm_core::wire::{WireError, HEADER_LEN};

use crate::error::{Error, Wire};
use crate::outputs::StagedFile;
use crate::progress::Progress;
use crate::stack::Stack;

/// What is wrong with a row dump.
#[derive(Debug, thiserror::Error)]
pub enum DumpError {
    /// Reading the file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The dump.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The header is unreadable (magic, version, CRC, field range).
    #[error("{}: header: {source}", path.display())]
    Header {
        /// The dump.
        path: PathBuf,
        /// What the header check found.
        source: Wire,
    },
    /// The dump was recorded with other patterns than the plan's.
    #[error("{}: recorded with the patterns of fingerprint {found:016x}, but the plan given shows patterns {expected:016x}; decode with a plan of the patterns the camera showed (`fsm plan --check` prints a plan's pattern fingerprint)", path.display())]
    PatternMismatch {
        /// The dump.
        path: PathBuf,
        /// The header's pattern fingerprint.
        found: u64,
        /// The plan's.
        expected: u64,
    },
    /// A version-1 dump (which names the whole plan) given another plan.
    #[error("{}: a version-1 dump, recorded with plan fingerprint {found:016x}, but the plan given has fingerprint {expected:016x}; version-1 dumps decode only with the plan they were recorded with, decoder settings included", path.display())]
    PlanMismatch {
        /// The dump.
        path: PathBuf,
        /// The header's plan fingerprint.
        found: u64,
        /// The plan's.
        expected: u64,
    },
    /// Frames per row differ from the plan's sequence.
    #[error("{}: {found} frames per row, the plan's sequence has {expected}", path.display())]
    FrameCount {
        /// The dump.
        path: PathBuf,
        /// The header's frame count.
        found: u32,
        /// The plan's.
        expected: usize,
    },
    /// The dump holds no rows.
    #[error("{}: the header announces 0 rows", path.display())]
    Empty {
        /// The dump.
        path: PathBuf,
    },
    /// The file ends inside (or before) a record.
    #[error("{}: truncated in record {record} (byte offset {offset}{}): {got} of its {needed} bytes present; the header announces {height} rows", path.display(), row.map(|r| format!(", row {r} by its first bytes")).unwrap_or_default())]
    Truncated {
        /// The dump.
        path: PathBuf,
        /// 0-based record number.
        record: u32,
        /// Byte offset of the record.
        offset: u64,
        /// The row index the record's first bytes state, if present (unverified).
        row: Option<u32>,
        /// Bytes of the record present.
        got: usize,
        /// Bytes a record has.
        needed: usize,
        /// Rows the header announces.
        height: u32,
    },
    /// A record fails its check (CRC names the row; row outside the image).
    #[error("{}: record {record} (byte offset {offset}): {source}", path.display())]
    Record {
        /// The dump.
        path: PathBuf,
        /// 0-based record number.
        record: u32,
        /// Byte offset of the record.
        offset: u64,
        /// What the record check found.
        source: Wire,
    },
    /// The same row twice.
    #[error("{}: row {row} appears twice (records {first} and {second})", path.display())]
    DuplicateRow {
        /// The dump.
        path: PathBuf,
        /// The row.
        row: u32,
        /// Record number of its first appearance.
        first: u32,
        /// Record number of the second.
        second: u32,
    },
    /// Bytes after the last record.
    #[error("{}: {extra} bytes follow the header's {height} records", path.display())]
    TrailingBytes {
        /// The dump.
        path: PathBuf,
        /// How many (at least).
        extra: u64,
        /// Rows the header announces.
        height: u32,
    },
    /// The sensor bit depth given differs from the header's.
    #[error("{}: recorded at {found} bits, but --bit-depth {requested} was given", path.display())]
    BitDepth {
        /// The dump.
        path: PathBuf,
        /// The header's.
        found: u8,
        /// The option's.
        requested: u8,
    },
}

impl DumpError {
    /// Whether the error is about one record only (a failed check, a repeated row): the
    /// reader has passed it and the records after it can still be read.
    pub fn spoils_one_record(&self) -> bool {
        matches!(
            self,
            DumpError::Record { .. } | DumpError::DuplicateRow { .. }
        )
    }

    /// The row an error is about, when it names one.
    pub fn row(&self) -> Option<u32> {
        match self {
            DumpError::Truncated { row, .. } => *row,
            DumpError::Record { source, .. } => match source.0 {
                WireError::RecordCrc { row, .. } | WireError::RowOutOfRange { row, .. } => {
                    Some(row)
                }
                _ => None,
            },
            DumpError::DuplicateRow { row, .. } => Some(*row),
            _ => None,
        }
    }
}

/// Reads a dump record by record, each record's samples straight into the caller's buffer;
/// holds a record number per row.
pub struct DumpReader<R> {
    path: PathBuf,
    reader: R,
    header: RowDumpHeader,
    record_len: usize,
    record: u32,
    /// The row index and CRC of the record being read.
    row_bytes: [u8; 4],
    crc_bytes: [u8; 4],
    /// Record number that delivered each row read so far (grows with the records actually
    /// present, never with what a header claims).
    seen: HashMap<u32, u32>,
}

impl DumpReader<BufReader<File>> {
    /// Opens a dump file and checks its header and its length against the header's promise
    /// (so a truncated or padded file is refused before any work, and before a record buffer
    /// is allocated).
    pub fn open(path: &Path) -> Result<Self, DumpError> {
        Self::open_with(path, false)
    }

    /// [`DumpReader::open`], but a file shorter than its header promises is accepted when
    /// `allow_short` (its reading then ends with [`DumpError::Truncated`] where the bytes end:
    /// the rows before it are whole and checked, the others missing).
    pub fn open_with(path: &Path, allow_short: bool) -> Result<Self, DumpError> {
        let io = |source| DumpError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut file = File::open(path).map_err(io)?;
        let file_len = file.metadata().map_err(io)?.len();
        let mut head = [0u8; HEADER_LEN];
        let got = read_full(&mut file, &mut head).map_err(io)?;
        let header = RowDumpHeader::decode(&head[..got]).map_err(|e| DumpError::Header {
            path: path.to_path_buf(),
            source: Wire(e),
        })?;
        if header.height == 0 {
            return Err(DumpError::Empty {
                path: path.to_path_buf(),
            });
        }
        let record_len = header
            .record_len()
            .expect("checked by RowDumpHeader::decode") as u64;
        let height = header.height;
        let expected = HEADER_LEN as u64 + record_len * height as u64;
        if file_len < expected && !allow_short {
            let record = ((file_len - HEADER_LEN as u64) / record_len) as u32;
            let offset = HEADER_LEN as u64 + record as u64 * record_len;
            let got = (file_len - offset) as usize;
            let mut row = None;
            if got >= 4 {
                let mut b = [0u8; 4];
                file.seek(SeekFrom::Start(offset)).map_err(io)?;
                file.read_exact(&mut b).map_err(io)?;
                row = Some(u32::from_le_bytes(b));
            }
            return Err(DumpError::Truncated {
                path: path.to_path_buf(),
                record,
                offset,
                row,
                got,
                needed: record_len as usize,
                height,
            });
        }
        if file_len > expected {
            return Err(DumpError::TrailingBytes {
                path: path.to_path_buf(),
                extra: file_len - expected,
                height,
            });
        }
        file.seek(SeekFrom::Start(0)).map_err(io)?;
        DumpReader::new(BufReader::with_capacity(1 << 20, file), path)
    }
}

impl<R: Read> DumpReader<R> {
    /// Reads and checks the header from `reader`; `path` names the source in errors.
    pub fn new(mut reader: R, path: &Path) -> Result<Self, DumpError> {
        let path = path.to_path_buf();
        let mut head = [0u8; HEADER_LEN];
        let got = read_full(&mut reader, &mut head).map_err(|source| DumpError::Io {
            path: path.clone(),
            source,
        })?;
        let header = RowDumpHeader::decode(&head[..got]).map_err(|e| DumpError::Header {
            path: path.clone(),
            source: Wire(e),
        })?;
        if header.height == 0 {
            return Err(DumpError::Empty { path });
        }
        let record_len = header
            .record_len()
            .expect("checked by RowDumpHeader::decode");
        Ok(DumpReader {
            path,
            reader,
            header,
            record_len,
            record: 0,
            row_bytes: [0; 4],
            crc_bytes: [0; 4],
            seen: HashMap::new(),
        })
    }

    /// The same reader behind a boxed `Read` (to hold file and memory dumps alike).
    pub fn boxed<'a>(self) -> DumpReader<Box<dyn Read + Send + 'a>>
    where
        R: Send + 'a,
    {
        DumpReader {
            path: self.path,
            reader: Box::new(self.reader),
            header: self.header,
            record_len: self.record_len,
            record: self.record,
            row_bytes: self.row_bytes,
            crc_bytes: self.crc_bytes,
            seen: self.seen,
        }
    }

    /// The header.
    pub fn header(&self) -> &RowDumpHeader {
        &self.header
    }

    /// The source's name.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Bytes of one record.
    pub fn record_len(&self) -> usize {
        self.record_len
    }

    /// Checks that the dump was made with `plan` (fingerprint, or the one a version-1 plan had,
    /// and frame count) and, if given, at `bit_depth`.
    pub fn check(
        &self,
        plan: impl Into<crate::plan_file::MethodPlan>,
        bit_depth: Option<u8>,
    ) -> Result<(), DumpError> {
        let plan = plan.into();
        let identity = plan.patterns().identity();
        let recorded = self.header.recorded_with;
        if !recorded.admits(&identity) {
            let path = self.path.clone();
            return Err(match recorded {
                RecordedWith::Patterns(found) => DumpError::PatternMismatch {
                    path,
                    found,
                    expected: identity.patterns,
                },
                RecordedWith::Plan(found) => DumpError::PlanMismatch {
                    path,
                    found,
                    expected: identity.plan,
                },
            });
        }
        if self.header.frames as usize != plan.frame_count() {
            return Err(DumpError::FrameCount {
                path: self.path.clone(),
                found: self.header.frames,
                expected: plan.frame_count(),
            });
        }
        match bit_depth {
            Some(b) if b != self.header.bit_depth => Err(DumpError::BitDepth {
                path: self.path.clone(),
                found: self.header.bit_depth,
                requested: b,
            }),
            _ => Ok(()),
        }
    }

    /// Reads the next record, checks it, and appends its samples (`W·M`, sample-major) to
    /// `samples`; returns its row, or `None` after the header's last record (then no byte may
    /// follow). Memory grows only with the bytes actually read. After an error that
    /// [spoils one record](DumpError::spoils_one_record) the reader stands on the next record.
    pub fn next_row(&mut self, samples: &mut Vec<u16>) -> Result<Option<u32>, DumpError> {
        let offset = HEADER_LEN as u64 + self.record as u64 * self.record_len as u64;
        let io = |path: &Path, source| DumpError::Io {
            path: path.to_path_buf(),
            source,
        };
        if self.record == self.header.height {
            let mut probe = [0u8; 1];
            let extra = read_full(&mut self.reader, &mut probe).map_err(|e| io(&self.path, e))?;
            if extra > 0 {
                return Err(DumpError::TrailingBytes {
                    path: self.path.clone(),
                    extra: extra as u64,
                    height: self.header.height,
                });
            }
            return Ok(None);
        }
        // The samples are read straight to where they are decoded: the row index, then the
        // samples into `samples` (grown with the bytes read: a damaged header could claim any
        // length), then the CRC, checked over them in place.
        let start = samples.len();
        let read = self
            .read_record_into(samples)
            .map_err(|e| io(&self.path, e));
        let got = match read {
            Ok(got) => got,
            Err(e) => {
                samples.truncate(start);
                return Err(e);
            }
        };
        if got < self.record_len {
            samples.truncate(start);
            return Err(DumpError::Truncated {
                path: self.path.clone(),
                record: self.record,
                offset,
                row: (got >= 4).then(|| u32::from_le_bytes(self.row_bytes)),
                got,
                needed: self.record_len,
                height: self.header.height,
            });
        }
        let checked = row_dump::check_record_parts(
            &self.header,
            &self.row_bytes,
            bytemuck::cast_slice(&samples[start..]),
            &self.crc_bytes,
        );
        let row = match checked {
            Ok(row) => row,
            Err(e) => {
                samples.truncate(start);
                // The record was read whole: the reader stands on the next one, so a caller
                // that skips bad rows can go on.
                self.record += 1;
                return Err(DumpError::Record {
                    path: self.path.clone(),
                    record: self.record - 1,
                    offset,
                    source: Wire(e),
                });
            }
        };
        if let Some(&first) = self.seen.get(&row) {
            samples.truncate(start);
            self.record += 1;
            return Err(DumpError::DuplicateRow {
                path: self.path.clone(),
                row,
                first,
                second: self.record - 1,
            });
        }
        self.seen.insert(row, self.record);
        // The samples are little-endian codes (nothing to do on a little-endian host).
        for s in &mut samples[start..] {
            *s = u16::from_le(*s);
        }
        self.record += 1;
        Ok(Some(row))
    }

    /// Reads one record's row index, samples (appended to `samples`, as raw bytes) and CRC;
    /// returns the bytes read (fewer than a record where the input ends).
    fn read_record_into(&mut self, samples: &mut Vec<u16>) -> std::io::Result<usize> {
        const STEP: usize = 1 << 19;
        let mut got = read_full(&mut self.reader, &mut self.row_bytes)?;
        if got < 4 {
            return Ok(got);
        }
        let (start, n) = (samples.len(), self.header.samples_per_row());
        while samples.len() - start < n {
            let filled = samples.len() - start;
            let step = (n - filled).min(STEP.max(filled));
            samples.resize(start + filled + step, 0);
            let part = read_full(
                &mut self.reader,
                bytemuck::cast_slice_mut(&mut samples[start + filled..]),
            )?;
            got += part;
            if part < 2 * step {
                return Ok(got);
            }
        }
        Ok(got + read_full(&mut self.reader, &mut self.crc_bytes)?)
    }

    /// Reads records until the one of row `row`; its samples replace the content of `samples`.
    pub fn find_row(&mut self, row: u32, samples: &mut Vec<u16>) -> Result<(), DumpError> {
        if row >= self.header.height {
            return Err(DumpError::Record {
                path: self.path.clone(),
                record: self.record,
                offset: 0,
                source: Wire(WireError::RowOutOfRange {
                    what: "row dump",
                    row,
                    height: self.header.height,
                }),
            });
        }
        loop {
            samples.clear();
            match self.next_row(samples)? {
                Some(r) if r == row => return Ok(()),
                Some(_) => {}
                None => break,
            }
        }
        // Unreachable for a complete dump (H distinct rows below H), kept as an error.
        Err(DumpError::Truncated {
            path: self.path.clone(),
            record: self.record,
            offset: HEADER_LEN as u64 + self.record as u64 * self.record_len as u64,
            row: Some(row),
            got: 0,
            needed: self.record_len,
            height: self.header.height,
        })
    }
}

/// Appends up to `len` bytes from `reader` to `buf` (fewer if the input ends first); returns
/// the bytes appended. The buffer grows with the bytes that actually arrive, so a header
/// claiming a huge record cannot make a reader allocate more than the input holds.
pub(crate) fn read_up_to(
    reader: &mut impl Read,
    len: usize,
    buf: &mut Vec<u8>,
) -> std::io::Result<usize> {
    const STEP: usize = 1 << 20;
    let base = buf.len();
    while buf.len() - base < len {
        let start = buf.len();
        let chunk = (len - (start - base)).min(STEP.max(start - base));
        buf.resize(start + chunk, 0);
        let got = read_full(reader, &mut buf[start..])?;
        buf.truncate(start + got);
        if got < chunk {
            break;
        }
    }
    Ok(buf.len() - base)
}

/// Reads until `buf` is full or the input ends; returns the bytes read.
pub(crate) fn read_full(reader: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match reader.read(&mut buf[got..]) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

/// Writes a dump: header first, then records (any row order, each row once).
pub struct DumpWriter<W> {
    out: W,
    header: RowDumpHeader,
    bytes: Vec<u8>,
    written: Vec<bool>,
    count: u32,
}

impl<W: Write> DumpWriter<W> {
    /// Writes the header.
    pub fn new(mut out: W, header: RowDumpHeader) -> std::io::Result<Self> {
        out.write_all(&header.encode())?;
        let len = header.record_len().ok_or_else(|| {
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "row records too large")
        })?;
        Ok(DumpWriter {
            out,
            header,
            bytes: vec![0; len],
            written: vec![false; header.height as usize],
            count: 0,
        })
    }

    /// Writes the record of `row`.
    pub fn write_row(&mut self, row: u32, samples: &[u16]) -> std::io::Result<()> {
        let invalid = |m: String| std::io::Error::new(std::io::ErrorKind::InvalidInput, m);
        let len = row_dump::encode_record(&self.header, row, samples, &mut self.bytes)
            .map_err(|e| invalid(e.to_string()))?;
        if std::mem::replace(&mut self.written[row as usize], true) {
            return Err(invalid(format!("row {row} written twice")));
        }
        self.count += 1;
        self.out.write_all(&self.bytes[..len])
    }

    /// Checks that every row was written and returns the output.
    pub fn finish(self) -> std::io::Result<W> {
        if self.count != self.header.height {
            let missing = self.written.iter().position(|w| !w).unwrap_or(0);
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "{} of {} rows written; row {missing} is missing",
                    self.count, self.header.height
                ),
            ));
        }
        Ok(self.out)
    }
}

/// Rows per band for a memory budget: a band of `rows` costs `rows · row_bytes`.
pub fn band_rows(budget_bytes: u64, row_bytes: u64, height: u32) -> u32 {
    (budget_bytes / row_bytes.max(1)).clamp(1, height.max(1) as u64) as u32
}

/// Converts a stack into a dump file (`fsm convert`), band by band within `budget_bytes`,
/// records in row order; the file appears whole or not at all.
pub fn write_dump_from_stack(
    plan: impl Into<crate::plan_file::MethodPlan>,
    stack: &Stack,
    out: &Path,
    budget_bytes: u64,
    progress: &Progress,
) -> Result<RowDumpHeader, Error> {
    let plan = plan.into();
    let header = RowDumpHeader {
        bit_depth: stack.bit_depth(),
        recorded_with: RecordedWith::Patterns(plan.pattern_fingerprint()),
        width: stack.width(),
        height: stack.height(),
        frames: plan.frame_count() as u32,
    };
    let mut file = StagedFile::create(out)?;
    let io = |e| Error::io(out, e);
    let mut writer = DumpWriter::new(file.writer(), header).map_err(io)?;
    let row_len = stack.row_len();
    let rows_per_band = band_rows(budget_bytes, row_len as u64 * 2, stack.height());
    let mut band = vec![0u16; rows_per_band as usize * row_len];
    progress.start(stack.height() as u64, "converting rows");
    let mut y0 = 0;
    while y0 < stack.height() {
        let y1 = (y0 + rows_per_band).min(stack.height());
        let band = &mut band[..(y1 - y0) as usize * row_len];
        stack.read_band(y0..y1, band)?;
        for (y, samples) in (y0..y1).zip(band.chunks_exact(row_len)) {
            writer.write_row(y, samples).map_err(io)?;
        }
        progress.advance((y1 - y0) as u64);
        y0 = y1;
    }
    writer.finish().map_err(io)?;
    progress.finish();
    file.commit()?;
    Ok(header)
}
