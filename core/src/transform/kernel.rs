//! The modelled spectrum of one lit projector column (SPEC §2).
//!
//! A pixel whose light comes from integer columns `j` with weights `w_j` (in sensor DN of fringe
//! modulation) records the mean-free samples `z_m = Σ_j w_j cos(2π f_m j)`, `f_m = (n₁+m)/L`.
//! With the decoder's spectrum `X_k = (1/Σh) Σ_m h_m (I_m − Ī) e^{−i2πkm/N}` (window `h`),
//!
//! ```text
//! X_k = Σ_j w_j · b_j(k),
//! b_j(k) = ½[φ_j G(jN/L − k) + φ̄_j G(−jN/L − k)] − μ_j G(−k),
//! G(u) = (1/Σh) Σ_m h_m e^{i2πmu/N},   φ_j = e^{i2πn₁j/L},   μ_j = (1/M) Σ_m cos(2π f_m j),
//! ```
//!
//! the first term being the column's own peak, the second its mirror at `−j`, the third what the
//! mean removal takes away. `G` is periodic in `u` with period `N`, and `u` only takes values on
//! the grid `1/q` bin (`q = L/gcd(N, L)`), so the decoder tabulates `G` once per plan: `N·q`
//! complex entries, computed in `f64` from closed forms and stored as `f32`.
//!
//! The table is stored by residue class so that a column's contribution to consecutive bins is
//! a contiguous run: entry `2rN + i` holds `G` at offset `t = ((−i) mod N)·q + r` (in `1/q` bin),
//! each row stored twice so runs never wrap, and bin `k` of a term at offset `t₀` reads entry
//! `2rN + ((−⌊t₀/q⌋) mod N) + k`. Removing a peak from the spectrum is then a handful of
//! complex AXPYs over contiguous runs.

use super::spectrum::Spectrum;
use crate::math::Complex;
use crate::plan::{ScanPlan, Window};

/// Tabulated `G(u)` of a plan, borrowed from caller storage.
#[derive(Clone, Copy, Debug)]
pub struct Kernel<'t> {
    /// Interleaved `(re, im)`; entry `2rN + i` is `G(t/q)` with `t = ((−i) mod N)·q + r`.
    table: &'t [f32],
    /// `(Re φ_j, Im φ_j, μ_j)` of every column `j` of the span.
    columns: &'t [f32],
    /// `N·q`.
    len: i64,
    /// `N`.
    transform_size: i64,
    /// `q`: table entries per bin.
    per_bin: i64,
    /// `N/gcd(N, L)`: table entries per column.
    per_column: i64,
    period: i64,
    first_harmonic: i64,
    count: i64,
}

/// The per-column factors of `b_j`: `φ_j` and `μ_j`.
#[derive(Clone, Copy, Debug)]
pub struct ColumnTerms {
    /// Table offset of `jN/L`, in `1/q` bins.
    offset: i64,
    phase: Complex,
    mean: f32,
}

/// A column's table runs, located once (see [`Kernel::lookup`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct ColumnLookup {
    direct: (usize, usize),
    mirror: (usize, usize),
    zero: (usize, usize),
    phase: Complex,
    mean: f32,
}

/// Most weighted columns one [`Model`] combines (a widened fit's, `crate::peak::deconvolution`).
pub const MAX_COLUMNS: usize = 13;

/// Most terms of a [`Model`]: a direct and a mirror term per column, and the mean term.
const MODEL_TERMS: usize = 2 * MAX_COLUMNS + 1;

/// `Σ_j w_j b_j(k)` of up to [`MAX_COLUMNS`] weighted columns, as terms `c·G(t − kq)`:
/// `Σ_j (w_j/2)φ_j G(u_j − k) + Σ_j (w_j/2)φ̄_j G(−u_j − k) − (Σ_j w_j μ_j) G(−k)`.
#[derive(Clone, Copy, Debug, Default)]
pub struct Model {
    len: usize,
    /// Table entry of bin 0 of each term: `r·N` plus the start index `(−⌊t/q⌋) mod N`.
    first: [u32; MODEL_TERMS],
    coefficient: [Complex; MODEL_TERMS],
}

impl<'t> Kernel<'t> {
    /// `f32` words of storage the kernel of `plan` needs: the `G` table and, per column of the
    /// span, `φ_j` and `μ_j` (so that no trigonometry is left on the decoding path).
    pub fn storage_len(plan: &ScanPlan) -> usize {
        4 * plan.kernel_table_len() + 3 * plan.span_columns() as usize
    }

