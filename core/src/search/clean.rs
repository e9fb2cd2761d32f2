//! The peak search: every column that really lights the pixel, no sidelobe reported as light.
//!
//! Without a window a column's spectrum has sidelobes of 22% of its peak that decay slowly, so a
//! threshold on local maxima reports sidelobes as light. The search instead removes each peak
//! it finds with its modelled spectrum (SPEC §2, CLEAN as in radio astronomy):
//!
//! 1. take the strongest bin of the residual; stop if it is below the plan's relative floor
//!    times the strongest peak or the absolute floor;
//! 2. fit the local column weights there ([`crate::peak::deconvolution`]), re-centring on the
//!    fitted centroid, and subtract the fitted model from every bin;
//! 3. keep the peak if its modelled magnitude exceeds `noise_factor ×` the bin noise RMS of
//!    what is left, else restore it and stop;
//! 4. repeat up to `max_peaks`; then, if there are several peaks, refit each against the
//!    residual with its own model restored, jointly with its neighbour when their column windows
//!    overlap (each first fit saw the later peaks' sidelobes and is biased by them).
//!
//! The bin noise RMS comes from the residual itself: noise makes `|X_k|²` exponential with mean
//! `σ_bin²`, so `σ_bin² = median |X_k|² / ln 2`. The median ignores the few bins a weaker peak
//! still occupies; it is taken after the peak under test is removed, because a short sequence
//! (16–32 fringes) with a defocused peak spreads that peak over most bins.

use heapless::Vec;

use crate::math::{round, select, sqrt, total_order_key};
use crate::peak::deconvolution::{Fit, FitDomain, FitTable, HALF_WIDTH};
use crate::peak::{neighbourhood, offset, Peak, PeakList};
use crate::plan::{PeakEstimator, ScanPlan, MAX_PEAKS};
use crate::transform::kernel::Kernel;
use crate::transform::spectrum::Spectrum;

use super::MEDIAN_SAMPLES;

/// Refinement passes over close peaks.
const REFINE_PASSES: usize = 1;

