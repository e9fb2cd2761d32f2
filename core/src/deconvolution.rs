//! Local c-domain deconvolution (SPEC §2): the weights of the few projector columns that light
//! a pixel, from the complex spectrum around their peak.
//!
//! Around a peak near integer column `j₀`, the unknowns are the real weights `w_j`,
//! `j = j₀−3..=j₀+3` (inside the span), and the data the complex bins within about ±5 columns
//! of them.
//! The model `X_k = Σ_j w_j b_j(k)` ([`crate::kernel`]) is exact for light that comes from
//! integer columns, which is what a projector emits: a camera footprint and the projector's
//! defocus only spread it over neighbouring columns. Light is never negative, so the weights
//! are the non-negative least-squares solution (Lawson–Hanson on the 7×7 normal equations, in
//! `f64`); the constraint is what keeps plans whose band stops short of 1/2 cycle per column
//! well posed, and it refuses to explain a residual with negative light. The column is the
//! centroid of the weights, the amplitude their sum.

// Index loops read best in the small dense linear algebra below.
#![allow(clippy::needless_range_loop)]

use crate::kernel::{ColumnLookup, ColumnTerms, Kernel, Model};
use crate::math::Complex;
use crate::spectrum::Spectrum;

/// Columns on each side of the centre column that carry a weight (±3 measured better than the
/// SPEC's ±2: a 1-column defocus blur puts 1% of the light 3 columns out).
pub const HALF_WIDTH: i32 = 3;
/// Most weights of one peak.
pub const MAX_COLUMNS: usize = (2 * HALF_WIDTH + 1) as usize;
/// Most weights of a joint fit of two close peaks.
pub const MAX_JOINT_COLUMNS: usize = 2 * MAX_COLUMNS + 2;
/// Bins further than this from the fitted columns (in columns) are not used by the fit…
pub const RADIUS_COLUMNS: f32 = 5.0;
/// … unless bins are coarser than this many per column radius.
const MIN_BINS_PER_SIDE: f32 = 2.5;
/// Most bins one fit reads.
pub const MAX_BINS: usize = 64;
/// Ridge added to the normal equations, relative to their mean diagonal.
const RIDGE: f64 = 1e-6;

/// Fitted weights of consecutive projector columns.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ColumnWeights {
    /// Column of `weights[0]` (span domain).
    pub first: i32,
    /// Number of weights used.
    pub len: u8,
    /// `w_j`, sensor DN of fringe modulation; may be slightly negative (noise).
    pub weights: [f32; MAX_COLUMNS],
}

impl ColumnWeights {
    /// `(column, weight)` pairs.
    pub fn iter(&self) -> impl Iterator<Item = (i32, f32)> + '_ {
        (0..self.len as usize).map(move |i| (self.first + i as i32, self.weights[i]))
    }

    /// Sum of the non-negative weights.
    pub fn amplitude(&self) -> f32 {
        self.iter().map(|(_, w)| w.max(0.0)).sum()
    }

    /// Light-weighted column of the non-negative weights, or `None` if none is positive.
    pub fn centroid(&self) -> Option<f32> {
        let (mut sum, mut moment) = (0.0f32, 0.0f32);
        for (j, w) in self.iter() {
            if w > 0.0 {
                sum += w;
                moment += w * j as f32;
            }
        }
        (sum > 0.0).then(|| moment / sum)
    }
}

/// A fit together with the kernel factors of its columns, so the model can be applied to the
/// whole spectrum without recomputing them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Fit {
    pub weights: ColumnWeights,
    model: Model,
}

/// Geometry of the fit in one plan.
#[derive(Clone, Copy, Debug)]
pub(crate) struct FitDomain {
    /// Columns `0..span` can carry light.
    pub span: i32,
    /// Columns per bin, `L/N`.
    pub bin_width: f32,
    /// `N/2 + 1`.
    pub bins: usize,
}

impl Fit {
    /// Least-squares weights of columns `centre−3..=centre+3` (inside the span) from `spectrum`.
    pub fn solve(
        kernel: &Kernel<'_>,
        spectrum: &Spectrum<'_>,
        domain: &FitDomain,
        centre: i32,
    ) -> Option<Fit> {
        let first = (centre - HALF_WIDTH).max(0);
        let last = (centre + HALF_WIDTH).min(domain.span - 1);
        let mut w = [0.0f64; MAX_JOINT_COLUMNS];
        let len = solve_columns(kernel, spectrum, domain, first, last, &mut w)?;
        Fit::from_weights(kernel, first, &w[..len])
    }

