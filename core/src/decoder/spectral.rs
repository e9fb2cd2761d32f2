//! The DFT searches' path, pixel by pixel: each group's fringes → zero-padded spectrum →
//! CLEAN or the local maxima → candidates.

use super::{saturation_code, Decoder, Row, SpectralTables};
use crate::candidate::{PixelCandidates, PixelFlags};
use crate::peak::PeakList;
use crate::plan::sequence::Group;
use crate::plan::{PeakSearch, ScanPlan};
use crate::search::{clean, local_maxima};
use crate::transform::spectrum::{self, Spectrum};

/// Floats of scratch one pixel needs: one spectrum and one bin per power.
pub(super) fn scratch_len(plan: &ScanPlan) -> usize {
    let n = plan.transform_size as usize;
    (n + 2) + (n / 2 + 1)
}

/// Loads the spectrum of `group` at pixel `x` into `scratch`; returns whether a fringe sample
/// saturated.
pub(super) fn load(
    plan: &ScanPlan,
    window: &[f32],
    inverse_window_sum: f32,
    row: &Row<'_>,
    x: usize,
    group: Group,
    scratch: &mut [f32],
) -> bool {
    let start = plan.group_frames(group).fringe_start;
    let w = row.width;
    // Frame `start + m` at pixel `x`, every `w` samples (the row's length is checked).
    let stats = spectrum::compute(
        plan,
        row.frames.get(start * w + x..).unwrap_or(&[]),
        w,
        window,
        inverse_window_sum,
        saturation_code(row.bit_depth),
        scratch,
    );
    stats.saturated
}

/// The peaks of the spectrum in `scratch`, written to `out` (a `PeakList` is 600 bytes:
/// returning it would copy it on the camera).
pub(super) fn search(
    plan: &ScanPlan,
    tables: &SpectralTables<'_>,
    scratch: &mut [f32],
    out: &mut PeakList,
) {
    let n = plan.transform_size as usize;
    let (spectrum, rest) = scratch.split_at_mut(n + 2);
    let mut residual = Spectrum::new(spectrum, n);
    let (kernel, fits) = (&tables.kernel, &tables.fits);
    match plan.decoding.search {
        PeakSearch::Clean => clean::find_peaks(plan, kernel, fits, &mut residual, rest, out),
        PeakSearch::LocalMaxima => {
            local_maxima::find_peaks(plan, kernel, fits, &residual, rest, out)
        }
        // The cosine search has its own path: spectral tables exist only for DFT plans.
        PeakSearch::Cosine => out.peaks.clear(),
    }
}

/// Decodes pixel `x` of a checked `row` into `out`.
pub(super) fn decode_pixel<const K: usize>(
    decoder: &Decoder<'_>,
    tables: &SpectralTables<'_>,
    row: &Row<'_>,
    x: usize,
    scratch: &mut [f32],
    peaks: &mut PeakList,
    out: &mut PixelCandidates<K>,
) {
    out.clear();
    let plan = &decoder.plan;
    let mut troubled_in_every_group = true;
    for group in plan.groups() {
        let (window, sum) = (tables.window, tables.inverse_window_sum);
        if load(plan, window, sum, row, x, group, scratch) {
            out.flags.insert(PixelFlags::SATURATED);
        }
        search(plan, tables, scratch, peaks);
        let noise_dn = peaks.bin_noise * tables.bin_to_sample_noise;
        troubled_in_every_group &= decoder.add_group(row, x, group, peaks, noise_dn, out);
    }
    decoder.finish(troubled_in_every_group, out);
}
