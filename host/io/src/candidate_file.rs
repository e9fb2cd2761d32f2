//! Candidate files: what `fsm decode` writes and the camera streams, in
//! [`fsm_core::wire::candidates`]'s bytes: a [`CandidateHeader`] then one record per camera
//! row, in row order (row 0 first), nothing after the last. Each record carries its own
//! CRC-32; the reader also checks the row order, the count and the end of the file.

use std::fs::File;
use std::io::{BufReader, Read, Write};
use std::path::{Path, PathBuf};

use fsm_core::wire::candidates::{self, CandidateHeader};
use fsm_core::wire::HEADER_LEN;
use fsm_core::PixelCandidates;

use crate::dump::{read_full, read_up_to};
use crate::error::Wire;

/// Candidates a pixel may carry in the host's files (`K` of [`PixelCandidates`]).
pub const CANDIDATE_CAPACITY: usize = 16;

/// A pixel's candidates as the host decodes and stores them.
pub type HostCandidates = PixelCandidates<CANDIDATE_CAPACITY>;

/// File name `fsm decode` gives the candidate file in its output folder.
pub const CANDIDATE_FILE_NAME: &str = "candidates.fsmc";

/// What is wrong with a candidate file.
#[derive(Debug, thiserror::Error)]
pub enum CandidateFileError {
    /// Reading the file failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The header is unreadable.
    #[error("{}: header: {source}", path.display())]
    Header {
        /// The file.
        path: PathBuf,
        /// What the header check found.
        source: Wire,
    },
    /// The file ends inside or before the record of `row`.
    #[error("{}: truncated in the record of row {row} (byte offset {offset}): {got} bytes present, {needed} needed; the header announces {height} rows", path.display())]
    Truncated {
        /// The file.
        path: PathBuf,
        /// The row whose record is cut.
        row: u32,
        /// Byte offset of the record.
        offset: u64,
        /// Bytes present.
        got: usize,
        /// Bytes needed.
        needed: usize,
        /// Rows announced.
        height: u32,
    },
    /// A record fails its checks (CRC, structure, range).
    #[error("{}: record of row {row} (byte offset {offset}): {source}", path.display())]
    Record {
        /// The file.
        path: PathBuf,
        /// The row expected at this position.
        row: u32,
        /// Byte offset of the record.
        offset: u64,
        /// What the record check found.
        source: Wire,
    },
    /// Records out of order.
    #[error("{}: record at byte offset {offset} holds row {found}, row {expected} was expected (records are in row order)", path.display())]
    RowOrder {
        /// The file.
        path: PathBuf,
        /// Byte offset of the record.
        offset: u64,
        /// Expected row.
        expected: u32,
        /// Row found.
        found: u32,
    },
    /// Bytes after the last record.
    #[error("{}: bytes follow the record of the last row {}", path.display(), height.saturating_sub(1))]
    TrailingBytes {
        /// The file.
        path: PathBuf,
        /// Rows announced.
        height: u32,
    },
}

/// Writes a candidate file: the header, then the records of rows `0..H` in order.
pub struct CandidateWriter<W> {
    out: W,
    header: CandidateHeader,
    next_row: u32,
    bytes: Vec<u8>,
}

impl<W: Write> CandidateWriter<W> {
    /// Writes the header.
    pub fn new(mut out: W, header: CandidateHeader) -> std::io::Result<Self> {
        out.write_all(&header.encode())?;
        Ok(CandidateWriter {
            out,
            header,
            next_row: 0,
            bytes: Vec::new(),
        })
    }

    /// The header.
    pub fn header(&self) -> &CandidateHeader {
        &self.header
    }

    /// The row the next record must be.
    pub fn next_row(&self) -> u32 {
        self.next_row
    }

    /// Encodes and writes the record of the next row.
    pub fn write_row<const K: usize>(
        &mut self,
        row: u32,
        pixels: &[PixelCandidates<K>],
    ) -> std::io::Result<()> {
        let mut bytes = std::mem::take(&mut self.bytes);
        encode_row(&self.header, row, pixels, &mut bytes)?;
        let result = self.write_record(row, &bytes);
        self.bytes = bytes;
        result
    }

    /// Writes an already encoded record (see [`encode_row`]) of the next row.
    pub fn write_record(&mut self, row: u32, record: &[u8]) -> std::io::Result<()> {
        if row != self.next_row {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "candidate record of row {row} given where row {} is due",
                    self.next_row
                ),
            ));
        }
        self.out.write_all(record)?;
        self.next_row += 1;
        Ok(())
    }

    /// Checks that every row was written; returns the output.
    pub fn finish(self) -> std::io::Result<W> {
        if self.next_row != self.header.height {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!(
                    "candidate file ends after {} of {} rows",
                    self.next_row, self.header.height
                ),
            ));
        }
        Ok(self.out)
    }
}