    /// Joint least-squares weights of two close peaks centred at `a < b`: one solve over the
    /// union of their columns, split at the midpoint, so that neither fit claims the other's
    /// light (SPEC §2: close peaks need a joint fit).
    pub fn solve_pair(
        kernel: &Kernel<'_>,
        spectrum: &Spectrum<'_>,
        domain: &FitDomain,
        a: f32,
        b: f32,
    ) -> Option<(Fit, Fit)> {
        let (ca, cb) = (crate::math::round(a) as i32, crate::math::round(b) as i32);
        let split = crate::math::floor(0.5 * (a + b)) as i32;
        let first = (ca - HALF_WIDTH).max(split - 2 * HALF_WIDTH).max(0);
        let last = (cb + HALF_WIDTH)
            .min(split + 1 + 2 * HALF_WIDTH)
            .min(domain.span - 1);
        if !(first <= split && split < last) {
            return None;
        }
        let mut w = [0.0f64; MAX_JOINT_COLUMNS];
        let len = solve_columns(kernel, spectrum, domain, first, last, &mut w)?;
        let left = (split - first + 1) as usize;
        let fa = Fit::from_weights(kernel, first, &w[..left])?;
        let fb = Fit::from_weights(kernel, split + 1, &w[left..len])?;
        Some((fa, fb))
    }

    fn from_weights(kernel: &Kernel<'_>, first: i32, w: &[f64]) -> Option<Fit> {
        if w.is_empty() || w.len() > MAX_COLUMNS {
            return None;
        }
        let mut weights = ColumnWeights {
            first,
            len: w.len() as u8,
            weights: [0.0; MAX_COLUMNS],
        };
        let mut terms = [None; MAX_COLUMNS];
        for (i, &v) in w.iter().enumerate() {
            let v = v as f32;
            if !v.is_finite() {
                return None;
            }
            weights.weights[i] = v;
            terms[i] = Some(kernel.column_terms(first + i as i32));
        }
        let model = kernel.model(terms.iter().flatten().zip(weights.weights.iter().copied()));
        Some(Fit { weights, model })
    }

    /// `X_k += sign·Σ_j w_j b_j(k)` for every bin: `sign = −1` removes the peak, `+1` restores it.
    pub fn apply(&self, kernel: &Kernel<'_>, spectrum: &mut Spectrum<'_>, sign: f32) {
        kernel.add_model(&self.model, spectrum, sign);
    }

    /// The modelled value of bin `k`.
    #[inline]
    pub fn model(&self, kernel: &Kernel<'_>, k: usize) -> Complex {
        kernel.model_at(&self.model, k)
    }
}

/// Least-squares weights of columns `first..=last` (at most `MAX_JOINT_COLUMNS`) from the bins
/// within `RADIUS_COLUMNS` of them; returns the number of weights written to `out`.
fn solve_columns(
    kernel: &Kernel<'_>,
    spectrum: &Spectrum<'_>,
    domain: &FitDomain,
    first: i32,
    last: i32,
    out: &mut [f64; MAX_JOINT_COLUMNS],
) -> Option<usize> {
    if last < first || (last - first) as usize >= MAX_JOINT_COLUMNS {
        return None;
    }
    let len = (last - first + 1) as usize;
    let mut terms = [None; MAX_JOINT_COLUMNS];
    for (i, t) in terms.iter_mut().take(len).enumerate() {
        *t = Some(kernel.column_terms(first + i as i32));
    }

    let radius = RADIUS_COLUMNS.max(MIN_BINS_PER_SIDE * domain.bin_width);
    let to_bin = |c: f32| c / domain.bin_width;
    let lo = crate::math::floor(to_bin(first as f32 - radius)).max(0.0) as usize;
    let hi_f = crate::math::floor(to_bin(last as f32 + radius)) + 1.0;
    let mut hi = (hi_f.max(0.0) as usize).min(domain.bins);
    if hi <= lo {
        return None;
    }
    if hi - lo > MAX_BINS {
        let centre = (lo + hi) / 2;
        hi = centre + MAX_BINS / 2;
        return solve_normal(kernel, spectrum, &terms[..len], hi - MAX_BINS, hi, out);
    }
    solve_normal(kernel, spectrum, &terms[..len], lo, hi, out)
}

fn solve_normal(
    kernel: &Kernel<'_>,
    spectrum: &Spectrum<'_>,
    terms: &[Option<ColumnTerms>],
    lo: usize,
    hi: usize,
    out: &mut [f64; MAX_JOINT_COLUMNS],
) -> Option<usize> {
    let len = terms.len();
    let mut lookups = [ColumnLookup::default(); MAX_JOINT_COLUMNS];
    for (l, t) in lookups.iter_mut().zip(terms.iter()) {
        *l = kernel.lookup(t.as_ref()?);
    }
    let mut a = [[0.0f64; MAX_JOINT_COLUMNS]; MAX_JOINT_COLUMNS];
    let y = out;
    y.fill(0.0);
    let mut basis = [Complex::default(); MAX_JOINT_COLUMNS];
    for k in lo..hi {
        for (b, l) in basis.iter_mut().zip(lookups.iter()).take(len) {
            *b = kernel.response_at(l, k);
        }
        let x = spectrum.bin(k);
        for i in 0..len {
            y[i] += basis[i].dot(x) as f64;
            for j in 0..=i {
                a[i][j] += basis[i].dot(basis[j]) as f64;
            }
        }
    }
    let mean_diagonal = (0..len).map(|i| a[i][i]).sum::<f64>() / len as f64;
    if mean_diagonal.is_nan() || mean_diagonal <= 0.0 {
        return None;
    }
    for (i, row) in a.iter_mut().enumerate().take(len) {
        row[i] += RIDGE * mean_diagonal;
    }
    for i in 0..len {
        for j in 0..i {
            a[j][i] = a[i][j];
        }
    }
    non_negative_solve(&a, y, len).then_some(len)
}

