//! Local c-domain deconvolution (SPEC §2): the weights of the few projector columns that light
//! a pixel, from the complex spectrum around their peak.
//!
//! Around a peak near integer column `j₀`, the unknowns are the real weights `w_j`,
//! `j = j₀−3..=j₀+3` (inside the span), and the data the complex bins within about ±5 columns
//! of them.
//! The model `X_k = Σ_j w_j b_j(k)` ([`crate::transform::kernel`]) is exact for light that comes from
//! integer columns, which is what a projector emits: a camera footprint and the projector's
//! defocus only spread it over neighbouring columns. Light is never negative, so the weights
//! are the non-negative least-squares solution (Lawson–Hanson on the 7×7 normal equations, in
//! `f64`); the constraint is what keeps plans whose band stops short of 1/2 cycle per column
//! well posed, and it refuses to explain a residual with negative light. The column is the
//! centroid of the weights, the amplitude their sum.

// Index loops read best in the small dense linear algebra below.
#![allow(clippy::needless_range_loop)]

use crate::math::Complex;
use crate::plan::ScanPlan;
use crate::transform::kernel::{self, ColumnLookup, ColumnTerms, Kernel, Model};
use crate::transform::spectrum::Spectrum;

/// Columns on each side of the centre column that carry a weight (±3 measured better than the
/// SPEC's ±2: a 1-column defocus blur puts 1% of the light 3 columns out).
pub const HALF_WIDTH: i32 = 3;
/// Weights of an ordinary fit (precomputed per centre).
pub const FIT_COLUMNS: usize = (2 * HALF_WIDTH + 1) as usize;
/// Columns on each side of the centre of a widened fit, for light spread wider than
/// `±HALF_WIDTH` (a camera footprint of several projector columns, a strong defocus).
pub const WIDE_HALF_WIDTH: i32 = 6;
/// Most weights of one peak (a widened fit).
pub const MAX_COLUMNS: usize = (2 * WIDE_HALF_WIDTH + 1) as usize;
const _: () = assert!(MAX_COLUMNS <= kernel::MAX_COLUMNS);
/// Most weights of a joint fit of two close peaks.
pub const MAX_JOINT_COLUMNS: usize = 2 * FIT_COLUMNS + 2;
/// Bins further than this from the fitted columns (in columns) are not used by the fit…
pub const RADIUS_COLUMNS: f32 = 5.0;
/// … unless bins are coarser than this many per column radius.
const MIN_BINS_PER_SIDE: f32 = 2.5;
/// Most bins one fit reads.
pub const MAX_BINS: usize = 64;
/// A fit whose outermost weight carries more than this share of its light is widened.
const EDGE_SHARE: f32 = 0.02;
/// A rise of this share of the maximum after a fall makes the weights a second light.
const MODE_TOLERANCE: f32 = 0.1;
/// Re-centre a fit when its centroid is further than this from its centre column.
const RECENTRE_DISTANCE: f32 = 0.75;
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
    /// Whether the weights rise to one maximum and fall from it (within `MODE_TOLERANCE` of the
    /// maximum): one light, however wide, not two side by side.
    pub fn is_unimodal(&self) -> bool {
        let w = &self.weights[..self.len as usize];
        let Some((top, &max)) = w.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)) else {
            return true;
        };
        let tolerance = MODE_TOLERANCE * max;
        // Moving away from the maximum, no weight may rise above the lowest one passed.
        let falls = |side: &mut dyn Iterator<Item = f32>| {
            let mut low = max;
            for v in side {
                low = low.min(v);
                if v > low + tolerance {
                    return false;
                }
            }
            true
        };
        falls(&mut w[..top].iter().rev().copied()) && falls(&mut w[top + 1..].iter().copied())
    }

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

impl FitDomain {
    pub fn of(plan: &ScanPlan) -> Self {
        FitDomain {
            span: plan.span_columns() as i32,
            bin_width: plan.bin_width(),
            bins: plan.bin_count(),
        }
    }
}

