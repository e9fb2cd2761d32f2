//! EFSM column recovery (paper §IV-B, SPEC §3): border guard, block decisions from the mask
//! patterns, and every (peak, block) combination as a candidate.
//!
//! Per group `g`: peaks of the `c̃`-domain spectrum outside `[cg, cB − cg]` are dropped (the
//! pattern is discontinuous at block borders, and the other group sees those columns inside a
//! block); block `b` lights the pixel when its mask exceeds the dark level by a noise margin
//! (`I_min`, eq. 17); each kept peak `c̃` and lit block `b` give `c = c̃ + b·cB − s_g`
//! (eqs. 18–20). Candidates outside the pixel's column range are fictitious and dropped. A
//! column both groups find is reported once: the mean of the two views where both are well
//! inside their blocks, else the view further from a block border.

use crate::candidate::{Candidate, ColumnRange, GroupSet, PixelCandidates};
use crate::peak::PeakList;
use crate::plan::sequence::Group;
use crate::plan::{BlockCoding, GroupFrames, PeakSearch, ScanPlan};

/// Whether a local column passes the border guard `[cg, cB − cg]`.
pub fn in_guard(local_column: f32, coding: &BlockCoding) -> bool {
    border_margin(local_column, coding) >= coding.border_guard
}

/// Distance of a local column from the nearer border of its block.
pub fn border_margin(local_column: f32, coding: &BlockCoding) -> f32 {
    local_column.min(coding.block_width as f32 - local_column)
}

/// Distance from a block border beyond which a group's view of a column is whole: the fit's
/// columns (`±HALF_WIDTH`) and half a column of light around them lie inside the block.
const WHOLE_VIEW_MARGIN: f32 = crate::peak::deconvolution::HALF_WIDTH as f32 + 0.5;

/// One candidate from two groups' views of the same column: where both see it whole, the
/// amplitude-weighted mean (two independent estimates: √2 less noise); otherwise the view
/// further from its block border, since light near a border is partly in the next block.
fn merge_views(
    plan: &ScanPlan,
    coding: &BlockCoding,
    old: &Candidate,
    new: &Candidate,
) -> Candidate {
    let margin = |c: &Candidate| {
        let shifted = c.column + plan.group_shift(c.group) as f32;
        border_margin(shifted - c.block as f32 * coding.block_width as f32, coding)
    };
    let (m_old, m_new) = (margin(old), margin(new));
    if m_old >= WHOLE_VIEW_MARGIN && m_new >= WHOLE_VIEW_MARGIN {
        let total = old.amplitude + new.amplitude;
        let mut merged = *old;
        if total > 0.0 {
            merged.column = (old.column * old.amplitude + new.column * new.amplitude) / total;
        }
        merged.amplitude = 0.5 * total;
        merged
    } else if m_new > m_old {
        *new
    } else {
        *old
    }
}

/// The levels of one group's masks at one pixel.
pub(crate) struct MaskLevels<F: Fn(u16) -> u16> {
    /// Sample of mask `i`.
    sample: F,
    /// Number of masks.
    count: u16,
    /// Dark-frame sample of the pixel.
    dark: u16,
    /// The pixel's sample noise RMS, sensor DN.
    noise_dn: f32,
    /// The brightest mask's sample (0 without masks).
    brightest: u16,
}

impl<F: Fn(u16) -> u16> MaskLevels<F> {
    /// The `count` masks `sample(0..count)` of a pixel whose dark sample is `dark`.
    pub fn new(sample: F, count: u16, dark: u16, noise_dn: f32) -> Self {
        let brightest = (0..count).map(&sample).max().unwrap_or(0);
        MaskLevels {
            sample,
            count,
            dark,
            noise_dn,
            brightest,
        }
    }

    /// `I_min − dark`: the margin a mask must exceed the dark level by: the larger of
    /// `mask_noise_factor ×` the pixel's noise and `mask_relative_floor ×` the brightest mask's
    /// excess (light scattered from far blocks is not a block that lights the pixel).
    pub fn margin(&self, plan: &ScanPlan) -> f32 {
        let d = plan.decoding;
        (d.mask_noise_factor * self.noise_dn).max(d.mask_relative_floor * self.brightest_excess())
    }

    /// `I_b − dark` of mask `i`, sensor DN.
    pub fn excess(&self, mask: u16) -> f32 {
        (self.sample)(mask) as f32 - self.dark as f32
    }

