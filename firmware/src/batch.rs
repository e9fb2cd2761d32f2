//! Scanning a whole row dump held in memory: the camera's replay mode, and what the QEMU
//! cross-check runs (the dump placed in RAM by QEMU's loader).
//!
//! The output is a complete candidate file: the 64-byte header, then one record per row of
//! the dump, in the dump's order — the bytes the host's decode writes for the same dump.

use core::fmt;

use fsm_core::wire::row_dump::RowDumpHeader;
use fsm_core::wire::HEADER_LEN;
use fsm_core::{MethodDecoder, MethodDecoderError, MethodPlan};

use crate::scan::{self, DumpError, Probe, RowBuffers, Scan};

/// Where the candidate file goes (a semihosting file on the target, a vector on the host).
pub trait Sink {
    /// The sink's error.
    type Error;
    /// Appends all of `bytes`.
    fn write(&mut self, bytes: &[u8]) -> Result<(), Self::Error>;
}

#[cfg(not(target_os = "none"))]
impl Sink for Vec<u8> {
    type Error = core::convert::Infallible;
    fn write(&mut self, bytes: &[u8]) -> Result<(), Self::Error> {
        self.extend_from_slice(bytes);
        Ok(())
    }
}

/// The buffers a batch scan needs.
pub struct BatchMemory<'a> {
    /// `MethodPlan::tables_len` floats or more (none for a baseline).
    pub tables: &'a mut [f32],
    /// The row's buffers.
    pub row: RowBuffers<'a>,
    /// A candidate record of the widest row.
    pub record: &'a mut [u8],
}

/// What a batch scan did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BatchSummary {
    /// The dump's header.
    pub dump: RowDumpHeader,
    /// Rows decoded.
    pub rows: u32,
    /// Bytes written (header and records).
    pub bytes: u64,
}

/// Why a batch scan stopped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BatchError<E> {
    /// The dump is not one this plan and this camera can scan.
    Dump(DumpError),
    /// The decoder could not be built.
    Decoder(MethodDecoderError),
    /// The sink failed.
    Sink(E),
}

impl<E: fmt::Debug> fmt::Display for BatchError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BatchError::Dump(e) => write!(f, "{e}"),
            BatchError::Decoder(e) => write!(f, "{e}"),
            BatchError::Sink(e) => write!(f, "output: {e:?}"),
        }
    }
}

/// Decodes every record of `dump` with `plan` (any method's) and writes the candidate file to
/// `sink`.
pub fn scan_dump<S: Sink, P: Probe>(
    plan: impl Into<MethodPlan>,
    dump: &[u8],
    memory: BatchMemory<'_>,
    sink: &mut S,
    probe: &mut P,
) -> Result<BatchSummary, BatchError<S::Error>> {
    let plan: MethodPlan = plan.into();
    let dump_error = |e| BatchError::Dump(e);
    let header = RowDumpHeader::decode(dump).map_err(|e| dump_error(DumpError::Wire(e)))?;
    let scan = Scan::of_dump(plan, &header).map_err(dump_error)?;
    let record_len = scan.record_len();
    let body = &dump[HEADER_LEN..];
    if !body.len().is_multiple_of(record_len) {
        return Err(dump_error(DumpError::Length {
            len: body.len(),
            record_len,
        }));
    }
    let BatchMemory {
        tables,
        row: mut buffers,
        record,
    } = memory;
    let decoder = MethodDecoder::new(&plan, tables).map_err(BatchError::Decoder)?;
    probe.tables_built();
    sink.write(&scan.candidates.encode())
        .map_err(BatchError::Sink)?;
    let mut bytes = HEADER_LEN as u64;
    let mut rows = 0;
    for input in body.chunks_exact(record_len) {
        let (row, len) = scan::decode_row(&decoder, &scan, input, &mut buffers, record, probe)
            .map_err(|e| dump_error(DumpError::Row(e)))?;
        sink.write(&record[..len]).map_err(BatchError::Sink)?;
        probe.end_row(row, len);
        bytes += len as u64;
        rows += 1;
    }
    Ok(BatchSummary {
        dump: header,
        rows,
        bytes,
    })
}
