//! The decoded candidates of every pixel of a scan, whichever method made them: captures on
//! disk (image stacks, dump files) through the host's parallel decoding pipeline, rows in
//! memory (a simulated camera's) row-parallel through the same line decoder
//! ([`fsm_io::decode::RowDecoder`]), for a plan of any method ([`MethodPlan`]). Triangulation
//! and selection take it from here.

use fsm_core::wire::candidates::decode_record;
use fsm_core::{ColumnRange, Row};
use fsm_io::candidate_file::HostCandidates;
use fsm_io::capture::Capture;
use fsm_io::decode::{candidate_header, decode_capture, DecodeOptions, DecodeSummary, RowDecoder};
use fsm_io::plan_file::MethodPlan;
use fsm_io::progress::Progress;
use fsm_io::{Error, Result};
use rayon::prelude::*;

/// Candidates of every pixel of `height` rows from `first_row` on, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedImage {
    /// Pixels per row.
    pub width: usize,
    /// Camera row of `pixels[0]`.
    pub first_row: usize,
    /// Rows.
    pub height: usize,
    /// One candidate list per pixel.
    pub pixels: Vec<HostCandidates>,
    /// The noise RMS of a light profile's column at a dark pixel, sensor DN
    /// ([`MethodPlan::dark_column_noise_dn`]): what a point's quality is measured in. `None`
    /// where the method has no such scale (DFT searches, phase shift).
    pub column_noise_dn: Option<f32>,
}

impl DecodedImage {
    /// Decodes a capture (image stack or dump file) of any method's plan with the host's
    /// pipeline.
    pub fn decode_capture(
        plan: impl Into<MethodPlan>,
        capture: &Capture,
        options: &DecodeOptions,
        progress: &Progress,
    ) -> Result<(DecodedImage, DecodeSummary)> {
        let plan: MethodPlan = plan.into();
        let (width, height) = (capture.width() as usize, capture.height() as usize);
        let mut image = DecodedImage::empty(width, height);
        image.column_noise_dn = plan.dark_column_noise_dn(capture.bit_depth());
        let header = candidate_header(plan, capture.width(), capture.height());
        let summary = decode_capture(plan, capture, options, progress, |row| {
            image.take_row(&header, row)
        })?;
        Ok((image, summary))
    }

    /// Decodes rows held in memory (a simulated camera's): `samples(y)` gives row `y` in the
    /// decoder's layout (`frames[i·W + x]`, the method's frame order); `limits(y)`, if given,
    /// the columns each pixel of row `y` can see (from the calibration's measurement volume).
    pub fn decode_rows(
        plan: &MethodPlan,
        width: usize,
        rows: std::ops::Range<usize>,
        bit_depth: u8,
        limits: Option<&(dyn Fn(usize) -> Vec<ColumnRange> + Sync)>,
        samples: impl Fn(usize) -> Result<Vec<u16>> + Sync,
    ) -> Result<DecodedImage> {
        let mut tables = Vec::new();
        let decoder = RowDecoder::new(plan, &mut tables)?;
        let decoded: Vec<Vec<HostCandidates>> = rows
            .clone()
            .into_par_iter()
            .map_init(
                || vec![0.0f32; decoder.scratch_len()],
                |scratch, y| {
                    let frames = samples(y)?;
                    let limits = limits.map(|l| l(y));
                    let row = Row {
                        frames: &frames,
                        width,
                        bit_depth,
                        column_limits: limits.as_deref(),
                    };
                    let mut out = vec![HostCandidates::new(); width];
                    decoder
                        .decode_row(&row, scratch, &mut out)
                        .map_err(|e| Error::Usage(format!("row {y}: {e}")))?;
                    Ok(out)
                },
            )
            .collect::<Result<_>>()?;
        Ok(DecodedImage {
            width,
            first_row: rows.start,
            height: rows.len(),
            pixels: decoded.into_iter().flatten().collect(),
            column_noise_dn: plan.dark_column_noise_dn(bit_depth),
        })
    }

    fn empty(width: usize, height: usize) -> Self {
        DecodedImage {
            width,
            first_row: 0,
            height,
            pixels: vec![HostCandidates::new(); width * height],
            column_noise_dn: None,
        }
    }

    /// Stores a decoded row from its candidate record (the bytes the candidate file holds).
    fn take_row(
        &mut self,
        header: &fsm_core::wire::candidates::CandidateHeader,
        row: fsm_io::decode::DecodedRow,
    ) -> Result<()> {
        let record = decode_record(header, &row.record)
            .map_err(|e| Error::Usage(format!("decoded row {}: {e}", row.row)))?;
        let y = record.row as usize;
        record
            .read_into(
                header,
                &mut self.pixels[y * self.width..(y + 1) * self.width],
            )
            .map_err(|e| Error::Usage(format!("decoded row {y}: {e}")))
    }
}
