//! Per-pixel spectrum: mean removal, window, zero padding to `N`, real DFT (microfft),
//! normalisation (SPEC §2, paper §III-D).
//!
//! The spectrum is `X_k = (1/Σh) Σ_m h_m (I_m − Ī) e^{−i2πkm/N}`, `k = 0..=N/2`, stored as
//! interleaved `(re, im)` pairs in a caller buffer of `N + 2` floats. With this scaling a pixel
//! lit by one column with fringe modulation `B` (sensor DN) shows a peak of magnitude `B/2`,
//! and white noise of variance `σ²` gives each bin a complex variance `σ²·Σh²/(Σh)²`
//! (`σ²/M` without window: eq. 21's `σ²/(2M)` per component). Bin `k` is column
//! `k·L/N` ([`ScanPlan::bin_column`]).

use crate::math::Complex;
use crate::plan::ScanPlan;

/// A pixel's spectrum (or the residual of the peak search), `N/2 + 1` complex bins.
#[derive(Debug)]
pub struct Spectrum<'s> {
    data: &'s mut [f32],
}

impl<'s> Spectrum<'s> {
    /// Borrows `N + 2` floats of `buffer` holding interleaved bins.
    pub(crate) fn new(buffer: &'s mut [f32], transform_size: usize) -> Self {
        Spectrum {
            data: &mut buffer[..transform_size + 2],
        }
    }

    /// Number of bins, `N/2 + 1`.
    #[inline]
    pub fn len(&self) -> usize {
        self.data.len() / 2
    }

    /// Never empty; present for API symmetry with `len`.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Bin `k`.
    #[inline]
    pub fn bin(&self, k: usize) -> Complex {
        Complex::new(self.data[2 * k], self.data[2 * k + 1])
    }

    /// `|X_k|`.
    #[inline]
    pub fn magnitude(&self, k: usize) -> f32 {
        self.bin(k).norm()
    }

    /// The interleaved `(re, im)` pairs.
    #[inline]
    pub(crate) fn as_slice(&self) -> &[f32] {
        self.data
    }

    /// The interleaved `(re, im)` pairs, mutable.
    #[inline]
    pub(crate) fn as_mut_slice(&mut self) -> &mut [f32] {
        self.data
    }

    /// Magnitudes of every bin, written to `out[..len]`.
    pub fn magnitudes(&self, out: &mut [f32]) {
        for (k, m) in out.iter_mut().take(self.len()).enumerate() {
            *m = self.magnitude(k);
        }
    }
}

/// What loading a pixel's fringe samples found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SampleStats {
    /// `Ī`, sensor DN.
    pub mean: f32,
    /// Whether a sample reached the saturation code.
    pub saturated: bool,
}

/// Fills `buffer[..N+2]` with the spectrum of one pixel's `M` fringe samples, sample `m`
/// being `frames[m·stride]` (a temporal row is sample-major: `stride` is the row's width).
///
/// `window` holds `h_m` (empty for the rectangular window) and `inverse_window_sum` is
/// `1/Σh`; the scaling is applied to the samples, before the (linear) transform, where it costs
/// `M` products instead of `N + 2`. The mean is computed exactly in integers so that no sample
/// order or platform can change it. `frames` must hold `(M − 1)·stride + 1` samples (with fewer,
/// every sample counts as 0; a checked row has them all).
pub(crate) fn compute(
    plan: &ScanPlan,
    frames: &[u16],
    stride: usize,
    window: &[f32],
    inverse_window_sum: f32,
    saturation: u16,
    buffer: &mut [f32],
) -> SampleStats {
    let n = plan.transform_size as usize;
    let m = plan.band.count as usize;
    // `M ≤ N ≤ 4096` codes below 2^16: the sum fits a u32 (a u64 costs a carry per sample and a
    // library conversion on the camera).
    let mut sum: u32 = 0;
    let mut brightest = 0u16;
    let (head, tail) = buffer[..n + 2].split_at_mut(m);
    // One pass over the samples (exact in f32), then the mean removal and window in place.
    match frames.get(..(m.max(1) - 1) * stride + 1) {
        Some(column) => {
            // One bounds check for the whole column; the loop reads every `stride`-th sample.
            for (i, z) in head.iter_mut().enumerate() {
                let s = column[i * stride];
                sum += s as u32;
                brightest = brightest.max(s);
                *z = s as f32;
            }
        }
        None => head.fill(0.0),
    }
    let saturated = brightest >= saturation;
    let mean = (sum as f64 / m as f64) as f32;
    if window.is_empty() {
        for z in head.iter_mut() {
            *z = (*z - mean) * inverse_window_sum;
        }
    } else {
        for (z, h) in head.iter_mut().zip(window) {
            *z = (*z - mean) * (h * inverse_window_sum);
        }
    }
    tail.fill(0.0);
    real_dft(buffer, n);
    SampleStats { mean, saturated }
}

/// In-place real DFT of `buffer[..n]` (microfft), unpacked to `n/2 + 1` interleaved bins in
/// `buffer[..n + 2]`: microfft packs the real Nyquist bin into the imaginary part of bin 0.
pub(crate) fn real_dft(buffer: &mut [f32], n: usize) {
    macro_rules! rfft {
        ($f:ident, $n:literal) => {{
            if let Ok(block) = <&mut [f32; $n]>::try_from(&mut buffer[..$n]) {
                let _ = microfft::real::$f(block);
            }
        }};
    }
    match n {
        64 => rfft!(rfft_64, 64),
        128 => rfft!(rfft_128, 128),
        256 => rfft!(rfft_256, 256),
        512 => rfft!(rfft_512, 512),
        1024 => rfft!(rfft_1024, 1024),
        2048 => rfft!(rfft_2048, 2048),
        4096 => rfft!(rfft_4096, 4096),
        // Plans are validated: N is one of the sizes above.
        _ => return,
    }
    buffer[n] = buffer[1];
    buffer[n + 1] = 0.0;
    buffer[1] = 0.0;
}
