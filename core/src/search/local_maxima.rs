//! The paper's peak search (§III-D, SPEC §2): every local maximum of `|X_k|` above a noise
//! threshold is a light, found in one pass over the spectrum with nothing subtracted.
//!
//! It is the fast alternative to [`crate::search::clean`] (CLEAN), selected by
//! [`PeakSearch::LocalMaxima`](crate::plan::PeakSearch): one pass for the powers, one median for
//! the noise, one pass for the maxima, then a 3-point estimate per peak. What it gives up:
//! a peak's sidelobes are not removed, so the rectangular window's (−13 dB) pass a relative floor
//! of a few percent and are reported as light (use the Hann window, −31 dB); two lights closer
//! than the main lobe (four resolution steps with Hann) show as one maximum; a weak light on the
//! flank of a strong one is measured with the strong one's slope under it; and a light wider than
//! about 3 columns, whose neighbouring columns' kernels differ in phase by a quarter turn, shows
//! its two edges as maxima (the magnitude cancels in its middle), where CLEAN fits the complex
//! spectrum and finds its centre.
//!
//! The bin noise RMS is `sqrt(median |X_k|² / ln 2)` over nearly independent bins beside the
//! strongest light (CLEAN measures it after removing the lights instead).

use heapless::Vec;

use super::MEDIAN_SAMPLES;
use crate::math::{round, select, sqrt};
use crate::peak::deconvolution::{ColumnWeights, Fit, FitDomain, FitTable};
use crate::peak::{self, magnitude_neighbourhood, mirrored_bin, offset, Peak, PeakList};
use crate::plan::{PeakEstimator, ScanPlan, Window, MAX_PEAKS};
use crate::transform::kernel::Kernel;
use crate::transform::spectrum::Spectrum;

/// The local maxima of `spectrum` that stand above the plan's floors, strongest first, at most
/// `max_peaks`, written to `out`. `scratch` holds at least `N/2 + 1` floats (the powers).
pub(crate) fn find_peaks(
    plan: &ScanPlan,
    kernel: &Kernel<'_>,
    table: &FitTable<'_>,
    spectrum: &Spectrum<'_>,
    scratch: &mut [f32],
    out: &mut PeakList,
) {
    let settings = plan.decoding;
    let domain = FitDomain::of(plan);
    let bins = spectrum.len();
    let powers = &mut scratch[..bins];
    let bin_noise = noise_and_powers(plan, spectrum, powers);
    let powers = &*powers;

    // Local maxima above the noise floor, kept strongest first (insertion into at most
    // `max_peaks` entries). A maximum on a plateau counts once: strictly above its left
    // neighbour, at least its right one. Ends compare with their mirror image.
    let noise_floor = settings.noise_factor * bin_noise;
    let floor_power = noise_floor * noise_floor;
    let capacity = (settings.max_peaks as usize).min(MAX_PEAKS);
    let mut maxima: Vec<(usize, f32), MAX_PEAKS> = Vec::new();
    for (k, &p) in powers.iter().enumerate() {
        if p <= floor_power {
            continue;
        }
        let (left, right) = if k > 0 && k + 1 < bins {
            (powers[k - 1], powers[k + 1])
        } else {
            (
                powers[mirrored_bin(k as i64 - 1, bins)],
                powers[mirrored_bin(k as i64 + 1, bins)],
            )
        };
        if !(p > left && p >= right) {
            continue;
        }
        let at = maxima
            .iter()
            .position(|&(_, q)| p > q)
            .unwrap_or(maxima.len());
        if at < capacity {
            if maxima.len() == capacity {
                maxima.pop();
            }
            // Room was made above.
            let _ = maxima.insert(at, (k, p));
        }
    }

    out.peaks.clear();
    out.bin_noise = bin_noise;
    let mut strongest = 0.0f32;
    for &(bin, power) in maxima.iter() {
        let Some(peak) = describe(plan, kernel, table, spectrum, powers, &domain, bin, power)
        else {
            continue;
        };
        // Strongest first, so the relative floor is known before a weaker peak is judged.
        strongest = strongest.max(peak.amplitude);
        if peak.amplitude <= settings.min_amplitude_dn
            || peak.amplitude <= settings.relative_floor * strongest
        {
            continue;
        }
        let _ = out.peaks.push(peak);
    }
}

