//! The decoded candidates of every pixel of a scan, whichever method made them: captures on
//! disk (image stacks, dump files) through the host's parallel decoding pipeline, rows in
//! memory (a simulated camera's) row-parallel through the same line decoder
//! ([`fsm_io::decode::RowDecoder`]), for a plan of any method ([`MethodPlan`]), or the
//! candidate file a camera streamed or `fsm decode` wrote. Decoded rows go straight into the
//! compact [`CandidateImage`], never through the candidate file's bytes. Triangulation and
//! selection take it from here.

use std::path::Path;

use fsm_core::{ColumnRange, Row};
use fsm_io::candidate_file::{CandidateReader, HostCandidates};
use fsm_io::candidate_image::CandidateImage;
use fsm_io::capture::Capture;
use fsm_io::decode::{
    candidate_image_row, decode_capture, DecodeOptions, DecodeSummary, RowDecoder,
};
use fsm_io::plan_file::MethodPlan;
use fsm_io::progress::Progress;
use fsm_io::{Error, Result};
use rayon::prelude::*;

/// Candidates of every pixel of `height` rows from `first_row` on, row-major, held compactly
/// ([`CandidateImage`]), with the scale a point's quality is measured in.
#[derive(Clone, Debug, PartialEq)]
pub struct DecodedImage {
    /// Every pixel's flags and candidates.
    pub candidates: CandidateImage,
    /// The noise RMS of a light's amplitude at a dark pixel, sensor DN
    /// ([`MethodPlan::dark_amplitude_noise_dn`]): what a point's quality is measured in.
    pub amplitude_noise_dn: f32,
    /// Whether the method measures each light ([`MethodPlan::measures_lights`]): the scan
    /// confirms such points by their neighbourhood.
    pub measured_lights: bool,
}

impl DecodedImage {
    /// Decodes a capture (image stack or dump file) of any method's plan with the host's
    /// pipeline; each row goes straight from the decoder into the compact image.
    pub fn decode_capture(
        plan: impl Into<MethodPlan>,
        capture: &Capture,
        options: &DecodeOptions,
        progress: &Progress,
    ) -> Result<(DecodedImage, DecodeSummary)> {
        let plan: MethodPlan = plan.into();
        let mut candidates = CandidateImage::new(capture.width() as usize, 0);
        let summary = decode_capture(
            plan,
            capture,
            options,
            progress,
            candidate_image_row,
            |row| {
                candidates.append(&row.kept);
                Ok(())
            },
        )?;
        let image = DecodedImage::new(&plan, candidates, capture.bit_depth());
        Ok((image, summary))
    }

    /// Reads the candidate file `path` (`fsm decode`'s, or a camera's) of a capture decoded
    /// with `plan`, from a sensor of `bit_depth` bits (the file does not record it; a point's
    /// quality is measured in it). The file must name `plan` by its fingerprint.
    pub fn read_candidates(plan: &MethodPlan, path: &Path, bit_depth: u8) -> Result<DecodedImage> {
        let mut reader = CandidateReader::open(path).map_err(|e| Error::Usage(e.to_string()))?;
        let named = reader.header().plan_fingerprint;
        if named != plan.fingerprint() {
            return Err(Error::Usage(format!(
                "{}: the candidates were decoded with the plan of fingerprint {named:016x}, not \
                 with this plan ({:016x}); decode the capture again with this plan, or scan \
                 with the plan they were decoded with",
                path.display(),
                plan.fingerprint()
            )));
        }
        let candidates =
            CandidateImage::read_file(&mut reader).map_err(|e| Error::Usage(e.to_string()))?;
        Ok(DecodedImage::new(plan, candidates, bit_depth))
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
        let decoded: Vec<CandidateImage> = rows
            .clone()
            .into_par_iter()
            .map_init(
                || {
                    (
                        vec![0.0f32; decoder.scratch_len()],
                        vec![HostCandidates::new(); width],
                    )
                },
                |(scratch, out), y| {
                    let frames = samples(y)?;
                    let limits = limits.map(|l| l(y));
                    let row = Row {
                        frames: &frames,
                        width,
                        bit_depth,
                        column_limits: limits.as_deref(),
                    };
                    decoder
                        .decode_row(&row, scratch, out)
                        .map_err(|e| Error::Usage(format!("row {y}: {e}")))?;
                    Ok(CandidateImage::of_row(y, out))
                },
            )
            .collect::<Result<_>>()?;
        let mut candidates = CandidateImage::new(width, rows.start);
        for row in &decoded {
            candidates.append(row);
        }
        Ok(DecodedImage::new(plan, candidates, bit_depth))
    }

    /// `candidates` decoded with `plan` from a sensor of `bit_depth` bits.
    fn new(plan: &MethodPlan, candidates: CandidateImage, bit_depth: u8) -> DecodedImage {
        DecodedImage {
            candidates,
            amplitude_noise_dn: plan.dark_amplitude_noise_dn(bit_depth),
            measured_lights: plan.measures_lights(),
        }
    }
}