impl Fit {
    /// Fits at `centre`, then once or twice more at the rounded centroid if it moved away;
    /// returns the fit and the centre it was fitted at.
    pub fn solve_recentred(
        kernel: &Kernel<'_>,
        table: &FitTable<'_>,
        spectrum: &Spectrum<'_>,
        mut centre: i32,
    ) -> Option<(Fit, i32)> {
        let mut fit = Fit::solve(kernel, table, spectrum, centre)?;
        for _ in 0..2 {
            let centroid = fit.weights.centroid()?;
            if (centroid - centre as f32).abs() <= RECENTRE_DISTANCE {
                break;
            }
            centre = crate::math::round(centroid) as i32;
            fit = Fit::solve(kernel, table, spectrum, centre)?;
        }
        Some((fit, centre))
    }

    /// Non-negative least-squares weights of columns `centre−3..=centre+3` (inside the span)
    /// from `spectrum`, with the centre's precomputed operator.
    pub fn solve(
        kernel: &Kernel<'_>,
        table: &FitTable<'_>,
        spectrum: &Spectrum<'_>,
        centre: i32,
    ) -> Option<Fit> {
        let mut w = [0.0f64; MAX_JOINT_COLUMNS];
        let (first, len) = table.solve(spectrum, centre, &mut w)?;
        Fit::from_weights(kernel, first, &w[..len])
    }

    /// Non-negative weights of columns `centre−6..=centre+6` (inside the span), solved directly:
    /// for light spread wider than an ordinary fit's window.
    pub fn solve_wide(
        kernel: &Kernel<'_>,
        spectrum: &Spectrum<'_>,
        domain: &FitDomain,
        centre: i32,
    ) -> Option<Fit> {
        let first = (centre - WIDE_HALF_WIDTH).max(0);
        let last = (centre + WIDE_HALF_WIDTH).min(domain.span - 1);
        let mut w = [0.0f64; MAX_JOINT_COLUMNS];
        let len = solve_columns(kernel, spectrum, domain, first, last, &mut w)?;
        Fit::from_weights(kernel, first, &w[..len])
    }