    /// The brightest mask's excess over dark, at least 0 (exact: codes are below 2^24).
    pub fn brightest_excess(&self) -> f32 {
        self.brightest.saturating_sub(self.dark) as f32
    }

    /// Whether any mask sample reaches `saturation`.
    pub fn saturated(&self, saturation: u16) -> bool {
        self.count > 0 && self.brightest >= saturation
    }
}

/// Adds every (guarded peak, lit block) combination of `group` to `out` (eqs. 18–20).
///
/// Returns whether the group's view is aliased ([`aliased`]).
pub(crate) fn recover<F: Fn(u16) -> u16, const K: usize>(
    plan: &ScanPlan,
    group: Group,
    frames: &GroupFrames,
    peaks: &PeakList,
    masks: &MaskLevels<F>,
    range: &ColumnRange,
    out: &mut PixelCandidates<K>,
) -> bool {
    let Some(coding) = plan.block_coding() else {
        return false;
    };
    let coding = &coding;
    let margin = masks.margin(plan);
    let mut lit_masks = 0;
    for mask in 0..masks.count {
        let excess = masks.excess(mask);
        if !(excess > margin && excess > 0.0) {
            continue;
        }
        lit_masks += 1;
        let blocks = frames.mask_blocks(mask);
        for block in core::iter::once(blocks.first).chain(blocks.second) {
            for (rank, peak) in peaks.peaks.iter().enumerate() {
                if !in_guard(peak.column, coding) {
                    continue;
                }
                let column = plan.column_of(peak.column, block, group);
                if range.contains(column) {
                    let candidate = Candidate {
                        column,
                        amplitude: peak.amplitude,
                        groups: GroupSet::only(group),
                        group,
                        peak: rank as u8,
                        block,
                    };
                    out.offer(candidate, plan.decoding.merge_tolerance, |old, new| {
                        merge_views(plan, coding, old, new)
                    });
                }
            }
        }
    }
    aliased(plan, peaks, masks, lit_masks)
}

/// Whether lights of different blocks are unresolved in a group's local column domain (paper
/// §IV-C), so that a peak's column is a mixture of two lights:
/// - a peak holds more light than the brightest lit block sends: its fringe modulation over
///   `PB` exceeds that block's mask excess (by [`SHARED_PEAK_RATIO`] and the mask noise), so
///   the light of two blocks falls on one local column; or
/// - the DFT searches: two peaks are closer than `2Δc`, the c-domain's resolution, and pull
///   on each other; the cosine search: two lights touch without a dip deep enough to split
///   them ([`PeakList::unresolved`]); lights whose footprints do not merge are exact however
///   close they are.
///
/// Light spread over many columns (diffuse interreflection) lights masks but makes no peak, so
/// it is not aliasing.
fn aliased<F: Fn(u16) -> u16>(
    plan: &ScanPlan,
    peaks: &PeakList,
    masks: &MaskLevels<F>,
    lit_masks: usize,
) -> bool {
    let block_light = SHARED_PEAK_RATIO * masks.brightest_excess()
        + plan.decoding.mask_noise_factor * masks.noise_dn;
    let light = |amplitude: f32| amplitude / plan.levels.amplitude;
    let shared = peaks.peaks.iter().any(|p| light(p.amplitude) > block_light);
    let separable = 2.0 * plan.column_resolution();
    let p = &peaks.peaks;
    let within_2dc = p.iter().enumerate().any(|(i, a)| {
        p[i + 1..]
            .iter()
            .any(|b| (a.column - b.column).abs() < separable)
    });
    let close = match plan.decoding.search {
        // The profile measures two lights exactly as long as their footprints do not merge,
        // but where they lie in different lit blocks, each light in the other's block is a
        // candidate within 2Δc of a true one, which the selection cannot tell from it: the
        // amplitudes match and the surfaces nearly do (plane_mirror: wrong points).
        PeakSearch::Cosine => peaks.unresolved || (lit_masks >= 2 && within_2dc),
        PeakSearch::Clean | PeakSearch::LocalMaxima => within_2dc,
    };
    shared || close
}

/// How much more light than the brightest block sends a peak must hold to be the light of two
/// blocks: above the amplitude estimate's error (< 1%) and the share of a light near a block
/// border that spills into the next block.
const SHARED_PEAK_RATIO: f32 = 1.3;
