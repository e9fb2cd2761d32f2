//! Peaks of a spectrum and the magnitude-based sub-pixel estimators of SPEC §2.
//!
//! Each estimator returns the offset `δ` (in bins) of the true peak from bin `p`, given the
//! magnitudes `F[p−4..=p+4]` of the peak's isolated spectrum (other peaks removed); the column is
//! `(p + δ)·L/N`. The deconvolution estimator lives in [`deconvolution`].

pub mod deconvolution;

use heapless::Vec;

use crate::math::{ln, Complex};
use crate::plan::PeakEstimator;
use crate::plan::MAX_PEAKS;
use deconvolution::ColumnWeights;

/// Half-width plus one of the magnitude neighbourhood the estimators read: Blais–Rioux 8 reads `F[p±5]`.
pub const NEIGHBOURHOOD: usize = 6;

/// One peak of one spectrum, or one light of a cosine profile: light from one or a few
/// adjacent projector columns.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Peak {
    /// Column in the plan's span domain (`c` for BFSM, `c̃` for EFSM), by the plan's estimator.
    pub column: f32,
    /// Fringe modulation of its light, sensor DN: the sum of the non-negative column weights.
    pub amplitude: f32,
    /// `|X|` of the isolated peak at `bin` (DFT searches), or the light's largest column
    /// weight (cosine search), sensor DN.
    pub magnitude: f32,
    /// Bin of the isolated peak's maximum, or the column of the light's largest weight.
    pub bin: u16,
    /// The fitted column weights (SPEC §2 local deconvolution); none (`len` 0) when the
    /// local-maximum search measured the peak with a magnitude estimator, or for a light of
    /// the cosine search (its weights are the profile's own columns).
    pub weights: ColumnWeights,
}

/// Peaks of one spectrum and the noise left in it.
#[derive(Clone, Debug, Default)]
pub struct PeakList {
    /// Peaks in the order found (strongest first).
    pub peaks: Vec<Peak, MAX_PEAKS>,
    /// RMS noise of one complex bin of the final residual (spectrum units); the cosine search
    /// leaves it 0 (its noise is the sensor's, known before the search).
    pub bin_noise: f32,
    /// The cosine search saw two lights it could not separate: two maxima with a dip between
    /// them well above the noise but not deep enough to tell their footprints apart. The peak
    /// it reports for them is their mixture.
    pub unresolved: bool,
}

/// Magnitudes `F[p−5 ..= p+5]` around a peak bin `p`; bins outside
/// the spectrum are mirrored (the real spectrum is symmetric about bin 0 and bin N/2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Neighbourhood {
    /// `F[p + i − 5]` for `i = 0..11`.
    pub magnitudes: [f32; 2 * NEIGHBOURHOOD - 1],
}

impl Neighbourhood {
    /// `F[p + d]`, `|d| ≤ 5`.
    #[inline]
    pub fn at(&self, d: i32) -> f32 {
        self.magnitudes[(d + NEIGHBOURHOOD as i32 - 1) as usize]
    }
}

/// Offset of the peak from the centre bin by a magnitude estimator, in bins, or `None` if the
/// neighbourhood is not a peak the estimator can use (flat, non-positive, or crossing out of
/// range). `Deconvolution` is not a magnitude estimator and gives `None`.
pub fn offset(estimator: PeakEstimator, f: &Neighbourhood) -> Option<f32> {
    let (l, c, r) = (f.at(-1), f.at(0), f.at(1));
    let delta = match estimator {
        PeakEstimator::Gaussian => {
            if l <= 0.0 || c <= 0.0 || r <= 0.0 {
                return None;
            }
            let (ll, lc, lr) = (ln(l), ln(c), ln(r));
            let den = 2.0 * (ll - 2.0 * lc + lr);
            if den >= 0.0 {
                return None;
            }
            (ll - lr) / den
        }
        PeakEstimator::Parabolic => {
            let den = 2.0 * (l - 2.0 * c + r);
            if den >= 0.0 {
                return None;
            }
            (l - r) / den
        }
        PeakEstimator::BlaisRioux4 => blais_rioux(f, 2)?,
        PeakEstimator::BlaisRioux8 => blais_rioux(f, 4)?,
        PeakEstimator::Deconvolution => return None,
    };
    (delta.is_finite() && delta.abs() <= 1.0).then_some(delta)
}

