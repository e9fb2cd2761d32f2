//! Parallel decoding of a whole scan: every temporal row through `fsm_core`'s line decoder
//! (paper §III-F, §IV-B), rows in parallel with rayon, results in row order.
//!
//! One [`Decoder`] per plan, shared by every thread (it only reads its tables); each thread
//! has its own scratch and candidate buffers. Rows arrive in batches from a
//! [`RowBatches`] source (stack bands or dump records, within the memory budget); a batch is
//! decoded in chunks of a few rows per thread so that the decoded rows held at once stay
//! small; each row becomes, right away, its strongest columns and the compact form its caller
//! keeps: a candidate record (the wire format of [`fsm_core::wire::candidates`]) for a
//! candidate file ([`candidate_record`]), a [`CandidateImage`] row for a scan in memory. Rows
//! are handed to the sink in row order whatever order a dump stores them in (a dump written
//! out of order holds the decoded rows that arrive early, in that compact form, until their
//! turn).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::time::Instant;

use fsm_core::wire::candidates::CandidateHeader;
use fsm_core::{Decoder, PixelDecoder, PixelFlags, Row};
use rayon::prelude::*;

use crate::candidate_file::{
    self, CandidateWriter, HostCandidates, CANDIDATE_CAPACITY, CANDIDATE_FILE_NAME,
};
use crate::candidate_image::CandidateImage;
use crate::capture::{BadRecord, BadRows, Capture, RowBatch, RowBatches};
use crate::column_map::{ColumnMap, COLUMN_PREVIEW_NAME, COLUMN_TIFF_NAME};
use crate::error::{Error, Result};
use crate::outputs::StagedDir;
use crate::plan_file::MethodPlan;
use crate::progress::Progress;

/// Default memory budget for captured samples held at once: 2 GiB.
pub const DEFAULT_MEMORY_BUDGET: u64 = 2 << 30;

/// How to decode.
#[derive(Clone, Copy, Debug)]
pub struct DecodeOptions {
    /// Bytes of captured samples (`u16`) held at once: a stack band or a batch of dump rows.
    pub memory_budget_bytes: u64,
    /// Worker threads; 0 for one per core.
    pub threads: usize,
}

impl Default for DecodeOptions {
    fn default() -> Self {
        DecodeOptions {
            memory_budget_bytes: DEFAULT_MEMORY_BUDGET,
            threads: 0,
        }
    }
}

/// One decoded row: its candidates in the form the caller keeps (`T`: a candidate record, a
/// [`CandidateImage`] row, nothing) and its pixels' strongest columns.
#[derive(Clone, Debug)]
pub struct DecodedRow<T> {
    /// Camera row.
    pub row: u32,
    /// The row's candidates, as the caller's `keep` made them.
    pub kept: T,
    /// Strongest candidate column of each pixel, NaN where none.
    pub strongest: Vec<f32>,
    /// Pixels with at least one candidate.
    pub lit_pixels: u32,
    /// Candidates in the row.
    pub candidates: u32,
    /// Pixels flagged saturated.
    pub saturated_pixels: u32,
    /// Pixels whose candidate list overflowed.
    pub truncated_pixels: u32,
    /// EFSM pixels whose lights are unresolved modulo the block width
    /// ([`PixelFlags::ALIASED`]).
    pub aliased_pixels: u32,
    /// Pixels with two touching lights the decoder could not split
    /// ([`PixelFlags::UNRESOLVED`]).
    pub unresolved_pixels: u32,
}

/// What a decode did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DecodeSummary {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Pixels with at least one candidate.
    pub lit_pixels: u64,
    /// Candidates in all.
    pub candidates: u64,
    /// Pixels flagged saturated.
    pub saturated_pixels: u64,
    /// Pixels whose candidate list overflowed.
    pub truncated_pixels: u64,
    /// EFSM pixels whose lights are unresolved modulo the block width
    /// ([`PixelFlags::ALIASED`]).
    pub aliased_pixels: u64,
    /// Pixels with two touching lights the decoder could not split
    /// ([`PixelFlags::UNRESOLVED`]).
    pub unresolved_pixels: u64,
    /// Rows per batch read at once.
    pub rows_per_batch: u32,
    /// Rows the capture held no valid samples for (bad or missing dump records skipped with
    /// [`BadRows::Skip`]): decoded as pixels without candidates, flagged
    /// [`PixelFlags::NO_DATA`]. In row order.
    pub rows_without_data: Vec<u32>,
    /// The dump records skipped, each with its error.
    pub bad_records: Vec<BadRecord>,
    /// Wall time, seconds.
    pub seconds: f64,
}