    /// Fills `storage` with the kernel of `plan` (which must be valid); `None` if `storage` is
    /// shorter than [`Kernel::storage_len`].
    pub fn build(plan: &ScanPlan, storage: &mut [f32]) -> Option<()> {
        let len = plan.kernel_table_len();
        let span = plan.span_columns() as usize;
        let (storage, column_storage) =
            storage.get_mut(..4 * len + 3 * span)?.split_at_mut(4 * len);
        let n = plan.transform_size as i64;
        let per_bin = len as i64 / n;
        let m = plan.band.count as usize;
        let window_sum = window_sum(plan.decoding.window, m);
        for (e, entry) in storage.chunks_exact_mut(2).enumerate() {
            // Each residue row is stored twice in a row (length 2N), so that a run of N/2 + 1
            // bins starting anywhere in the first copy never wraps.
            let (r, i) = (e as i64 / (2 * n), e as i64 % n);
            let t = (-i).rem_euclid(n) * per_bin + r;
            // u = t/q bins, θ = 2πu/N.
            let g = match plan.decoding.window {
                Window::Rectangular => dirichlet_grid(m as i64, t, len as i64),
                Window::Hann => {
                    let theta = core::f64::consts::TAU * t as f64 / len as f64;
                    let shift = core::f64::consts::TAU / (m as f64 - 1.0);
                    let centre = dirichlet(m, theta);
                    let up = dirichlet(m, theta + shift);
                    let down = dirichlet(m, theta - shift);
                    (
                        0.5 * centre.0 - 0.25 * (up.0 + down.0),
                        0.5 * centre.1 - 0.25 * (up.1 + down.1),
                    )
                }
            };
            entry[0] = (g.0 / window_sum) as f32;
            entry[1] = (g.1 / window_sum) as f32;
        }
        let kernel = Kernel::with_table(plan, storage, &[]);
        for (j, entry) in column_storage.chunks_exact_mut(3).enumerate() {
            let t = kernel.compute_column_terms(j as i64);
            entry.copy_from_slice(&[t.phase.re, t.phase.im, t.mean]);
        }
        Some(())
    }

    /// Reads a kernel built by [`Kernel::build`] for the same plan; `None` if `storage` is
    /// shorter than [`Kernel::storage_len`].
    pub fn view(plan: &ScanPlan, storage: &'t [f32]) -> Option<Self> {
        let len = plan.kernel_table_len();
        let span = plan.span_columns() as usize;
        let (table, columns) = storage.get(..4 * len + 3 * span)?.split_at(4 * len);
        Some(Kernel::with_table(plan, table, columns))
    }

    fn with_table(plan: &ScanPlan, table: &'t [f32], columns: &'t [f32]) -> Self {
        let len = plan.kernel_table_len() as i64;
        let n = plan.transform_size as i64;
        let per_bin = len / n;
        Kernel {
            table,
            columns,
            len,
            transform_size: n,
            per_bin,
            per_column: per_bin * n / plan.band.period_columns as i64,
            period: plan.band.period_columns as i64,
            first_harmonic: plan.band.first_harmonic as i64,
            count: plan.band.count as i64,
        }
    }

    /// `G(t/q)` for any table offset `t` (reduced modulo `N·q`).
    #[inline]
    pub fn at(&self, t: i64) -> Complex {
        let (base, start) = self.locate(t);
        self.entry(base + start)
    }

    /// Table entry of bin 0 of a term at offset `t`: `(2rN, (−⌊t/q⌋) mod N)`.
    #[inline]
    fn locate(&self, t: i64) -> (usize, usize) {
        // The same integers with fewer divisions (a Cortex-A9 divides in software, 64-bit
        // divisions slowest): one entry per bin and N a power of two (the paper's EFSM) need
        // only masks, and table offsets fit in 32 bits.
        let n = self.transform_size;
        if self.per_bin == 1 && n > 0 && n & (n - 1) == 0 {
            return (0, ((-(t & (n - 1))) & (n - 1)) as usize);
        }
        if let (Ok(t), Ok(len), Ok(q), Ok(n)) = (
            i32::try_from(t),
            i32::try_from(self.len),
            i32::try_from(self.per_bin),
            i32::try_from(n),
        ) {
            let t = t.rem_euclid(len);
            let (r, i) = (t % q, t / q);
            return (
                (2 * r as i64 * n as i64) as usize,
                (-i).rem_euclid(n) as usize,
            );
        }
        let t = t.rem_euclid(self.len);
        let (r, i) = (t % self.per_bin, t / self.per_bin);
        (
            (2 * r * self.transform_size) as usize,
            (-i).rem_euclid(self.transform_size) as usize,
        )
    }

    #[inline]
    fn entry(&self, e: usize) -> Complex {
        Complex::new(self.table[2 * e], self.table[2 * e + 1])
    }