/// Blais–Rioux detector of order `2·half`: zero crossing of
/// `g[i] = Σ_{j=1..half} (F[i−j] − F[i+j])` next to the peak, by linear interpolation.
fn blais_rioux(f: &Neighbourhood, half: i32) -> Option<f32> {
    let g = |i: i32| -> f32 { (1..=half).map(|j| f.at(i - j) - f.at(i + j)).sum() };
    let (g_left, g_centre, g_right) = (g(-1), g(0), g(1));
    // g rises through zero at the peak: negative before it, positive after it.
    if g_centre <= 0.0 && g_right > 0.0 {
        Some(g_centre / (g_centre - g_right))
    } else if g_left <= 0.0 && g_centre > 0.0 {
        Some(g_left / (g_left - g_centre) - 1.0)
    } else {
        None
    }
}

/// `|z|` of a bin, with the spectrum's symmetry outside `0..bins`.
pub(crate) fn mirrored_bin(bin: i64, bins: usize) -> usize {
    let last = bins as i64 - 1;
    let period = 2 * last;
    // The cases every caller meets first, without a division (the Cortex-A9 has no integer
    // divider: a 64-bit remainder is a library call of ~100 instructions).
    if (0..=last).contains(&bin) {
        return bin as usize;
    }
    if (-last..0).contains(&bin) {
        return (-bin) as usize;
    }
    if (last..=period).contains(&bin) {
        return (period - bin) as usize;
    }
    let b = bin.rem_euclid(period);
    (if b > last { period - b } else { b }) as usize
}

/// Builds a neighbourhood from a closure giving the complex value of any bin in range.
pub(crate) fn neighbourhood(
    centre: usize,
    bins: usize,
    value: impl Fn(usize) -> Complex,
) -> Neighbourhood {
    magnitude_neighbourhood(centre, bins, NEIGHBOURHOOD - 1, |k| value(k).norm())
}

/// Bins either side of the peak `estimator` reads.
pub(crate) fn reach(estimator: PeakEstimator) -> usize {
    match estimator {
        PeakEstimator::Gaussian | PeakEstimator::Parabolic | PeakEstimator::Deconvolution => 1,
        PeakEstimator::BlaisRioux4 => 3,
        PeakEstimator::BlaisRioux8 => NEIGHBOURHOOD - 1,
    }
}

/// Builds a neighbourhood from a closure giving the magnitude of any bin in range, reading the
/// `reach ≤ 5` bins either side of `centre` (the others stay 0).
pub(crate) fn magnitude_neighbourhood(
    centre: usize,
    bins: usize,
    reach: usize,
    magnitude: impl Fn(usize) -> f32,
) -> Neighbourhood {
    let mut magnitudes = [0.0; 2 * NEIGHBOURHOOD - 1];
    let middle = NEIGHBOURHOOD - 1;
    let reach = reach.min(middle);
    for (i, m) in magnitudes
        .iter_mut()
        .enumerate()
        .take(middle + reach + 1)
        .skip(middle - reach)
    {
        let k = mirrored_bin(centre as i64 + i as i64 - middle as i64, bins);
        *m = magnitude(k);
    }
    Neighbourhood { magnitudes }
}

#[cfg(test)]
mod tests {
    use super::mirrored_bin;

    #[test]
    fn mirrored_bin_reflects_like_the_remainder_it_avoids() {
        for bins in [2usize, 3, 33, 65, 513] {
            let last = bins as i64 - 1;
            let period = 2 * last;
            for bin in -3 * period..=3 * period {
                let b = bin.rem_euclid(period);
                let expected = if b > last { period - b } else { b } as usize;
                assert_eq!(mirrored_bin(bin, bins), expected, "bin {bin} of {bins}");
            }
        }
    }
}