impl DecodeSummary {
    /// `W·H`.
    pub fn pixels(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    /// Throughput, megapixels per second of wall time.
    pub fn megapixels_per_second(&self) -> f64 {
        self.pixels() as f64 / self.seconds.max(f64::MIN_POSITIVE) / 1e6
    }

    /// The counts in words, as `fsm decode` prints them: share of pixels with light,
    /// candidates per lit pixel, and the pixels flagged.
    pub fn counts(&self) -> String {
        format!(
            "{:.1}% of pixels have candidates, {:.2} per lit pixel; {} saturated, {} with more \
             than the file's capacity, {} aliased (EFSM: two lights unresolved modulo the block \
             width), {} unresolved (two touching lights not split)",
            100.0 * self.lit_pixels as f64 / self.pixels().max(1) as f64,
            self.candidates as f64 / self.lit_pixels.max(1) as f64,
            self.saturated_pixels,
            self.truncated_pixels,
            self.aliased_pixels,
            self.unresolved_pixels
        )
    }

    /// The decode of `source` as `fsm decode` reports it: size, time and throughput, then
    /// [`Self::counts`] and [`Self::skipped_lines`].
    pub fn report(&self, source: &str) -> String {
        format!(
            "decoded {source} ({}x{}) in {:.2} s: {:.3} Mpx/s\n  {}{}",
            self.width,
            self.height,
            self.seconds,
            self.megapixels_per_second(),
            self.counts(),
            self.skipped_lines()
        )
    }

    /// [`Self::skipped`] as lines to append to a report, each indented by two spaces; empty
    /// when nothing was skipped.
    pub fn skipped_lines(&self) -> String {
        (self.skipped()).map_or(String::new(), |s| {
            format!("\n  {}", s.replace('\n', "\n  "))
        })
    }

    /// What a decode with [`BadRows::Skip`] skipped, one line per bad record after the
    /// count and the rows (`3, 7-9, 12`); `None` when nothing was skipped.
    pub fn skipped(&self) -> Option<String> {
        if self.rows_without_data.is_empty() && self.bad_records.is_empty() {
            return None;
        }
        let rows = &self.rows_without_data;
        let mut runs: Vec<String> = Vec::new();
        let mut i = 0;
        while i < rows.len() {
            let mut j = i;
            while j + 1 < rows.len() && rows[j + 1] == rows[j] + 1 {
                j += 1;
            }
            runs.push(if j == i {
                rows[i].to_string()
            } else {
                format!("{}-{}", rows[i], rows[j])
            });
            i = j + 1;
        }
        let mut text = format!(
            "skipped {} bad record(s); {} row(s) without data, no point: {}",
            self.bad_records.len(),
            rows.len(),
            runs.join(", ")
        );
        for bad in &self.bad_records {
            text.push_str(&format!("\n  {}", bad.error));
        }
        Some(text)
    }
}

/// The candidate-file header of a scan decoded by the host.
pub fn candidate_header(plan: impl Into<MethodPlan>, width: u32, height: u32) -> CandidateHeader {
    CandidateHeader {
        capacity: CANDIDATE_CAPACITY as u16,
        plan_fingerprint: plan.into().fingerprint(),
        width,
        height,
    }
}

fn thread_pool(threads: usize) -> Result<rayon::ThreadPool> {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| Error::Usage(format!("cannot start {threads} decoding threads: {e}")))
}