/// Finds the peaks of `residual` (which it leaves as the residual) and writes them to `out`.
/// `scratch` holds at least `N/2 + 1` floats.
pub(crate) fn find_peaks(
    plan: &ScanPlan,
    kernel: &Kernel<'_>,
    table: &FitTable<'_>,
    residual: &mut Spectrum<'_>,
    scratch: &mut [f32],
    out: &mut PeakList,
) {
    let settings = plan.decoding;
    let domain = FitDomain::of(plan);
    let mut fits: Vec<Fit, MAX_PEAKS> = Vec::new();
    let mut strongest = 0.0f32;
    let mut attempts = 0;
    let mut peak_bin = strongest_bin(residual);
    // Bin noise of the residual as it stands, when a scan has measured it.
    let mut noise = None;
    while fits.len() < settings.max_peaks as usize && attempts < 2 * MAX_PEAKS {
        attempts += 1;
        let floor =
            (0.5 * settings.min_amplitude_dn).max(0.5 * settings.relative_floor * strongest);
        if residual.magnitude(peak_bin) <= floor {
            break;
        }
        let centre = round(peak_bin as f32 * domain.bin_width) as i32;
        let Some((narrow, centre)) = Fit::solve_recentred(kernel, table, residual, centre) else {
            break;
        };
        if narrow.clipped(&domain) {
            // Widening refines the shape of a light; first the narrow fit must show there is
            // one (the noise test below), else noise, which clips often, costs a wide solve.
            let n = noise_without(kernel, residual, &narrow);
            if narrow.model(kernel, peak_bin).norm() <= settings.noise_factor * n {
                break;
            }
        }
        let fit = widened(kernel, residual, &domain, centre, narrow);
        let amplitude = fit.weights.amplitude();
        if amplitude <= settings.min_amplitude_dn
            || amplitude <= settings.relative_floor * strongest
        {
            break;
        }
        // Judge the peak against the noise left once it is removed: before that, a broad peak
        // of a short sequence fills most bins and the median would measure the peak itself.
        fit.apply(kernel, residual, -1.0);
        let (next_bin, next_noise) = scan(residual, scratch);
        let norm = fit.model(kernel, peak_bin).norm();
        if norm <= settings.noise_factor * next_noise
            && !(fits.len() + 1 < settings.max_peaks as usize
                && residual.magnitude(next_bin) > settings.noise_factor * next_noise
                && both_above_noise(plan, kernel, table, residual, scratch, norm, next_bin))
        {
            // Back to the residual the previous scan measured.
            fit.apply(kernel, residual, 1.0);
            break;
        }
        // A fit whose centroid lands within one resolution step of an earlier peak is the rest
        // of that peak's light: fold it back into that peak instead of reporting it twice.
        let same_light = plan.column_resolution().max(HALF_WIDTH as f32);
        let overlap = fit.weights.centroid().and_then(|c| {
            fits.iter().position(|f| {
                f.weights
                    .centroid()
                    .is_some_and(|d| (c - d).abs() < same_light)
            })
        });
        match overlap {
            Some(i) => {
                // Restore both and fit their light as one.
                fit.apply(kernel, residual, 1.0);
                let earlier = fits[i];
                earlier.apply(kernel, residual, 1.0);
                let centre = earlier
                    .weights
                    .centroid()
                    .map_or(earlier.weights.first + HALF_WIDTH, |c| round(c) as i32);
                fits[i] = fit_centred(kernel, table, residual, &domain, centre).unwrap_or(earlier);
                fits[i].apply(kernel, residual, -1.0);
                let (bin, n) = scan(residual, scratch);
                (peak_bin, noise) = (bin, Some(n));
            }
            None => {
                strongest = strongest.max(amplitude);
                // Capacity was checked by the loop condition.
                let _ = fits.push(fit);
                (peak_bin, noise) = (next_bin, Some(next_noise));
            }
        }
    }

    if fits.len() > 1 {
        refine(kernel, table, residual, &domain, &mut fits);
        noise = None;
    }
    let bin_noise = match noise {
        Some(n) => n,
        None => scan(residual, scratch).1,
    };

    out.peaks.clear();
    out.bin_noise = bin_noise;
    for fit in fits.iter() {
        if let Some(peak) = describe(plan, kernel, residual, &domain, fit) {
            let _ = out.peaks.push(peak);
        }
    }
}

/// Fits at `centre`, then once or twice more at the rounded centroid if it moved away; a fit
/// that leaves light at the edge of its window is widened.
fn fit_centred(
    kernel: &Kernel<'_>,
    table: &FitTable<'_>,
    residual: &Spectrum<'_>,
    domain: &FitDomain,
    centre: i32,
) -> Option<Fit> {
    let (fit, centre) = Fit::solve_recentred(kernel, table, residual, centre)?;
    Some(widened(kernel, residual, domain, centre, fit))
}

/// Whether a peak of modelled magnitude `norm`, already removed from `residual`, and the light
/// at `next_bin` both stand above the noise once that light is removed too. With a short
/// sequence (16 fringes) two lights' sidelobes cover every bin, so the residual one light
/// leaves measures the other light, not the noise: each light alone fails its noise test and
/// the pair would be lost. The look-ahead leaves `residual` as it found it; the search then
/// finds the second light in its own turn.
fn both_above_noise(
    plan: &ScanPlan,
    kernel: &Kernel<'_>,
    table: &FitTable<'_>,
    residual: &mut Spectrum<'_>,
    scratch: &mut [f32],
    norm: f32,
    next_bin: usize,
) -> bool {
    let settings = plan.decoding;
    let domain = FitDomain::of(plan);
    let centre = round(next_bin as f32 * domain.bin_width) as i32;
    let Some(next) = fit_centred(kernel, table, residual, &domain, centre) else {
        return false;
    };
    if next.weights.amplitude() <= settings.min_amplitude_dn {
        return false;
    }
    next.apply(kernel, residual, -1.0);
    let (_, noise) = scan(residual, scratch);
    let next_norm = next.model(kernel, next_bin).norm();
    next.apply(kernel, residual, 1.0);
    norm.min(next_norm) > settings.noise_factor * noise
}