    /// Whether light remains at an edge of the fitted columns that is not the span's: the
    /// light is wider than the window, and the centroid of what it holds is biased.
    pub fn clipped(&self, domain: &FitDomain) -> bool {
        let w = &self.weights;
        let n = w.len as usize;
        let edge = EDGE_SHARE * w.amplitude();
        let last = w.first + n as i32 - 1;
        n > 0
            && ((w.first > 0 && w.weights[0] > edge)
                || (last < domain.span - 1 && w.weights[n - 1] > edge))
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

    /// `data[2k..2k+2] += model(k)` for the bins `data` holds (interleaved, from bin 0).
    pub fn add_to(&self, kernel: &Kernel<'_>, data: &mut [f32]) {
        kernel.add_model_to(&self.model, data, 1.0);
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

    let (lo, hi) = bin_range(domain, first, last)?;
    solve_normal(kernel, spectrum, &terms[..len], lo, hi, out)
}

/// The bins a fit of columns `first..=last` reads: those within `RADIUS_COLUMNS` of them (more
/// when bins are coarse), at most `MAX_BINS`, centred on the columns.
fn bin_range(domain: &FitDomain, first: i32, last: i32) -> Option<(usize, usize)> {
    let radius = RADIUS_COLUMNS.max(MIN_BINS_PER_SIDE * domain.bin_width);
    let to_bin = |c: f32| c / domain.bin_width;
    let lo = crate::math::floor(to_bin(first as f32 - radius)).max(0.0) as usize;
    let hi_f = crate::math::floor(to_bin(last as f32 + radius)) + 1.0;
    let hi = (hi_f.max(0.0) as usize).min(domain.bins);
    if hi <= lo {
        return None;
    }
    if hi - lo > MAX_BINS {
        let centre = (lo + hi) / 2;
        return Some((centre + MAX_BINS / 2 - MAX_BINS, centre + MAX_BINS / 2));
    }
    Some((lo, hi))
}

/// Bins of one chunk of [`normal_equations`].
const NORMAL_CHUNK: usize = 16;

/// Ridged Gram matrix `Re(BᴴB) + λI` (full, symmetric) of the columns' responses over bins
/// `lo..hi`, and `y = Re(Bᴴx)` when a spectrum is given.
fn normal_equations(
    kernel: &Kernel<'_>,
    lookups: &[ColumnLookup],
    lo: usize,
    hi: usize,
    spectrum: Option<&Spectrum<'_>>,
    a: &mut [[f64; MAX_JOINT_COLUMNS]; MAX_JOINT_COLUMNS],
    y: &mut [f64; MAX_JOINT_COLUMNS],
) -> bool {
    let len = lookups.len();
    if len > MAX_JOINT_COLUMNS {
        return false;
    }
    // Bins in chunks: the responses of every column over a chunk, then the sums over its bins,
    // each sum accumulated in bin order.
    let mut basis = [[Complex::default(); NORMAL_CHUNK]; MAX_JOINT_COLUMNS];
    *a = [[0.0; MAX_JOINT_COLUMNS]; MAX_JOINT_COLUMNS];
    y.fill(0.0);
    let mut start = lo;
    while start < hi {
        let n = (hi - start).min(NORMAL_CHUNK);
        for (b, l) in basis.iter_mut().zip(lookups) {
            kernel.responses(l, start, &mut b[..n]);
        }
        let basis = &basis[..len];
        if let Some(spectrum) = spectrum {
            let x = &spectrum.as_slice()[2 * start..2 * (start + n)];
            for (yi, b) in y.iter_mut().zip(basis) {
                let mut sum = *yi;
                for (bk, xk) in b[..n].iter().zip(x.chunks_exact(2)) {
                    sum += bk.dot(Complex::new(xk[0], xk[1])) as f64;
                }
                *yi = sum;
            }
        }
        for (i, (row, bi)) in a.iter_mut().zip(basis).enumerate() {
            for (aij, bj) in row[..=i].iter_mut().zip(basis) {
                let mut sum = *aij;
                for (p, q) in bi[..n].iter().zip(&bj[..n]) {
                    sum += p.dot(*q) as f64;
                }
                *aij = sum;
            }
        }
        start += n;
    }
    let mean_diagonal = (0..len).map(|i| a[i][i]).sum::<f64>() / len as f64;
    if mean_diagonal.is_nan() || mean_diagonal <= 0.0 {
        return false;
    }
    for i in 0..len {
        a[i][i] += RIDGE * mean_diagonal;
        for j in 0..i {
            a[j][i] = a[i][j];
        }
    }
    true
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
    if !normal_equations(kernel, &lookups[..len], lo, hi, Some(spectrum), &mut a, out) {
        return None;
    }
    // Light that is non-negative everywhere (the usual case) needs one unconstrained solve.
    let all = [true; MAX_JOINT_COLUMNS];
    let mut unconstrained = [0.0f64; MAX_JOINT_COLUMNS];
    if solve_free(&a, out, &all, len, &mut unconstrained)
        && unconstrained[..len].iter().all(|&v| v >= 0.0)
    {
        *out = unconstrained;
        return Some(len);
    }
    let mut hint = [false; MAX_JOINT_COLUMNS];
    for (h, &v) in hint.iter_mut().zip(&unconstrained[..len]) {
        *h = v > 0.0;
    }
    non_negative_solve(&a, out, len, &hint).then_some(len)
}

/// Per-centre least-squares operators: for a peak centred on column `c` the fitted columns and
/// the bins read are fixed, so the unconstrained solution is one precomputed product
/// `w = Re(P x)` with `P = (Re BᴴB + λI)⁻¹ Bᴴ` (SPEC §2). When a weight comes out negative the
/// non-negative solution is computed from the stored Gram matrix and `y = A w`.
///
/// Layout of the entry of centre `c` (`stride` floats): first column, number of columns, first
/// bin, number of bins `n`; the Gram matrix `A` (7×7, row-major); then per column `i` the `n`
/// pairs `(Re P_ik, −Im P_ik)`, padded to the plan's largest `n`. (`FIT_COLUMNS` of each.)
#[derive(Clone, Copy, Debug)]
pub struct FitTable<'t> {
    data: &'t [f32],
    stride: usize,
    max_bins: usize,
    span: usize,
}

const ENTRY_HEADER: usize = 4;
const GRAM_LEN: usize = FIT_COLUMNS * FIT_COLUMNS;

/// Fitted columns and bins of the fit centred on column `centre`.
fn centre_window(domain: &FitDomain, centre: i32) -> Option<(i32, i32, usize, usize)> {
    let first = (centre - HALF_WIDTH).max(0);
    let last = (centre + HALF_WIDTH).min(domain.span - 1);
    if last < first {
        return None;
    }
    let (lo, hi) = bin_range(domain, first, last)?;
    Some((first, last, lo, hi))
}

impl<'t> FitTable<'t> {
    fn max_bins(domain: &FitDomain) -> usize {
        (0..domain.span)
            .filter_map(|c| centre_window(domain, c))
            .map(|(_, _, lo, hi)| hi - lo)
            .max()
            .unwrap_or(0)
    }