/// What a caller keeps of a decoded row: `keep(row, pixels)` turns its pixels' candidate lists
/// into a compact form (called on the decoding threads, so it runs in parallel).
pub trait KeepRow: Sync {
    /// The compact form.
    type Kept: Send;
    /// Row `row`'s pixels in the compact form.
    fn keep(&self, row: u32, pixels: &[HostCandidates]) -> Result<Self::Kept>;
}

impl<T: Send, F: Fn(u32, &[HostCandidates]) -> Result<T> + Sync> KeepRow for F {
    type Kept = T;
    fn keep(&self, row: u32, pixels: &[HostCandidates]) -> Result<T> {
        self(row, pixels)
    }
}

/// Keeps a decoded row as its record in the candidate format (CRC included), for a candidate
/// file with `header`.
pub fn candidate_record(
    header: CandidateHeader,
) -> impl Fn(u32, &[HostCandidates]) -> Result<Vec<u8>> + Sync {
    move |row, pixels| {
        let mut record = Vec::new();
        candidate_file::encode_row(&header, row, pixels, &mut record)
            .map_err(|e| Error::Usage(format!("row {row}: {e}")))?;
        Ok(record)
    }
}

/// Keeps a decoded row as a one-row [`CandidateImage`], for a scan in memory.
pub fn candidate_image_row(row: u32, pixels: &[HostCandidates]) -> Result<CandidateImage> {
    Ok(CandidateImage::of_row(row as usize, pixels))
}

/// Decodes every row of `capture`, handing the rows to `sink` in row order, each in the form
/// `keep` makes of it.
pub fn decode_capture<K: KeepRow>(
    plan: impl Into<MethodPlan>,
    capture: &Capture,
    options: &DecodeOptions,
    progress: &Progress,
    keep: K,
    sink: impl FnMut(DecodedRow<K::Kept>) -> Result<()> + Send,
) -> Result<DecodeSummary> {
    let threads = thread_pool(options.threads)?.current_num_threads();
    let mut batches = capture.batches(options.memory_budget_bytes, dump_batch_rows(threads))?;
    decode_batches(plan, &mut batches, options, progress, keep, sink)
}

/// Rows of a dump read per batch: enough to keep every thread busy between two reads.
pub fn dump_batch_rows(threads: usize) -> u32 {
    (8 * threads.max(1)) as u32
}