/// `fit` (centred on `centre`), widened if it leaves light at the edge of its window.
fn widened(
    kernel: &Kernel<'_>,
    residual: &Spectrum<'_>,
    domain: &FitDomain,
    centre: i32,
    fit: Fit,
) -> Fit {
    if fit.clipped(domain) {
        // One light wider than the window, unless the wider fit shows a second light beside it
        // (that one the search finds on its own).
        if let Some(wide) = Fit::solve_wide(kernel, residual, domain, centre) {
            if wide.weights.is_unimodal() {
                return wide;
            }
        }
    }
    fit
}

/// Refits every peak once all are known: each first fit saw the others' sidelobes, which bias
/// its weights (by a few percent of the other peak's light at 10–20 columns with 32 fringes).
/// A peak whose column window overlaps its nearest neighbour's is fitted jointly with it
/// ([`Fit::solve_pair`]); the others are refitted against the residual with their own model
/// restored.
fn refine(
    kernel: &Kernel<'_>,
    table: &FitTable<'_>,
    residual: &mut Spectrum<'_>,
    domain: &FitDomain,
    fits: &mut Vec<Fit, MAX_PEAKS>,
) {
    let overlap = (2 * HALF_WIDTH + 1) as f32;
    if fits.len() < 2 {
        return;
    }
    for _ in 0..REFINE_PASSES {
        for i in 0..fits.len() {
            let Some(ci) = fits[i].weights.centroid() else {
                continue;
            };
            let nearest = fits
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .filter_map(|(j, f)| f.weights.centroid().map(|c| (j, c)))
                .min_by(|a, b| (a.1 - ci).abs().total_cmp(&(b.1 - ci).abs()));
            let Some((j, cj)) = nearest else { continue };
            if (cj - ci).abs() >= overlap {
                fits[i].apply(kernel, residual, 1.0);
                if let Some(refit) = fit_centred(kernel, table, residual, domain, round(ci) as i32)
                {
                    fits[i] = refit;
                }
                fits[i].apply(kernel, residual, -1.0);
            } else if i < j {
                let (lo, hi) = if ci < cj { (i, j) } else { (j, i) };
                fits[lo].apply(kernel, residual, 1.0);
                fits[hi].apply(kernel, residual, 1.0);
                if let Some((a, b)) =
                    Fit::solve_pair(kernel, residual, domain, ci.min(cj), ci.max(cj))
                {
                    if a.weights.centroid().is_some() && b.weights.centroid().is_some() {
                        fits[lo] = a;
                        fits[hi] = b;
                    }
                }
                fits[lo].apply(kernel, residual, -1.0);
                fits[hi].apply(kernel, residual, -1.0);
            }
        }
    }
}

/// The reported peak of a fit: position by the plan's estimator on the isolated spectrum.
fn describe(
    plan: &ScanPlan,
    kernel: &Kernel<'_>,
    residual: &Spectrum<'_>,
    domain: &FitDomain,
    fit: &Fit,
) -> Option<Peak> {
    let centroid = fit.weights.centroid()?;
    let amplitude = fit.weights.amplitude();
    let isolated = |k: usize| {
        let r = residual.bin(k);
        let m = fit.model(kernel, k);
        crate::math::Complex::new(r.re + m.re, r.im + m.im)
    };
    // The isolated peak's maximum bin, next to the centroid's bin.
    let near = round(centroid / domain.bin_width).max(0.0) as usize;
    let near = near.min(domain.bins - 1);
    let mut bin = near;
    let mut best = isolated(near).norm_sqr();
    for k in [near.wrapping_sub(1), near + 1] {
        if k < domain.bins {
            let p = isolated(k).norm_sqr();
            if p > best {
                best = p;
                bin = k;
            }
        }
    }
    let column = match plan.decoding.estimator {
        PeakEstimator::Deconvolution => centroid,
        estimator => {
            let f = neighbourhood(bin, domain.bins, isolated);
            let delta = offset(estimator, &f)?;
            (bin as f32 + delta) * domain.bin_width
        }
    };
    Some(Peak {
        column,
        amplitude,
        magnitude: sqrt(best),
        bin: bin as u16,
        weights: fit.weights,
    })
}