    /// Floats of storage the table of `plan` needs.
    pub fn storage_len(plan: &ScanPlan) -> usize {
        let domain = FitDomain::of(plan);
        domain.span as usize * (ENTRY_HEADER + GRAM_LEN + 2 * FIT_COLUMNS * Self::max_bins(&domain))
    }

    /// Computes the operators of every centre column of `plan` into `storage`; `None` if it is
    /// shorter than [`FitTable::storage_len`].
    pub fn build(plan: &ScanPlan, kernel: &Kernel<'_>, storage: &mut [f32]) -> Option<()> {
        let domain = FitDomain::of(plan);
        let max_bins = Self::max_bins(&domain);
        let stride = ENTRY_HEADER + GRAM_LEN + 2 * FIT_COLUMNS * max_bins;
        let span = domain.span as usize;
        let data = storage.get_mut(..span * stride)?;
        for (c, entry) in data.chunks_exact_mut(stride).enumerate() {
            entry.fill(0.0);
            let Some((first, last, lo, hi)) = centre_window(&domain, c as i32) else {
                continue;
            };
            let len = (last - first + 1) as usize;
            let mut lookups = [ColumnLookup::default(); MAX_JOINT_COLUMNS];
            for (i, l) in lookups.iter_mut().take(len).enumerate() {
                *l = kernel.lookup(&kernel.column_terms(first + i as i32));
            }
            let mut a = [[0.0f64; MAX_JOINT_COLUMNS]; MAX_JOINT_COLUMNS];
            let mut unused = [0.0f64; MAX_JOINT_COLUMNS];
            if !normal_equations(kernel, &lookups[..len], lo, hi, None, &mut a, &mut unused) {
                continue;
            }
            // A⁻¹ column by column.
            let mut inverse = [[0.0f64; MAX_JOINT_COLUMNS]; MAX_JOINT_COLUMNS];
            let all = [true; MAX_JOINT_COLUMNS];
            let mut ok = true;
            for j in 0..len {
                let mut e = [0.0f64; MAX_JOINT_COLUMNS];
                e[j] = 1.0;
                let mut col = [0.0f64; MAX_JOINT_COLUMNS];
                ok &= solve_free(&a, &e, &all, len, &mut col);
                for i in 0..len {
                    inverse[i][j] = col[i];
                }
            }
            if !ok {
                continue;
            }
            entry[0] = first as f32;
            entry[1] = len as f32;
            entry[2] = lo as f32;
            entry[3] = (hi - lo) as f32;
            for i in 0..len {
                for j in 0..len {
                    entry[ENTRY_HEADER + i * FIT_COLUMNS + j] = a[i][j] as f32;
                }
            }
            let operator = &mut entry[ENTRY_HEADER + GRAM_LEN..];
            for k in lo..hi {
                let mut basis = [Complex::default(); MAX_JOINT_COLUMNS];
                for (b, l) in basis.iter_mut().zip(lookups.iter()).take(len) {
                    *b = kernel.response_at(l, k);
                }
                for i in 0..len {
                    // P_ik = Σ_j A⁻¹_ij conj(b_j(k)); stored as (Re P, −Im P) so that
                    // w_i = Σ_k Re(P_ik x_k) is a real dot product with (Re x, Im x).
                    let (mut re, mut im) = (0.0f64, 0.0f64);
                    for j in 0..len {
                        re += inverse[i][j] * basis[j].re as f64;
                        im += inverse[i][j] * basis[j].im as f64;
                    }
                    let at = 2 * (i * max_bins + (k - lo));
                    operator[at] = re as f32;
                    operator[at + 1] = im as f32;
                }
            }
        }
        Some(())
    }