/// Decodes every row `batches` delivers, handing the rows to `sink` in row order, each in the
/// form `keep` makes of it.
pub fn decode_batches<K: KeepRow>(
    plan: impl Into<MethodPlan>,
    batches: &mut RowBatches<'_>,
    options: &DecodeOptions,
    progress: &Progress,
    keep: K,
    mut sink: impl FnMut(DecodedRow<K::Kept>) -> Result<()> + Send,
) -> Result<DecodeSummary> {
    let plan: MethodPlan = plan.into();
    let started = Instant::now();
    let pool = thread_pool(options.threads)?;
    let mut tables = Vec::new();
    let decoder = RowDecoder::new(&plan, &mut tables)?;
    let width = batches.width();
    let height = batches.height();
    let bit_depth = batches.bit_depth();
    let row_len = batches.row_len();
    let mut summary = DecodeSummary {
        width,
        height,
        rows_per_batch: batches.rows_per_batch(),
        ..Default::default()
    };
    let mut pending: BTreeMap<u32, DecodedRow<K::Kept>> = BTreeMap::new();
    // Rows given up (a bad record of a dump in row order stood where they belong): handed on
    // without data when their turn comes, instead of holding every later row until the end.
    let mut given_up: BTreeSet<u32> = BTreeSet::new();
    let mut next_row = 0u32;
    let skip_bad_rows = batches.bad_rows() == BadRows::Skip;
    progress.start(height as u64, "decoding rows");
    // Decodes one batch, its rows in parallel.
    let decode_batch = |batch: &RowBatch| -> Result<Vec<DecodedRow<K::Kept>>> {
        batch
            .rows
            .par_iter()
            .zip(batch.samples.par_chunks(row_len))
            .map_init(
                || {
                    (
                        vec![0.0f32; decoder.scratch_len()],
                        vec![HostCandidates::new(); width as usize],
                    )
                },
                |(scratch, pixels), (&row, frames)| {
                    decode_row(&decoder, &keep, row, frames, bit_depth, scratch, pixels)
                },
            )
            .collect()
    };
    // Hands every decoded row now due to the sink; with `finish`, also the rows that never
    // came (as rows without data).
    let mut deliver = |decoded: Vec<DecodedRow<K::Kept>>,
                       bad: &[BadRecord],
                       finish: bool|
     -> Result<()> {
        progress.advance(decoded.len() as u64);
        for d in decoded {
            // A good record of a row a bad one had claimed: its data wins while there is time.
            given_up.remove(&d.row);
            if d.row < next_row {
                // Too late: the row went on without data.
                summary.bad_records.push(BadRecord {
                    record: None,
                    row_hint: None,
                    error: format!(
                        "row {} came after a bad record in its place had given it up; its record is ignored",
                        d.row
                    ),
                });
                continue;
            }
            pending.insert(d.row, d);
        }
        for b in bad {
            if let Some(row) = b.row_hint.filter(|&r| r >= next_row && r < height) {
                if !pending.contains_key(&row) {
                    given_up.insert(row);
                }
            }
            summary.bad_records.push(b.clone());
        }
        while next_row < height {
            let d = match pending.remove(&next_row) {
                Some(d) => d,
                None if given_up.remove(&next_row) || finish => {
                    progress.advance(1);
                    summary.rows_without_data.push(next_row);
                    row_without_data(&keep, next_row, width)?
                }
                None => break,
            };
            summary.lit_pixels += d.lit_pixels as u64;
            summary.candidates += d.candidates as u64;
            summary.saturated_pixels += d.saturated_pixels as u64;
            summary.truncated_pixels += d.truncated_pixels as u64;
            summary.aliased_pixels += d.aliased_pixels as u64;
            summary.unresolved_pixels += d.unresolved_pixels as u64;
            sink(d)?;
            next_row += 1;
        }
        Ok(())
    };
    let mut batch = RowBatch::default();
    match batches {
        // Stack bands are read frame-parallel on the pool, then decoded row-parallel: both
        // phases use every thread, so alternating them costs nothing and holds one band.
        RowBatches::Stack { .. } => {
            while pool.install(|| batches.next_batch(&mut batch))? {
                deliver(pool.install(|| decode_batch(&batch))?, &[], false)?;
            }
        }
        // Dump records are read and CRC-checked one after the other: the next batch is read
        // as one more task of the pool while the rows of this one decode (two batches in all,
        // and no thread beyond the pool's to share the cores with).
        RowBatches::Dump { .. } => {
            let mut next = RowBatch::default();
            let mut more = batches.next_batch(&mut batch)?;
            while more {
                let (decoded, read) = pool.install(|| {
                    rayon::join(|| decode_batch(&batch), || batches.next_batch(&mut next))
                });
                deliver(decoded?, &batch.bad, false)?;
                more = read?;
                std::mem::swap(&mut batch, &mut next);
            }
        }
    }
    if skip_bad_rows {
        deliver(Vec::new(), &[], true)?;
    }
    progress.finish();
    if next_row != height {
        return Err(Error::Usage(format!(
            "the capture delivered {next_row} of {height} rows in order; row {next_row} is missing"
        )));
    }
    summary.seconds = started.elapsed().as_secs_f64();
    Ok(summary)
}

/// A row the capture held no valid samples for: no candidates, every pixel flagged
/// [`PixelFlags::NO_DATA`].
fn row_without_data<K: KeepRow>(keep: &K, row: u32, width: u32) -> Result<DecodedRow<K::Kept>> {
    let mut pixel = HostCandidates::new();
    pixel.flags.insert(PixelFlags::NO_DATA);
    decoded_row(keep, row, &vec![pixel; width as usize])
}

