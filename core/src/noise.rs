//! Noise propagation: what scatter a decoder should show for a given sensor noise (paper §VI),
//! and the noise the cosine search judges a light against (SPEC §2b).

use crate::math::{ln, sqrt};
use crate::plan::SensorNoise;

/// Eq. 21: variance of a DFT magnitude bin for samples with noise variance `sigma²`,
/// `σ²_DFT = σ²/(2M)`, with the spectrum scaled as in [`crate::transform::spectrum`] (no window).
pub fn dft_magnitude_variance(sample_variance: f32, fringe_count: usize) -> f32 {
    sample_variance / (2.0 * fringe_count as f32)
}

/// Eq. 22: variance of the 3-point Gaussian estimator's column for magnitudes `F_l, F, F_r`
/// whose noise variance is `dft_variance`, bins `bin_width` columns apart.
///
/// Differentiating `δ = (ln F_l − ln F_r) / (2(ln F_l − 2 ln F + ln F_r))` gives
/// `∂δ/∂F_l = ln(F_r/F)/(F_l D²)`, `∂δ/∂F_r = ln(F/F_l)/(F_r D²)`, `∂δ/∂F = ln(F_l/F_r)/(F D²)`
/// with `D = ln(F_l/F) + ln(F_r/F)`, hence `σ_c² = Δ² (Σ ∂²) σ²_DFT` with `Δ` the bin width.
/// The paper prints the prefactor as `(2Δc)²`; the derivative above has `Δ²`, and the
/// Monte-Carlo test in this crate agrees with `Δ²`.
pub fn gaussian_column_variance(
    left: f32,
    centre: f32,
    right: f32,
    dft_variance: f32,
    bin_width: f32,
) -> f32 {
    let d = ln(left / centre) + ln(right / centre);
    let d2 = d * d;
    let g_left = ln(right / centre) / left;
    let g_right = ln(centre / left) / right;
    let g_centre = ln(left / right) / centre;
    bin_width * bin_width * (g_left * g_left + g_right * g_right + g_centre * g_centre) / (d2 * d2)
        * dft_variance
}

/// RMS noise of one sample, sensor codes (DN), of a pixel whose fringe samples sit
/// `signal_dn` above its dark level: read noise, the rounding to codes (`1/12` DN²) and the
/// photon shot noise of `signal_dn`, with the sensor's electrons scaled to codes by the bit
/// depth (`2^bits − 1` codes at full scale; SPEC §2b).
pub fn sample_noise_dn(sensor: &SensorNoise, bit_depth: u8, signal_dn: f32) -> f32 {
    let top_code = ((1u32 << bit_depth.clamp(1, 16)) - 1) as f32;
    let dn_per_electron = top_code / sensor.full_scale_electrons;
    let read = sensor.read_noise_electrons * dn_per_electron;
    let shot = dn_per_electron * signal_dn.max(0.0);
    sqrt(read * read + 1.0 / 12.0 + shot)
}

/// RMS noise, per component, of a light's amplitude estimated from `samples` samples of RMS
/// noise `sample_noise_dn`: `σ·√(2/n)`. It is the form every decoder's amplitude takes — the
/// modulation of `n` phase steps, `2/n·|Σ I_k e^{iθ_k}|` (phase shift, Micro Phase Shifting),
/// the mean of `n` differences `pattern − inverse` (Code Ensemble), one sample above another
/// (`n = 1`, line scanning's peak over its surroundings) — so a point's quality, its amplitude
/// over this at a dark pixel, means the same signal-to-noise ratio for every method.
pub fn amplitude_noise_dn(sample_noise_dn: f32, samples: usize) -> f32 {
    sample_noise_dn * sqrt(2.0 / samples.max(1) as f32)
}

/// RMS noise of one column of the inverse cosine transform of `span + 1` columns
/// ([`crate::transform::cosine`]) when every fringe sample has RMS noise `sample_noise_dn`:
/// `σ·√(2/span)`, the same in every column but the two ends (which have half the variance).
pub fn profile_noise_dn(sample_noise_dn: f32, span: u16) -> f32 {
    amplitude_noise_dn(sample_noise_dn, span as usize)
}