/// Encodes the record of `row` into `out` (cleared first).
pub fn encode_row<const K: usize>(
    header: &CandidateHeader,
    row: u32,
    pixels: &[PixelCandidates<K>],
    out: &mut Vec<u8>,
) -> std::io::Result<()> {
    out.clear();
    out.resize(candidates::record_len(pixels), 0);
    candidates::encode_record(header, row, pixels, out)
        .map(|_| ())
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidInput, e.to_string()))
}

/// Reads a candidate file row by row, in constant memory.
pub struct CandidateReader<R> {
    path: PathBuf,
    reader: R,
    header: CandidateHeader,
    next_row: u32,
    offset: u64,
    bytes: Vec<u8>,
}

impl CandidateReader<BufReader<File>> {
    /// Opens a candidate file and reads its header.
    pub fn open(path: &Path) -> Result<Self, CandidateFileError> {
        let file = File::open(path).map_err(|source| CandidateFileError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::new(BufReader::with_capacity(1 << 20, file), path)
    }
}

impl<R: Read> CandidateReader<R> {
    /// Reads the header from `reader`; `path` names the source in errors.
    pub fn new(mut reader: R, path: &Path) -> Result<Self, CandidateFileError> {
        let path = path.to_path_buf();
        let mut head = [0u8; HEADER_LEN];
        let got = read_full(&mut reader, &mut head).map_err(|source| CandidateFileError::Io {
            path: path.clone(),
            source,
        })?;
        let header =
            CandidateHeader::decode(&head[..got]).map_err(|e| CandidateFileError::Header {
                path: path.clone(),
                source: Wire(e),
            })?;
        Ok(CandidateReader {
            path,
            reader,
            header,
            next_row: 0,
            offset: HEADER_LEN as u64,
            bytes: Vec::new(),
        })
    }

    /// The header.
    pub fn header(&self) -> &CandidateHeader {
        &self.header
    }

    /// Reads the next row's candidates into `out` (one entry per pixel); returns the row, or
    /// `None` after the last row (then no byte may follow).
    pub fn next_row<const K: usize>(
        &mut self,
        out: &mut [PixelCandidates<K>],
    ) -> Result<Option<u32>, CandidateFileError> {
        let io = |path: &Path, source| CandidateFileError::Io {
            path: path.to_path_buf(),
            source,
        };
        let row = self.next_row;
        let height = self.header.height;
        if row == height {
            let mut probe = [0u8; 1];
            if read_full(&mut self.reader, &mut probe).map_err(|e| io(&self.path, e))? > 0 {
                return Err(CandidateFileError::TrailingBytes {
                    path: self.path.clone(),
                    height,
                });
            }
            return Ok(None);
        }
        let truncated = |got, needed| CandidateFileError::Truncated {
            path: self.path.clone(),
            row,
            offset: self.offset,
            got,
            needed,
            height,
        };
        self.bytes.resize(8, 0);
        let got =
            read_full(&mut self.reader, &mut self.bytes[..8]).map_err(|e| io(&self.path, e))?;
        if got < 8 {
            return Err(truncated(got, 8));
        }
        let payload = u32::from_le_bytes(self.bytes[4..8].try_into().expect("4 bytes")) as usize;
        let max = self.header.max_record_len().unwrap_or(usize::MAX);
        let len = payload.saturating_add(candidates::RECORD_OVERHEAD);
        if len > max {
            // Let the core name the field before reading a huge length.
            let e = candidates::decode_record(&self.header, &self.bytes[..8])
                .expect_err("over-long payload");
            return Err(CandidateFileError::Record {
                path: self.path.clone(),
                row,
                offset: self.offset,
                source: Wire(e),
            });
        }
        self.bytes.truncate(8);
        let got = read_up_to(&mut self.reader, len - 8, &mut self.bytes)
            .map_err(|e| io(&self.path, e))?;
        if got < len - 8 {
            return Err(truncated(8 + got, len));
        }
        let record = candidates::decode_record(&self.header, &self.bytes).map_err(|e| {
            CandidateFileError::Record {
                path: self.path.clone(),
                row,
                offset: self.offset,
                source: Wire(e),
            }
        })?;
        if record.row != row {
            return Err(CandidateFileError::RowOrder {
                path: self.path.clone(),
                offset: self.offset,
                expected: row,
                found: record.row,
            });
        }
        record
            .read_into(&self.header, out)
            .map_err(|e| CandidateFileError::Record {
                path: self.path.clone(),
                row,
                offset: self.offset,
                source: Wire(e),
            })?;
        self.offset += len as u64;
        self.next_row += 1;
        Ok(Some(row))
    }
}