/// The line decoder of a plan of any method: the core's FSM decoder (with its tables), or a
/// baseline's [`PixelDecoder`]. The one dispatch the host's pipelines share (this module's
/// batches and fsm-scan's rows in memory).
pub enum RowDecoder<'t> {
    /// The decoder (boxed: 10 times a baseline's plan) and its scratch length.
    Fsm(Box<Decoder<'t>>, usize),
    /// Phase shift + Gray code.
    PhaseShift(fsm_core::PhaseShiftPlan),
    /// Micro Phase Shifting.
    MicroPhaseShift(fsm_core::MicroPhaseShiftPlan),
    /// Line scanning.
    LineScan(fsm_core::LineScanPlan),
    /// Code Ensemble.
    CodeEnsemble(fsm_core::CodeEnsemblePlan),
}

impl<'t> RowDecoder<'t> {
    /// The decoder of `plan`; an FSM plan's tables are built in `tables`.
    pub fn new(plan: &MethodPlan, tables: &'t mut Vec<f32>) -> Result<Self> {
        Ok(match plan {
            MethodPlan::Fsm(p) => {
                tables.resize(Decoder::tables_len(p), 0.0);
                RowDecoder::Fsm(
                    Box::new(
                        Decoder::new(p, tables).map_err(|e| {
                            Error::Usage(format!("cannot decode with this plan: {e}"))
                        })?,
                    ),
                    Decoder::scratch_len(p),
                )
            }
            MethodPlan::PhaseShift(p) => RowDecoder::PhaseShift(*p),
            MethodPlan::MicroPhaseShift(p) => RowDecoder::MicroPhaseShift(*p),
            MethodPlan::LineScan(p) => RowDecoder::LineScan(*p),
            MethodPlan::CodeEnsemble(p) => RowDecoder::CodeEnsemble(*p),
        })
    }

    /// Floats of scratch [`RowDecoder::decode_row`] needs.
    pub fn scratch_len(&self) -> usize {
        match self {
            RowDecoder::Fsm(_, len) => *len,
            _ => 0,
        }
    }

    /// Decodes every pixel of `row` into `pixels`.
    pub fn decode_row(
        &self,
        row: &Row<'_>,
        scratch: &mut [f32],
        pixels: &mut [HostCandidates],
    ) -> std::result::Result<(), fsm_core::RowError> {
        match self {
            RowDecoder::Fsm(d, _) => d.decode_row(row, scratch, pixels),
            RowDecoder::PhaseShift(p) => p.decode_row(row, pixels),
            RowDecoder::MicroPhaseShift(p) => p.decode_row(row, pixels),
            RowDecoder::LineScan(p) => p.decode_row(row, pixels),
            RowDecoder::CodeEnsemble(p) => p.decode_row(row, pixels),
        }
    }
}

fn decode_row<K: KeepRow>(
    decoder: &RowDecoder<'_>,
    keep: &K,
    row: u32,
    frames: &[u16],
    bit_depth: u8,
    scratch: &mut [f32],
    pixels: &mut [HostCandidates],
) -> Result<DecodedRow<K::Kept>> {
    let input = Row {
        frames,
        width: pixels.len(),
        bit_depth,
        column_limits: None,
    };
    decoder
        .decode_row(&input, scratch, pixels)
        .map_err(|e| Error::Usage(format!("row {row}: {e}")))?;
    decoded_row(keep, row, pixels)
}

/// Row `row`'s kept form, strongest columns and counts, from its pixels.
fn decoded_row<K: KeepRow>(
    keep: &K,
    row: u32,
    pixels: &[HostCandidates],
) -> Result<DecodedRow<K::Kept>> {
    let mut decoded = DecodedRow {
        row,
        kept: keep.keep(row, pixels)?,
        strongest: Vec::with_capacity(pixels.len()),
        lit_pixels: 0,
        candidates: 0,
        saturated_pixels: 0,
        truncated_pixels: 0,
        aliased_pixels: 0,
        unresolved_pixels: 0,
    };
    for p in pixels {
        decoded
            .strongest
            .push(p.strongest().map_or(f32::NAN, |c| c.column));
        decoded.lit_pixels += !p.candidates.is_empty() as u32;
        decoded.candidates += p.candidates.len() as u32;
        decoded.saturated_pixels += p.flags.contains(PixelFlags::SATURATED) as u32;
        decoded.truncated_pixels += p.flags.contains(PixelFlags::TRUNCATED) as u32;
        decoded.aliased_pixels += p.flags.contains(PixelFlags::ALIASED) as u32;
        decoded.unresolved_pixels += p.flags.contains(PixelFlags::UNRESOLVED) as u32;
    }
    Ok(decoded)
}

