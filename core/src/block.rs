//! EFSM column recovery (paper §IV-B, SPEC §3): border guard, block decisions from the mask
//! patterns, and every (peak, block) combination as a candidate.
//!
//! Per group `g`: peaks of the `c̃`-domain spectrum outside `[cg, cB − cg]` are dropped (the
//! pattern is discontinuous at block borders, and the other group sees those columns inside a
//! block); block `b` lights the pixel when its mask exceeds the dark level by a noise margin
//! (`I_min`, eq. 17); each kept peak `c̃` and lit block `b` give `c = c̃ + b·cB − s_g`
//! (eqs. 18–20). Candidates outside the pixel's column range are fictitious and dropped. A
//! column both groups find is reported once, from the group that sees it further from a block
//! border.

use crate::candidate::{Candidate, ColumnRange, GroupSet, PixelCandidates};
use crate::plan::{BlockCoding, ScanPlan};
use crate::search::PeakList;
use crate::sequence::Group;

/// Whether a local column passes the border guard `[cg, cB − cg]`.
pub fn in_guard(local_column: f32, coding: &BlockCoding) -> bool {
    border_margin(local_column, coding) >= coding.border_guard
}

/// Distance of a local column from the nearer border of its block.
pub fn border_margin(local_column: f32, coding: &BlockCoding) -> f32 {
    local_column.min(coding.block_width as f32 - local_column)
}

/// The levels of one group's masks at one pixel.
pub(crate) struct MaskLevels<F: Fn(u16) -> u16> {
    /// Sample of mask `i`.
    pub sample: F,
    /// Number of masks.
    pub count: u16,
    /// Dark-frame sample of the pixel.
    pub dark: u16,
    /// The pixel's sample noise RMS, sensor DN.
    pub noise_dn: f32,
}

impl<F: Fn(u16) -> u16> MaskLevels<F> {
    /// `I_min − dark`: the margin a mask must exceed the dark level by: the larger of
    /// `mask_noise_factor ×` the pixel's noise and `mask_relative_floor ×` the brightest mask's
    /// excess (light scattered from far blocks is not a block that lights the pixel).
    pub fn margin(&self, plan: &ScanPlan) -> f32 {
        let brightest = (0..self.count)
            .map(|i| self.excess(i))
            .fold(0.0f32, f32::max);
        let d = plan.decoding;
        (d.mask_noise_factor * self.noise_dn).max(d.mask_relative_floor * brightest)
    }

    /// `I_b − dark` of mask `i`, sensor DN.
    pub fn excess(&self, mask: u16) -> f32 {
        (self.sample)(mask) as f32 - self.dark as f32
    }

    /// Whether any mask sample reaches `saturation`.
    pub fn saturated(&self, saturation: u16) -> bool {
        (0..self.count).any(|i| (self.sample)(i) >= saturation)
    }
}

/// Adds every (guarded peak, lit block) combination of `group` to `out` (eqs. 18–20).
pub(crate) fn recover<F: Fn(u16) -> u16, const K: usize>(
    plan: &ScanPlan,
    coding: &BlockCoding,
    group: Group,
    peaks: &PeakList,
    masks: &MaskLevels<F>,
    range: &ColumnRange,
    out: &mut PixelCandidates<K>,
) {
    let margin = masks.margin(plan);
    for mask in 0..masks.count {
        let excess = masks.excess(mask);
        if !(excess > margin && excess > 0.0) {
            continue;
        }
        let blocks = plan.mask_blocks(group, mask);
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
                    // Both groups may see this column; the one that sees it further from a
                    // block border has the least of the pattern's discontinuity in its light.
                    let margin = |c: &Candidate| {
                        let shifted = c.column + plan.group_shift(c.group) as f32;
                        border_margin(shifted - c.block as f32 * coding.block_width as f32, coding)
                    };
                    out.offer(candidate, plan.decoding.merge_tolerance, |new, old| {
                        margin(new) > margin(old)
                    });
                }
            }
        }
    }
}