/// Strongest bin of the residual.
fn strongest_bin(residual: &Spectrum<'_>) -> usize {
    let mut best = 0;
    let mut best_power = -1.0f32;
    for k in 0..residual.len() {
        let p = residual.bin(k).norm_sqr();
        if p > best_power {
            best_power = p;
            best = k;
        }
    }
    best
}

/// Strongest bin of the residual and the bin noise RMS, `sqrt(median |X_k|² / ln 2)`.
///
/// The median is taken over every `stride`-th bin, at most about 128 of them: zero-padded bins
/// are correlated anyway, and a threshold needs no more precision than that.
fn scan(residual: &Spectrum<'_>, _scratch: &mut [f32]) -> (usize, f32) {
    let bins = residual.len();
    let stride = bins.div_ceil(MEDIAN_SAMPLES);
    let mut best = 0;
    let mut best_power = -1.0f32;
    // The sampled powers as integers ordered like `f32::total_cmp`.
    let mut keys = [0i32; MEDIAN_SAMPLES];
    let sampled = if stride == 1 {
        // Every bin (at most MEDIAN_SAMPLES): one key per bin.
        let mut sampled = 0;
        for ((k, x), key) in residual
            .as_slice()
            .chunks_exact(2)
            .enumerate()
            .zip(keys.iter_mut())
        {
            let p = x[0] * x[0] + x[1] * x[1];
            if p > best_power {
                best_power = p;
                best = k;
            }
            *key = total_order_key(p);
            sampled += 1;
        }
        sampled
    } else {
        let mut sampled = 0;
        let mut next_sample = 0;
        for (k, x) in residual.as_slice().chunks_exact(2).enumerate() {
            let p = x[0] * x[0] + x[1] * x[1];
            if p > best_power {
                best_power = p;
                best = k;
            }
            if k == next_sample {
                if let Some(key) = keys.get_mut(sampled) {
                    *key = total_order_key(p);
                    sampled += 1;
                }
                next_sample += stride;
            }
        }
        sampled
    };
    let median = f32::from_bits(select(&mut keys[..sampled], sampled / 2) as u32);
    (best, sqrt(median / core::f32::consts::LN_2))
}

/// The bin noise RMS [`scan`] would measure once `fit` is removed from `residual`, computed
/// without changing `residual`.
fn noise_without(kernel: &Kernel<'_>, residual: &Spectrum<'_>, fit: &Fit) -> f32 {
    let bins = residual.len();
    let stride = bins.div_ceil(MEDIAN_SAMPLES);
    let mut keys = [0i32; MEDIAN_SAMPLES];
    let mut sampled = 0;
    if bins <= MEDIAN_SAMPLES {
        // Every bin is sampled: the model of all bins at once, term by term (the same sums as
        // `Fit::model`).
        let mut model = [0.0f32; 2 * MEDIAN_SAMPLES];
        let model = &mut model[..2 * bins];
        fit.add_to(kernel, model);
        for ((key, r), m) in keys
            .iter_mut()
            .zip(residual.as_slice().chunks_exact(2))
            .zip(model.chunks_exact(2))
        {
            let (re, im) = (r[0] - m[0], r[1] - m[1]);
            *key = total_order_key(re * re + im * im);
            sampled += 1;
        }
    } else {
        for (key, k) in keys.iter_mut().zip((0..bins).step_by(stride)) {
            let (r, m) = (residual.bin(k), fit.model(kernel, k));
            let (re, im) = (r.re - m.re, r.im - m.im);
            *key = total_order_key(re * re + im * im);
            sampled += 1;
        }
    }
    let median = f32::from_bits(select(&mut keys[..sampled], sampled / 2) as u32);
    sqrt(median / core::f32::consts::LN_2)
}