    /// `φ_j`, `μ_j` and the table offset of column `j` (in the plan's span domain), from the
    /// column table (computed on the spot for columns outside the span).
    pub fn column_terms(&self, column: i32) -> ColumnTerms {
        let j = column as i64;
        match usize::try_from(column)
            .ok()
            .and_then(|i| self.columns.get(3 * i..3 * i + 3))
        {
            Some(c) => ColumnTerms {
                offset: j * self.per_column,
                phase: Complex::new(c[0], c[1]),
                mean: c[2],
            },
            None => self.compute_column_terms(j),
        }
    }

    fn compute_column_terms(&self, j: i64) -> ColumnTerms {
        let l = self.period;
        // φ_j = e^{iπ r/L}, r = 2n₁j mod 2L.
        let phase = turns_to_unit(
            ((2 * self.first_harmonic * j).rem_euclid(2 * l)) as f64 / (2 * l) as f64,
        );
        ColumnTerms {
            offset: j * self.per_column,
            phase,
            mean: self.column_mean(j) as f32,
        }
    }

    /// `μ_j = (1/M) Σ_m cos(2π (n₁+m) j / L)` in closed form, arguments reduced in integers.
    fn column_mean(&self, j: i64) -> f64 {
        let (l, m, n1) = (self.period, self.count, self.first_harmonic);
        let two_l = 2 * l;
        if (j).rem_euclid(l) == 0 {
            // Every term is cos(2π·integer·j/L) with j a multiple of L.
            return 1.0;
        }
        let pi = core::f64::consts::PI;
        let sin_half = libm::sin(pi * (j.rem_euclid(two_l)) as f64 / l as f64);
        let sin_m = libm::sin(pi * ((m * j).rem_euclid(two_l)) as f64 / l as f64);
        let centre = libm::cos(pi * (((2 * n1 + m - 1) * j).rem_euclid(two_l)) as f64 / l as f64);
        sin_m / sin_half * centre / m as f64
    }

    /// `b_j(k)`: the spectrum bin `k` of unit weight on the column of `terms`.
    pub fn response(&self, terms: &ColumnTerms, bin: usize) -> Complex {
        self.response_at(&self.lookup(terms), bin)
    }

    /// Locates a column's three table runs once, for [`Kernel::response_at`] on many bins.
    pub fn lookup(&self, terms: &ColumnTerms) -> ColumnLookup {
        ColumnLookup {
            direct: self.locate(terms.offset),
            mirror: self.locate(-terms.offset),
            zero: self.locate(0),
            phase: terms.phase,
            mean: terms.mean,
        }
    }

    /// `b_j(k)` from a [`ColumnLookup`]: three table reads, no division.
    #[inline]
    pub fn response_at(&self, lookup: &ColumnLookup, bin: usize) -> Complex {
        let read = |(base, start): (usize, usize)| self.entry(base + start + bin);
        let (direct, mirror, zero) = (read(lookup.direct), read(lookup.mirror), read(lookup.zero));
        let p = lookup.phase;
        Complex::new(
            0.5 * (p.re * direct.re - p.im * direct.im + p.re * mirror.re + p.im * mirror.im)
                - lookup.mean * zero.re,
            0.5 * (p.re * direct.im + p.im * direct.re + p.re * mirror.im - p.im * mirror.re)
                - lookup.mean * zero.im,
        )
    }

    /// `b_j(first_bin + i)` into `out[i]` for every `i`: [`Kernel::response_at`] over a run of
    /// consecutive bins, reading the three table runs sequentially.
    pub(crate) fn responses(&self, lookup: &ColumnLookup, first_bin: usize, out: &mut [Complex]) {
        let n = out.len();
        let run = |(base, start): (usize, usize)| {
            let e = base + start + first_bin;
            &self.table[2 * e..2 * (e + n)]
        };
        let (direct, mirror, zero) = (run(lookup.direct), run(lookup.mirror), run(lookup.zero));
        let p = lookup.phase;
        let mean = lookup.mean;
        for (((o, d), m), z) in out
            .iter_mut()
            .zip(direct.chunks_exact(2))
            .zip(mirror.chunks_exact(2))
            .zip(zero.chunks_exact(2))
        {
            // The arithmetic of `response_at`, term for term.
            *o = Complex::new(
                0.5 * (p.re * d[0] - p.im * d[1] + p.re * m[0] + p.im * m[1]) - mean * z[0],
                0.5 * (p.re * d[1] + p.im * d[0] + p.re * m[1] - p.im * m[0]) - mean * z[1],
            );
        }
    }