/// Non-negative least squares on the normal equations, `min ½wᵀAw − yᵀw` subject to `w ≥ 0`
/// (Lawson–Hanson active set). Light is never negative: without the constraint, a band that
/// stops short of 1/2 cycle per column leaves alternating weights unobserved, and noise fills
/// them with large values of both signs. `A` is full and symmetric; the solution overwrites
/// `y`. Returns `false` if a subproblem is not positive definite.
fn non_negative_solve(
    a: &[[f64; MAX_JOINT_COLUMNS]; MAX_JOINT_COLUMNS],
    y: &mut [f64; MAX_JOINT_COLUMNS],
    n: usize,
) -> bool {
    let mut w = [0.0f64; MAX_JOINT_COLUMNS];
    let mut free = [false; MAX_JOINT_COLUMNS];
    let scale = (0..n).map(|i| y[i].abs()).fold(0.0, f64::max);
    let tolerance = 1e-9 * scale.max(f64::MIN_POSITIVE);
    for _ in 0..3 * n {
        // Gradient of the objective's negative: y − A w.
        let mut best = None;
        let mut best_gradient = tolerance;
        for j in 0..n {
            if !free[j] {
                let g = y[j] - (0..n).map(|k| a[j][k] * w[k]).sum::<f64>();
                if g > best_gradient {
                    best_gradient = g;
                    best = Some(j);
                }
            }
        }
        let Some(t) = best else { break };
        free[t] = true;
        loop {
            let mut s = [0.0f64; MAX_JOINT_COLUMNS];
            if !solve_free(a, y, &free, n, &mut s) {
                return false;
            }
            if (0..n).all(|j| !free[j] || s[j] > 0.0) {
                w = s;
                break;
            }
            // Step from w towards s until the first free weight reaches zero.
            let mut alpha = 1.0f64;
            for j in 0..n {
                if free[j] && s[j] <= 0.0 {
                    let step = w[j] / (w[j] - s[j]);
                    if step < alpha {
                        alpha = step;
                    }
                }
            }
            for j in 0..n {
                w[j] += alpha * (s[j] - w[j]);
                if free[j] && w[j] <= 0.0 {
                    free[j] = false;
                    w[j] = 0.0;
                }
            }
            if !free.iter().take(n).any(|&f| f) {
                break;
            }
        }
    }
    y[..n].copy_from_slice(&w[..n]);
    y[n..].fill(0.0);
    true
}

/// Unconstrained solution over the free weights (the others held at zero), by Cholesky.
fn solve_free(
    a: &[[f64; MAX_JOINT_COLUMNS]; MAX_JOINT_COLUMNS],
    y: &[f64; MAX_JOINT_COLUMNS],
    free: &[bool; MAX_JOINT_COLUMNS],
    n: usize,
    out: &mut [f64; MAX_JOINT_COLUMNS],
) -> bool {
    let mut index = [0usize; MAX_JOINT_COLUMNS];
    let mut m = 0;
    for j in 0..n {
        if free[j] {
            index[m] = j;
            m += 1;
        }
    }
    let mut sub = [[0.0f64; MAX_JOINT_COLUMNS]; MAX_JOINT_COLUMNS];
    let mut rhs = [0.0f64; MAX_JOINT_COLUMNS];
    for r in 0..m {
        rhs[r] = y[index[r]];
        for c in 0..=r {
            sub[r][c] = a[index[r]][index[c]];
        }
    }
    if !cholesky_solve(&mut sub, &mut rhs, m) {
        return false;
    }
    out.fill(0.0);
    for r in 0..m {
        out[index[r]] = rhs[r];
    }
    true
}

/// Solves `A x = y` for symmetric positive definite `A` (lower triangle filled); `x`
/// overwrites `y`. Returns `false` if `A` is not positive definite.
fn cholesky_solve(
    a: &mut [[f64; MAX_JOINT_COLUMNS]; MAX_JOINT_COLUMNS],
    y: &mut [f64; MAX_JOINT_COLUMNS],
    n: usize,
) -> bool {
    for j in 0..n {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[j][k] * a[j][k];
        }
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        let d = libm::sqrt(d);
        a[j][j] = d;
        for i in j + 1..n {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k];
            }
            a[i][j] = s / d;
        }
    }
    // L z = y, then Lᵀ x = z.
    for i in 0..n {
        let mut s = y[i];
        for k in 0..i {
            s -= a[i][k] * y[k];
        }
        y[i] = s / a[i][i];
    }
    for i in (0..n).rev() {
        let mut s = y[i];
        for k in i + 1..n {
            s -= a[k][i] * y[k];
        }
        y[i] = s / a[i][i];
    }
    true
}
