//! The methods the paper compares FSM with (§VII, Figs. 9–13), each with its own plan type,
//! patterns and per-pixel decoder, all decoded into the same [`PixelCandidates`] as FSM so that
//! every method goes through one triangulation and selection path:
//!
//! | method | module | frames (paper's setting) |
//! |---|---|---|
//! | phase shift + Gray code (PS) | [`phase_shift`] | dark, white, 6 fringes, 7 Gray codes |
//! | Micro Phase Shifting (MPS, Gupta & Nayar 2012) | [`micro_phase_shift`] | 17 fringes ("16–15") |
//! | Code Ensemble (CE, Gupta et al. 2011) | [`code_ensemble`] | 4 binary codes × 10 bits, each with its inverse (80) |
//! | line scanning (LS) | [`line_scan`] | dark, white, one lit column per frame (768) |
//!
//! [`PatternSequence`] is what a simulator renders and a pattern writer draws, for these and
//! the FSM plans alike; [`PixelDecoder`] is what turns one pixel's samples into candidates, and
//! its [`PixelDecoder::decode_row`] checks a row once for every baseline.

pub mod code_ensemble;
pub mod line_scan;
pub mod micro_phase_shift;
pub mod phase_shift;

use crate::candidate::{Candidate, ColumnRange, GroupSet, PixelCandidates};
use crate::decoder::{Row, RowError};
use crate::plan::sequence::Group;
use crate::wire::PlanIdentity;

/// A sequence of projected frames, each a value per projector column: what a simulator renders
/// and a pattern writer draws, for FSM plans and the baselines alike.
pub trait PatternSequence {
    /// Projector columns.
    fn projector_columns(&self) -> u16;
    /// Frames in the sequence, reference frames included.
    fn frame_count(&self) -> usize;
    /// Frames that code the column, reference frames (dark, white) not counted: the figure the
    /// paper compares methods by. Every frame, unless the sequence says otherwise.
    fn pattern_count(&self) -> usize {
        self.frame_count()
    }
    /// Relative intensity in `[0, 1]` of frame `frame` at `column`.
    fn frame_intensity(&self, frame: usize, column: u32) -> f32;
    /// Identity of the whole plan, frames and decoder settings: what candidate files of its
    /// decodes carry.
    fn fingerprint(&self) -> u64;
    /// Identity of the frames alone ([`crate::wire::pattern_fingerprint`]): what row dumps of
    /// its captures carry, so that a plan with other decoder settings decodes them too.
    fn pattern_fingerprint(&self) -> u64;
    /// Every fingerprint of the plan.
    fn identity(&self) -> PlanIdentity {
        PlanIdentity {
            patterns: self.pattern_fingerprint(),
            plan: self.fingerprint(),
            legacy_plan: None,
        }
    }
}

impl PatternSequence for crate::plan::ScanPlan {
    fn projector_columns(&self) -> u16 {
        self.projector_columns
    }

    fn frame_count(&self) -> usize {
        self.sequence_len()
    }

    fn pattern_count(&self) -> usize {
        crate::plan::ScanPlan::pattern_count(self)
    }

    fn frame_intensity(&self, frame: usize, column: u32) -> f32 {
        self.pattern(frame)
            .map_or(0.0, |p| self.intensity(p, column))
    }

    fn fingerprint(&self) -> u64 {
        crate::plan::ScanPlan::fingerprint(self)
    }

    fn pattern_fingerprint(&self) -> u64 {
        crate::plan::ScanPlan::pattern_fingerprint(self)
    }

    fn identity(&self) -> PlanIdentity {
        crate::plan::ScanPlan::identity(self)
    }
}

/// Offers `out` a light at `column` of strength `amplitude` when `range` holds the column: the
/// one way the baselines make a candidate (one group, no block, rank 0; a decoder that finds
/// several ranks them after).
pub(crate) fn offer_light<const K: usize>(
    out: &mut PixelCandidates<K>,
    range: &ColumnRange,
    column: f32,
    amplitude: f32,
) {
    if range.contains(column) {
        let candidate = Candidate {
            column,
            amplitude,
            groups: GroupSet::only(Group::One),
            group: Group::One,
            peak: 0,
            block: 0,
        };
        out.offer(candidate, 0.0, |old, _| *old);
    }
}

/// A baseline's decoder of one pixel, and of a row of them.
pub trait PixelDecoder: PatternSequence {
    /// Decodes one pixel from its samples in sequence order (`samples(i)` is frame `i`'s):
    /// its candidates within `range`, strongest first. `saturation` is the sensor's top code.
    fn decode_pixel<const K: usize>(
        &self,
        samples: impl Fn(usize) -> u16,
        saturation: u16,
        range: &ColumnRange,
        out: &mut PixelCandidates<K>,
    );

    /// The noise RMS of the amplitude this decoder gives a light, at a pixel that receives no
    /// light, sensor DN ([`crate::noise::amplitude_noise_dn`] of the plan's sensor): what a
    /// point's quality (amplitude over this) is measured in, as FSM's
    /// [`crate::Decoder::dark_column_noise_dn`].
    fn dark_amplitude_noise_dn(&self, bit_depth: u8) -> f32;

    /// Decodes every pixel of a row in the decoder's layout (`frames[i·W + x]`, this plan's
    /// frame order): the baselines' counterpart of [`crate::Decoder::decode_row`], with the same
    /// checks and errors.
    fn decode_row<const K: usize>(
        &self,
        row: &Row<'_>,
        out: &mut [PixelCandidates<K>],
    ) -> Result<(), RowError> {
        row.check_shape(self.frame_count())?;
        if out.len() != row.width {
            return Err(RowError::OutputLength {
                expected: row.width,
                actual: out.len(),
            });
        }
        for (x, pixel) in out.iter_mut().enumerate() {
            self.decode_checked(row, x, pixel);
        }
        Ok(())
    }

    /// Decodes pixel `x` of `row` alone, with the checks of [`PixelDecoder::decode_row`]: the
    /// same candidates as the whole row gives that pixel (each pixel is decoded on its own),
    /// so a camera may decode a row a slice of pixels at a time.
    fn decode_row_pixel<const K: usize>(
        &self,
        row: &Row<'_>,
        x: usize,
        out: &mut PixelCandidates<K>,
    ) -> Result<(), RowError> {
        row.check_shape(self.frame_count())?;
        if x >= row.width {
            return Err(RowError::Pixel {
                x,
                width: row.width,
            });
        }
        self.decode_checked(row, x, out);
        Ok(())
    }

    /// Decodes pixel `x < row.width` of a row whose frames, bit depth and column limits were
    /// checked (what both methods above share).
    #[doc(hidden)]
    fn decode_checked<const K: usize>(
        &self,
        row: &Row<'_>,
        x: usize,
        out: &mut PixelCandidates<K>,
    ) {
        let saturation = ((1u32 << row.bit_depth) - 1) as u16;
        let projector = ColumnRange::projector(self.projector_columns());
        let range = row
            .column_limits
            .map_or(projector, |l| projector.intersect(&l[x]));
        self.decode_pixel(|i| row.frames[i * row.width + x], saturation, &range, out);
    }
}