    /// Reads operators built by [`FitTable::build`] for the same plan.
    pub fn view(plan: &ScanPlan, storage: &'t [f32]) -> Option<Self> {
        let domain = FitDomain::of(plan);
        let max_bins = Self::max_bins(&domain);
        let stride = ENTRY_HEADER + GRAM_LEN + 2 * FIT_COLUMNS * max_bins;
        let span = domain.span as usize;
        let data = storage.get(..span * stride)?;
        Some(FitTable {
            data,
            stride,
            max_bins,
            span,
        })
    }

    /// Non-negative weights of the fit centred on `centre`; returns the first column and the
    /// number of weights written to `out`.
    fn solve(
        &self,
        spectrum: &Spectrum<'_>,
        centre: i32,
        out: &mut [f64; MAX_JOINT_COLUMNS],
    ) -> Option<(i32, usize)> {
        let c = usize::try_from(centre).ok().filter(|&c| c < self.span)?;
        let entry = &self.data[c * self.stride..(c + 1) * self.stride];
        let (first, len, lo, bins) = (
            entry[0] as i32,
            entry[1] as usize,
            entry[2] as usize,
            entry[3] as usize,
        );
        if len == 0 || lo + bins > spectrum.len() {
            return None;
        }
        let x = &spectrum.as_slice()[2 * lo..2 * (lo + bins)];
        let operator = &entry[ENTRY_HEADER + GRAM_LEN..];
        let mut negative = false;
        for i in 0..len {
            let row = &operator[2 * i * self.max_bins..2 * (i * self.max_bins + bins)];
            let w: f32 = row.iter().zip(x).map(|(p, x)| p * x).sum();
            out[i] = w as f64;
            negative |= w < 0.0;
        }
        if !negative {
            return Some((first, len));
        }
        // A system of the fit's own size: the solver's work arrays stay small.
        let len = len.min(FIT_COLUMNS);
        let mut a = [[0.0f64; FIT_COLUMNS]; FIT_COLUMNS];
        for i in 0..len {
            for j in 0..len {
                a[i][j] = entry[ENTRY_HEADER + i * FIT_COLUMNS + j] as f64;
            }
        }
        let mut y = [0.0f64; FIT_COLUMNS];
        let mut hint = [false; FIT_COLUMNS];
        for i in 0..len {
            y[i] = (0..len).map(|j| a[i][j] * out[j]).sum();
            hint[i] = out[i] > 0.0;
        }
        if !non_negative_solve(&a, &mut y, len, &hint) {
            return None;
        }
        out[..FIT_COLUMNS].copy_from_slice(&y);
        out[FIT_COLUMNS..].fill(0.0);
        Some((first, len))
    }
}

/// Non-negative least squares on the normal equations, `min ½wᵀAw − yᵀw` subject to `w ≥ 0`
/// (Lawson–Hanson active set). Light is never negative: without the constraint, a band that
/// stops short of 1/2 cycle per column leaves alternating weights unobserved, and noise fills
/// them with large values of both signs. `A` is full and symmetric; the solution overwrites
/// `y`. Returns `false` if a subproblem is not positive definite.
fn non_negative_solve<const S: usize>(
    a: &[[f64; S]; S],
    y: &mut [f64; S],
    n: usize,
    hint: &[bool; S],
) -> bool {
    let scale = (0..n).map(|i| y[i].abs()).fold(0.0, f64::max);
    let tolerance = 1e-9 * scale.max(f64::MIN_POSITIVE);
    // Usually the weights the unconstrained solution left positive are the free set: solve on
    // them and accept if the result satisfies the optimality (KKT) conditions.
    let mut guess = [0.0f64; S];
    if solve_free(a, y, hint, n, &mut guess) {
        let feasible = (0..n).all(|j| !hint[j] || guess[j] > 0.0);
        let optimal = (0..n).all(|j| {
            hint[j] || y[j] - (0..n).map(|k| a[j][k] * guess[k]).sum::<f64>() <= tolerance
        });
        if feasible && optimal {
            *y = guess;
            return true;
        }
    }
    let mut w = [0.0f64; S];
    let mut free = [false; S];
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
        // Each pass leaves at least one weight (the one that blocks the step) out of the free
        // set, so at most n passes: rounding must not leave it a hair above zero and free,
        // which would repeat the same step for ever.
        for _ in 0..n {
            let mut s = [0.0f64; S];
            if !solve_free(a, y, &free, n, &mut s) {
                return false;
            }
            if (0..n).all(|j| !free[j] || s[j] > 0.0) {
                w = s;
                break;
            }
            // Step from w towards s until the first free weight reaches zero.
            let mut alpha = 1.0f64;
            let mut blocking = None;
            for j in 0..n {
                if free[j] && s[j] <= 0.0 {
                    // w_j > 0 ≥ s_j for every free weight but the one just freed (w_j = 0).
                    let step = if w[j] > 0.0 {
                        w[j] / (w[j] - s[j])
                    } else {
                        0.0
                    };
                    if blocking.is_none() || step < alpha {
                        alpha = step;
                        blocking = Some(j);
                    }
                }
            }
            for j in 0..n {
                w[j] += alpha * (s[j] - w[j]);
                if free[j] && (w[j] <= 0.0 || blocking == Some(j)) {
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
fn solve_free<const S: usize>(
    a: &[[f64; S]; S],
    y: &[f64; S],
    free: &[bool; S],
    n: usize,
    out: &mut [f64; S],
) -> bool {
    let mut index = [0usize; S];
    let mut m = 0;
    for j in 0..n {
        if free[j] {
            index[m] = j;
            m += 1;
        }
    }
    let mut sub = [[0.0f64; S]; S];
    let mut rhs = [0.0f64; S];
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
/// overwrites `y`. Returns `false` if `A` is not positive definite. By `A = L D Lᵀ` (unit `L`):
/// Cholesky without its square roots, which a Cortex-A9 computes in software.
fn cholesky_solve<const S: usize>(a: &mut [[f64; S]; S], y: &mut [f64; S], n: usize) -> bool {
    for j in 0..n {
        let mut d = a[j][j];
        for k in 0..j {
            d -= a[j][k] * a[j][k] * a[k][k];
        }
        if d.is_nan() || d <= 0.0 {
            return false;
        }
        a[j][j] = d;
        for i in j + 1..n {
            let mut s = a[i][j];
            for k in 0..j {
                s -= a[i][k] * a[j][k] * a[k][k];
            }
            a[i][j] = s / d;
        }
    }
    // L z = y, D w = z, then Lᵀ x = w.
    for i in 0..n {
        let mut s = y[i];
        for k in 0..i {
            s -= a[i][k] * y[k];
        }
        y[i] = s;
    }
    for i in 0..n {
        y[i] /= a[i][i];
    }
    for i in (0..n).rev() {
        let mut s = y[i];
        for k in i + 1..n {
            s -= a[k][i] * y[k];
        }
        y[i] = s;
    }
    true
}