    /// Combines weighted columns into a [`Model`] (at most [`MAX_COLUMNS`]; more are ignored).
    pub fn model<'a>(&self, columns: impl Iterator<Item = (&'a ColumnTerms, f32)>) -> Model {
        let mut m = Model::default();
        let mut mean = 0.0f32;
        let push = |m: &mut Model, t: i64, c: Complex| {
            let (base, start) = self.locate(t);
            // Table entries fit in u32: tables are far smaller than 2^32 floats.
            m.first[m.len] = (base + start) as u32;
            m.coefficient[m.len] = c;
            m.len += 1;
        };
        for (t, w) in columns.take(MAX_COLUMNS) {
            if w == 0.0 {
                // Non-negative fits leave columns at exactly zero: nothing to add.
                continue;
            }
            let h = 0.5 * w;
            push(
                &mut m,
                t.offset,
                Complex::new(h * t.phase.re, h * t.phase.im),
            );
            push(
                &mut m,
                -t.offset,
                Complex::new(h * t.phase.re, -h * t.phase.im),
            );
            mean += w * t.mean;
        }
        push(&mut m, 0, Complex::new(-mean, 0.0));
        m
    }

    /// The value of `model` at bin `k`.
    pub fn model_at(&self, model: &Model, bin: usize) -> Complex {
        let mut sum = Complex::default();
        for i in 0..model.len {
            let c = model.coefficient[i];
            let g = self.entry(model.first[i] as usize + bin);
            sum.re += c.re * g.re - c.im * g.im;
            sum.im += c.re * g.im + c.im * g.re;
        }
        sum
    }

    /// `spectrum_k += sign·model(k)` for every bin: per term, one contiguous complex AXPY over
    /// the table.
    pub fn add_model(&self, model: &Model, spectrum: &mut Spectrum<'_>, sign: f32) {
        self.add_model_to(model, spectrum.as_mut_slice(), sign);
    }

    /// `data[2k..2k+2] += sign·model(k)` for the bins `data` holds (interleaved, from bin 0).
    pub(crate) fn add_model_to(&self, model: &Model, data: &mut [f32], sign: f32) {
        let bins = data.len() / 2;
        for i in 0..model.len {
            let c = model.coefficient[i];
            let c = Complex::new(sign * c.re, sign * c.im);
            let first = model.first[i] as usize;
            let run = &self.table[2 * first..2 * (first + bins)];
            for (y, g) in data.chunks_exact_mut(2).zip(run.chunks_exact(2)) {
                y[0] += c.re * g[0] - c.im * g[1];
                y[1] += c.re * g[1] + c.im * g[0];
            }
        }
    }
}

/// `Σ_m h_m` of a window of `m` samples.
pub(crate) fn window_sum(window: Window, m: usize) -> f64 {
    match window {
        Window::Rectangular => m as f64,
        Window::Hann => (0..m).map(|i| hann(i, m)).sum(),
    }
}

/// `Σ_m h_m²` of a window of `m` samples (the spectrum's noise gain, with [`window_sum`]).
pub(crate) fn window_sum_of_squares(window: Window, m: usize) -> f64 {
    match window {
        Window::Rectangular => m as f64,
        Window::Hann => (0..m).map(|i| hann(i, m) * hann(i, m)).sum(),
    }
}

/// Symmetric Hann weight `h_i = ½ − ½cos(2πi/(M−1))`, in `f64`.
pub(crate) fn hann(i: usize, m: usize) -> f64 {
    0.5 - 0.5 * libm::cos(core::f64::consts::TAU * i as f64 / (m as f64 - 1.0))
}

/// `e^{i2π·turns}`.
fn turns_to_unit(turns: f64) -> Complex {
    let a = core::f64::consts::TAU * turns;
    Complex::new(libm::cos(a) as f32, libm::sin(a) as f32)
}

/// `D(θ) = Σ_{m<M} e^{imθ}` at `θ = 2πt/T` (`T = N·q`), with exact integer argument reduction.
fn dirichlet_grid(m: i64, t: i64, period: i64) -> (f64, f64) {
    let t = t.rem_euclid(period);
    if t == 0 {
        return (m as f64, 0.0);
    }
    let pi = core::f64::consts::PI;
    let two_t = 2 * period;
    // D = e^{i(M−1)θ/2} · sin(Mθ/2)/sin(θ/2), θ/2 = πt/T.
    let half = pi * (t as f64) / period as f64;
    let ratio =
        libm::sin(pi * ((m * t).rem_euclid(two_t)) as f64 / period as f64) / libm::sin(half);
    let phase = pi * (((m - 1) * t).rem_euclid(two_t)) as f64 / period as f64;
    (ratio * libm::cos(phase), ratio * libm::sin(phase))
}

/// `D(θ)` for any real `θ` (used by windows whose kernel is a sum of shifted Dirichlets).
fn dirichlet(m: usize, theta: f64) -> (f64, f64) {
    let half = 0.5 * theta;
    let s = libm::sin(half);
    let phase = (m as f64 - 1.0) * half;
    if s.abs() < 1e-12 {
        // θ ≡ 0 (mod 2π): every term is 1.
        return (m as f64, 0.0);
    }
    let ratio = libm::sin(m as f64 * half) / s;
    (ratio * libm::cos(phase), ratio * libm::sin(phase))
}