/// Decodes `capture` into the folder `out`: the candidate file ([`CANDIDATE_FILE_NAME`]), the
/// strongest-candidate column map as a float TIFF ([`COLUMN_TIFF_NAME`]) and its preview
/// ([`COLUMN_PREVIEW_NAME`]). The folder appears whole or not at all.
pub fn decode_to_dir(
    plan: impl Into<MethodPlan>,
    capture: &Capture,
    out: &Path,
    replace: bool,
    options: &DecodeOptions,
    progress: &Progress,
) -> Result<DecodeSummary> {
    let staged = StagedDir::create(out, replace)?;
    let summary = decode_into(&plan.into(), capture, &staged, options, progress)?;
    staged.commit()?;
    Ok(summary)
}

/// What [`decode_to_dir`] wrote into `out`, as `fsm decode` says it: `wrote
/// OUT/{candidates.fsmc, column.tiff, column.png}`. The names are the decoder's outputs, so
/// the line is made here rather than by the command.
pub fn files_written(out: &Path) -> String {
    format!(
        "wrote {}/{{{CANDIDATE_FILE_NAME}, {COLUMN_TIFF_NAME}, {COLUMN_PREVIEW_NAME}}}",
        out.display()
    )
}

fn decode_into(
    plan: &MethodPlan,
    capture: &Capture,
    staged: &StagedDir,
    options: &DecodeOptions,
    progress: &Progress,
) -> Result<DecodeSummary> {
    let candidates_path = staged.file(CANDIDATE_FILE_NAME);
    let file =
        std::fs::File::create(&candidates_path).map_err(|e| Error::io(&candidates_path, e))?;
    let header = candidate_header(*plan, capture.width(), capture.height());
    let io = |e| Error::io(staged.target().join(CANDIDATE_FILE_NAME), e);
    let mut writer = CandidateWriter::new(std::io::BufWriter::with_capacity(1 << 20, file), header)
        .map_err(io)?;
    let mut map = ColumnMap::new(capture.width(), capture.height());
    let keep = candidate_record(header);
    let summary = decode_capture(*plan, capture, options, progress, keep, |row| {
        writer.write_record(row.row, &row.kept).map_err(io)?;
        map.set_row_columns(row.row, &row.strongest);
        Ok(())
    })?;
    let out = writer.finish().map_err(io)?;
    let file = out.into_inner().map_err(|e| io(e.into_error()))?;
    file.sync_all().map_err(io)?;
    map.write_tiff(&staged.file(COLUMN_TIFF_NAME))?;
    map.write_preview(
        &staged.file(COLUMN_PREVIEW_NAME),
        plan.patterns().projector_columns(),
    )?;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_report_lists_what_was_skipped_under_the_counts() {
        let mut summary = DecodeSummary {
            width: 4,
            height: 10,
            seconds: 2.0,
            ..DecodeSummary::default()
        };
        let clean = summary.report("dump scan.dump");
        assert!(clean.starts_with("decoded dump scan.dump (4x10) in 2.00 s: 0.000 Mpx/s\n  "));
        assert_eq!(
            (clean.lines().count(), summary.skipped_lines()),
            (2, String::new())
        );
        summary.rows_without_data = vec![3, 4, 5, 9];
        summary.bad_records = vec![BadRecord {
            record: Some(3),
            row_hint: Some(3),
            error: "record 3: CRC".into(),
        }];
        let report = summary.report("dump scan.dump");
        let lines: Vec<&str> = report.lines().skip(2).collect();
        assert_eq!(
            lines,
            [
                "  skipped 1 bad record(s); 4 row(s) without data, no point: 3-5, 9",
                "    record 3: CRC"
            ]
        );
    }
}