/// Writes `|X_k|²` to `powers` and returns the bin noise RMS, `sqrt(median |X_k|² / ln 2)`.
///
/// The median is taken beside the strongest light, outside its main lobe widened by a blur of
/// 3 columns (the border guard's allowance), over every `stride`-th bin: zero padding
/// correlates bins closer than `N/M`, and the Hann window correlates neighbours of those (by
/// 2/3), so `stride = N/M`, twice that with Hann, but small enough to keep about 16 bins and
/// large enough for at most [`MEDIAN_SAMPLES`]. Without the exclusion a short sequence's
/// broad peak would fill the median and hide itself; [`crate::plan::LOCAL_MAXIMA_MIN_FRINGES`] keeps room beside it.
fn noise_and_powers(plan: &ScanPlan, spectrum: &Spectrum<'_>, powers: &mut [f32]) -> f32 {
    let mut strongest = (0, -1.0f32);
    for (k, (p, x)) in powers
        .iter_mut()
        .zip(spectrum.as_slice().chunks_exact(2))
        .enumerate()
    {
        *p = x[0] * x[0] + x[1] * x[1];
        if *p > strongest.1 {
            strongest = (k, *p);
        }
    }
    let bins = powers.len();
    let padding = (plan.transform_size / plan.band.count.max(1)).max(1) as usize;
    let (independent, lobe_steps) = match plan.decoding.window {
        Window::Rectangular => (padding, 1.0),
        Window::Hann => (2 * padding, 2.0),
    };
    let stride = independent
        .min((bins / 16).max(1))
        .max(bins.div_ceil(MEDIAN_SAMPLES));
    let lobe = ((lobe_steps * plan.column_resolution() + 3.0) / plan.bin_width()) as usize;
    // Not zeroed first: filling 128 keys costs as much as the median itself on the camera.
    let mut keys: Vec<i32, { MEDIAN_SAMPLES }> = Vec::new();
    for (k, &p) in powers.iter().enumerate().step_by(stride) {
        // Powers are sums of squares, never negative or NaN: their bits order like them.
        if k.abs_diff(strongest.0) > lobe && keys.push(p.to_bits() as i32).is_err() {
            break;
        }
    }
    if keys.is_empty() {
        // Every bin is in the lobe (a plan validation prevents it): the whole spectrum.
        for &p in powers.iter().step_by(stride) {
            if keys.push(p.to_bits() as i32).is_err() {
                break;
            }
        }
    }
    let sampled = keys.len();
    let median = f32::from_bits(select(&mut keys, sampled / 2) as u32);
    sqrt(median / core::f32::consts::LN_2)
}

/// The peak at local maximum `bin`. Its amplitude is `2·|X|` at the vertex of the parabola
/// through the three magnitudes around it (a lit column of modulation `B` peaks at `B/2`,
/// [`crate::transform::spectrum`]), for every estimator, so the floors judge every peak alike. Its column
/// is the plan's estimator's; the deconvolution estimator fits the local column weights on the
/// spectrum as it is and reports their centroid where it lies within a bin of the maximum (a
/// fit centred on a sidelobe is not a light, so it is not trusted over the magnitudes), else
/// the parabola's vertex.
#[allow(clippy::too_many_arguments)]
fn describe(
    plan: &ScanPlan,
    kernel: &Kernel<'_>,
    table: &FitTable<'_>,
    spectrum: &Spectrum<'_>,
    powers: &[f32],
    domain: &FitDomain,
    bin: usize,
    power: f32,
) -> Option<Peak> {
    let reach = peak::reach(plan.decoding.estimator);
    let f = magnitude_neighbourhood(bin, domain.bins, reach, |k| sqrt(powers[k]));
    let (l, c, r) = (f.at(-1), f.at(0), f.at(1));
    // Vertex of the parabola through the three magnitudes: `c + (r − l)·x/4` at
    // `x = (l − r) / (2(l − 2c + r))`, within a bin of the maximum.
    let den = 2.0 * (l - 2.0 * c + r);
    let x = if den < 0.0 {
        ((l - r) / den).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let amplitude = 2.0 * (c + 0.25 * (r - l) * x);
    let (column, weights) = match plan.decoding.estimator {
        PeakEstimator::Deconvolution => {
            let vertex = (bin as f32 + x) * domain.bin_width;
            let centre = round(bin as f32 * domain.bin_width) as i32;
            match Fit::solve_recentred(kernel, table, spectrum, centre) {
                Some((fit, _))
                    if fit
                        .weights
                        .centroid()
                        .is_some_and(|m| (m - vertex).abs() <= domain.bin_width) =>
                {
                    (fit.weights.centroid()?, fit.weights)
                }
                _ => (vertex, ColumnWeights::default()),
            }
        }
        estimator => {
            let delta = offset(estimator, &f)?;
            (
                (bin as f32 + delta) * domain.bin_width,
                ColumnWeights::default(),
            )
        }
    };
    Some(Peak {
        column,
        amplitude,
        magnitude: sqrt(power),
        bin: bin as u16,
        weights,
    })
}
