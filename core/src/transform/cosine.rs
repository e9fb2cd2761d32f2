//! Inverse DCT-I of `span + 1` points, the FSM spectrum inversion, for `L` pixels at once.
//!
//! Forward model `z_h = Σ_(j=0..n) p_j·cos(πhj/n)`, `h = 0..=n`, `n = span`. Its inverse is
//! `p_j = (c_j/n)·[z_0/2 + (−1)^j·z_n/2 + Σ_(h=1..n−1) z_h·cos(πhj/n)]`, `c_j = 2` inside,
//! `1` at `j ∈ {0, n}`; the bracket is the DCT-I `Y` of `z`, so `p = (c/n)·Y`.
//!
//! # Even span (`n = 2m`): real FFT of `n` from a complex FFT of `m`
//! (Numerical Recipes' `cosft1`, with the scale folded into the tables.)
//! 1. Fold: `a_j = z_j + z_(n−j)`, `b_j = z_j − z_(n−j)`, and
//!    `g_j = a_j/(2n) − (sin(πj/n)/n)·b_j`, `g_(n−j) = a_j/(2n) + (sin(πj/n)/n)·b_j`
//!    (`g_0 = (z_0 + z_n)/(2n)`, `g_m = z_m/n`): the symmetric part of `g` carries the even
//!    outputs, the antisymmetric part (times a sine) the differences of the odd outputs.
//! 2. Pack `c_k = g_(2k) + i·g_(2k+1)` and FFT it (`m` points): `Z`.
//! 3. Unpack `G_k = (Z_k + Z̄_(m−k)) − i·e^(−2πik/n)·(Z_k − Z̄_(m−k))`, the real FFT of
//!    `g` times two: `p_(2k) = Re G_k`, and `p_(2k+1) = p_(2k−1) − Im G_k`, a running sum
//!    started from both ends: `p_1 = (z_0 − z_n)/n + S_e + S_o` and
//!    `p_(n−1) = (z_0 − z_n)/n + S_e − S_o`, where `S_e`, `S_o` sum `(2cos(πj/n)/n)·b_j`
//!    over even and odd `j` (computed in step 1), so each chain is only `n/4` long.
//!    `p_0 = Re Z_0 + Im Z_0`, `p_n = Re Z_0 − Im Z_0`.
//!
//! # Odd span: complex FFT of `n` on the even extension
//! `x_j = z_j` (`j ≤ n`), `z_(2n−j)` (`j > n`) is real and even with `Y_k = ½·DFT_2n(x)_k`;
//! its real FFT of `2n` comes from a complex FFT of `n` of `c_j = (x_2j + i·x_(2j+1))/(2n)`
//! with the same unpacking (twiddle `e^(−iπk/n)`), keeping only the real parts. About twice
//! the work of the even route, but stable (no running sum).
//!
//! # Tables (f32s, in order)
//! * header: `[n, 1/(2n), 1/n, kind]` (`kind` 2 even, 1 odd: [`CosineTransform::view`]
//!   checks it against the span);
//! * even only, fold weights: `(sin(πj/n)/n, 2cos(πj/n)/n)` for `j = 1..m`;
//! * unpack twiddles: `(cos θ_k, sin θ_k)`, `k = 1..=(m−1)/2` with `θ_k = 2πk/n` (even) or
//!   `k = 1..=(n−1)/2` with `θ_k = πk/n` (odd);
//! * the FFT tables of `m` (even) or `n` (odd), see [`crate::transform::fft`].
//!
//! Scratch: `n` lanes (even: the FFT input planes; `data` serves as its ping-pong buffer),
//! `4n` lanes (odd: FFT input and work buffer).
//!
//! # Paths
//! The `L` pixels run as `L/W` chunks of `W`-lane vectors (`simd.rs`): on x86-64
//! AVX-512F (`W = 16`) or AVX (`W = 8`) when the crate is built with them and `W` divides
//! `L`, else SSE2 (`W = 4`, the x86-64 baseline) when 4 divides `L`, else scalar `f32`
//! (`W = 1`, every other target and lane count; [`CosineTransform::inverse_scalar`] forces
//! it); a caller that detected AVX2 or AVX-512F at run time enters
//! `CosineTransform::inverse_with` with its vector type from a function compiled for it. Each path runs the same code with the same operations in the same order per lane,
//! so every path and every `L` gives the bits of the scalar path. Chunk `c` reads and
//! writes lanes `cW..(c+1)W` of `data` and keeps its FFT planes contiguous (scratch and
//! the reused part of `data` are laid out chunk after chunk): all chunks fold before any
//! FFT borrows `data`, and all FFTs end before any unpack writes it. The fold and unpack
//! loops zip only `TrustedRandomAccess` iterators (backward runs as one-item `rchunks`),
//! so they keep one counter. Every pass is inlined into its caller, so that a caller
//! compiled with a target feature compiles them with it (a separate function would not
//! inline the vector instructions; inlined, they measured 5% more instructions than as
//! separate functions).

use core::fmt;

use crate::transform::fft::{cis, Fft};
use crate::transform::simd::{Arith, Vector};
use crate::transform::Lanes;

/// Smallest supported span.
pub const MIN_SPAN: usize = 2;
/// Largest supported span.
pub const MAX_SPAN: usize = 16384;

const HEADER: usize = 4;
const KIND_EVEN: f32 = 2.0;
const KIND_ODD: f32 = 1.0;

/// Why a transform could not be built, viewed or run: what is short, needed vs got.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransformError {
    /// The span is outside `MIN_SPAN..=MAX_SPAN`.
    SpanOutOfRange {
        /// The span asked for.
        span: usize,
    },
    /// An FFT length is outside `1..=max`.
    LengthOutOfRange {
        /// The length asked for.
        len: usize,
        /// The largest supported length.
        max: usize,
    },
    /// The table storage is shorter than the span needs.
    TablesTooShort {
        /// f32s needed.
        needed: usize,
        /// f32s given.
        got: usize,
    },
    /// The tables' header does not describe tables built for this span.
    TablesNotBuilt {
        /// The span the tables were viewed for.
        span: usize,
    },
    /// The signal slice is shorter than the transform.
    DataTooShort {
        /// Lanes needed.
        needed: usize,
        /// Lanes given.
        got: usize,
    },
    /// The scratch slice is shorter than the transform needs.
    ScratchTooShort {
        /// Lanes needed.
        needed: usize,
        /// Lanes given.
        got: usize,
    },
}

impl fmt::Display for TransformError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            TransformError::SpanOutOfRange { span } => {
                write!(f, "span {span} outside {MIN_SPAN}..={MAX_SPAN}")
            }
            TransformError::LengthOutOfRange { len, max } => {
                write!(f, "FFT length {len} outside 1..={max}")
            }
            TransformError::TablesTooShort { needed, got } => {
                write!(f, "tables too short: need {needed} f32, got {got}")
            }
            TransformError::TablesNotBuilt { span } => {
                write!(f, "tables were not built for span {span}")
            }
            TransformError::DataTooShort { needed, got } => {
                write!(f, "data too short: need {needed} lanes, got {got}")
            }
            TransformError::ScratchTooShort { needed, got } => {
                write!(f, "scratch too short: need {needed} lanes, got {got}")
            }
        }
    }
}

/// Where each part of the tables lives, derived from the span alone.
#[derive(Clone, Copy)]
struct Layout {
    even: bool,
    /// FFT length: `n/2` (even) or `n` (odd).
    m: usize,
    fold: usize,
    fold_len: usize,
    unpack: usize,
    unpack_len: usize,
    fft: usize,
    fft_len: usize,
}

impl Layout {
    fn new(span: usize) -> Layout {
        let even = span.is_multiple_of(2);
        let m = if even { span / 2 } else { span };
        let fold_len = if even { 2 * (m - 1) } else { 0 };
        let unpack_len = 2 * ((m - 1) / 2);
        let fold = HEADER;
        let unpack = fold + fold_len;
        let fft = unpack + unpack_len;
        Layout {
            even,
            m,
            fold,
            fold_len,
            unpack,
            unpack_len,
            fft,
            fft_len: Fft::tables_len(m),
        }
    }

    fn total(&self) -> usize {
        self.fft + self.fft_len
    }
}

fn check_span(span: usize) -> Result<(), TransformError> {
    if (MIN_SPAN..=MAX_SPAN).contains(&span) {
        Ok(())
    } else {
        Err(TransformError::SpanOutOfRange { span })
    }
}

/// A planned inverse DCT-I for one span, borrowing tables filled by [`CosineTransform::build`].
#[derive(Clone, Copy, Debug)]
pub struct CosineTransform<'t> {
    span: usize,
    even: bool,
    /// `1/(2n)` and `1/n`, from the header.
    half_inv: f32,
    inv: f32,
    fold: &'t [f32],
    unpack: &'t [f32],
    fft: Fft<'t>,
}

impl<'t> CosineTransform<'t> {
    /// f32s of table storage for `span` (0 if the span is out of range).
    pub fn tables_len(span: usize) -> usize {
        if check_span(span).is_err() {
            return 0;
        }
        Layout::new(span).total()
    }

    /// [`Lanes`] of scratch [`CosineTransform::inverse`] needs for `span`, for every `L`.
    pub fn scratch_len(span: usize) -> usize {
        if check_span(span).is_err() {
            0
        } else if span.is_multiple_of(2) {
            span
        } else {
            4 * span
        }
    }

    /// Fills `tables[..tables_len(span)]`. Every value is computed in f64 from an exact
    /// rational multiple of π and rounded once, so every machine gets the same bits.
    pub fn build(span: usize, tables: &mut [f32]) -> Result<(), TransformError> {
        check_span(span)?;
        let lay = Layout::new(span);
        let needed = lay.total();
        if tables.len() < needed {
            return Err(TransformError::TablesTooShort {
                needed,
                got: tables.len(),
            });
        }
        let n = span as f64;
        let two_n = 2 * span as u64;
        tables[0] = span as f32;
        tables[1] = (1.0 / (2.0 * n)) as f32;
        tables[2] = (1.0 / n) as f32;
        tables[3] = if lay.even { KIND_EVEN } else { KIND_ODD };
        let fold = &mut tables[lay.fold..lay.fold + lay.fold_len];
        for (j, w) in fold.chunks_exact_mut(2).enumerate() {
            let (c, s) = cis(j as u64 + 1, two_n);
            w[0] = (s / n) as f32;
            w[1] = (2.0 * c / n) as f32;
        }
        let unpack = &mut tables[lay.unpack..lay.unpack + lay.unpack_len];
        let den = if lay.even { span as u64 } else { two_n };
        for (k, w) in unpack.chunks_exact_mut(2).enumerate() {
            let (c, s) = cis(k as u64 + 1, den);
            w[0] = c as f32;
            w[1] = s as f32;
        }
        Fft::build(lay.m, &mut tables[lay.fft..needed])
    }

    /// Borrows tables built by [`CosineTransform::build`] for `span` (no recomputation).
    pub fn view(span: usize, tables: &'t [f32]) -> Result<Self, TransformError> {
        check_span(span)?;
        let lay = Layout::new(span);
        let needed = lay.total();
        if tables.len() < needed {
            return Err(TransformError::TablesTooShort {
                needed,
                got: tables.len(),
            });
        }
        let kind = if lay.even { KIND_EVEN } else { KIND_ODD };
        if tables[0] != span as f32 || tables[3] != kind {
            return Err(TransformError::TablesNotBuilt { span });
        }
        Ok(CosineTransform {
            span,
            even: lay.even,
            half_inv: tables[1],
            inv: tables[2],
            fold: &tables[lay.fold..lay.fold + lay.fold_len],
            unpack: &tables[lay.unpack..lay.unpack + lay.unpack_len],
            fft: Fft::view(lay.m, &tables[lay.fft..needed])?,
        })
    }

    /// The span `n` (the transform has `n + 1` points).
    pub fn span(&self) -> usize {
        self.span
    }

    fn check<const L: usize>(
        &self,
        data: &[Lanes<L>],
        scratch: &[Lanes<L>],
    ) -> Result<(), TransformError> {
        let needed = self.span + 1;
        if data.len() < needed {
            return Err(TransformError::DataTooShort {
                needed,
                got: data.len(),
            });
        }
        let needed = Self::scratch_len(self.span);
        if scratch.len() < needed {
            return Err(TransformError::ScratchTooShort {
                needed,
                got: scratch.len(),
            });
        }
        Ok(())
    }

    /// In place: `data[0..=span]` holds `z` on entry and `p` on return (longer slices are
    /// left alone past `span`). `scratch` needs [`CosineTransform::scratch_len`] lanes.
    /// Only the lengths are checked; any values (NaN, ∞) go through without a panic.
    #[inline(always)]
    pub fn inverse<const L: usize>(
        &self,
        data: &mut [Lanes<L>],
        scratch: &mut [Lanes<L>],
    ) -> Result<(), TransformError> {
        self.check(data, scratch)?;
        #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
        if L.is_multiple_of(16) {
            self.run::<L, 16, crate::transform::simd::F16>(data, scratch);
            return Ok(());
        }
        #[cfg(all(target_arch = "x86_64", target_feature = "avx"))]
        if L.is_multiple_of(8) {
            self.run::<L, 8, crate::transform::simd::F8>(data, scratch);
            return Ok(());
        }
        if L.is_multiple_of(4) {
            self.run::<L, 4, crate::transform::simd::F4>(data, scratch);
            return Ok(());
        }
        self.run::<L, 1, f32>(data, scratch);
        Ok(())
    }

    /// [`CosineTransform::inverse`] with `L/W` chunks of the vector type `V`. A caller passing
    /// an AVX vector type must run on a CPU that has it, in a function compiled for it
    /// (`crate::decoder`).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn inverse_with<const L: usize, const W: usize, V: Vector<W>>(
        &self,
        data: &mut [Lanes<L>],
        scratch: &mut [Lanes<L>],
    ) -> Result<(), TransformError> {
        self.check(data, scratch)?;
        self.run::<L, W, V>(data, scratch);
        Ok(())
    }

    /// [`CosineTransform::inverse`] through the scalar path (one lane at a time), on every
    /// target: the reference the vector paths must match bit for bit.
    pub fn inverse_scalar<const L: usize>(
        &self,
        data: &mut [Lanes<L>],
        scratch: &mut [Lanes<L>],
    ) -> Result<(), TransformError> {
        self.check(data, scratch)?;
        self.run::<L, 1, f32>(data, scratch);
        Ok(())
    }

    /// The forward model in place: `data[0..=span]` holds `p` on entry and
    /// `z_h = Σ_j p_j·cos(πhj/n)` on return. The inverse's path with the endpoints doubled
    /// before and the `n/c_j` scale after (one extra rounding per output).
    pub fn forward<const L: usize>(
        &self,
        data: &mut [Lanes<L>],
        scratch: &mut [Lanes<L>],
    ) -> Result<(), TransformError> {
        self.check(data, scratch)?;
        let n = self.span;
        for i in [0, n] {
            for v in &mut data[i] {
                *v += *v;
            }
        }
        self.inverse(data, scratch)?;
        let full = n as f32;
        let half = (n / 2) as f32 + if n % 2 == 1 { 0.5 } else { 0.0 };
        for i in [0, n] {
            for v in &mut data[i] {
                *v *= full;
            }
        }
        for v in data[1..n].as_flattened_mut() {
            *v *= half;
        }
        Ok(())
    }

    /// Both routes for `L` lanes as `L/W` chunks of `W`-lane vectors (`data`, `scratch`
    /// checked long enough).
    #[inline(always)]
    fn run<const L: usize, const W: usize, V: Vector<W>>(
        &self,
        data: &mut [Lanes<L>],
        scratch: &mut [Lanes<L>],
    ) {
        let n = self.span;
        let chunks = L / W;
        let scratch = scratch.as_flattened_mut().as_chunks_mut::<W>().0;
        if self.even {
            // All folds first (they read all of `data`), then the FFTs with `data[..n]` as
            // their work buffer, then the unpacks (which write all of `data`).
            let per = n;
            let mut up = [0.0f32; L];
            let mut down = [0.0f32; L];
            for c in 0..chunks {
                let buf = &mut scratch[c * per..][..per];
                let (u, d) = self.fold::<L, W, V>(&data[..=n], c, buf);
                u.store(&mut up.as_chunks_mut::<W>().0[c]);
                d.store(&mut down.as_chunks_mut::<W>().0[c]);
            }
            for c in 0..chunks {
                let buf = &mut scratch[c * per..][..per];
                let work =
                    &mut data[..n].as_flattened_mut().as_chunks_mut::<W>().0[c * per..][..per];
                self.fft.run::<W, V>(buf, work);
            }
            for c in 0..chunks {
                let buf = &scratch[c * per..][..per];
                let u = V::load(&up.as_chunks::<W>().0[c]);
                let d = V::load(&down.as_chunks::<W>().0[c]);
                self.unpack::<L, W, V>(buf, &mut data[..=n], c, u, d);
            }
        } else {
            let per = 4 * n;
            for c in 0..chunks {
                let (buf, work) = scratch[c * per..][..per].split_at_mut(2 * n);
                self.inverse_odd::<L, W, V>(&mut data[..=n], c, buf, work);
            }
        }
    }

    /// Even span, step 1: folds chunk `c` of `data` (`n + 1` lanes) into the FFT input
    /// planes `buf` (`n` vectors); returns the starts of the upward and downward sums.
    #[inline(always)]
    fn fold<const L: usize, const W: usize, V: Vector<W>>(
        &self,
        data: &[Lanes<L>],
        c: usize,
        buf: &mut [[f32; W]],
    ) -> (V, V) {
        let n = self.span;
        let m = n / 2;
        let ld = |e: &Lanes<L>| V::load(&e.as_chunks::<W>().0[c]);
        let (alpha, inv) = (V::splat(self.half_inv), V::splat(self.inv));
        let (zr, zi) = buf.split_at_mut(m);
        let f0 = ld(&data[0]);
        let fe = ld(&data[n]);
        ((f0 + fe) * alpha).store(&mut zr[0]);
        let d = (f0 - fe) * inv;
        let pairs = (m - 1) / 2;
        // Planes: re = [g_0 | g_2j forward | (g_m) | g_(n−2j) backward],
        //         im = [g_(2j−1) forward | (g_(m−1), g_(m+1)) or (g_m) | g_(n−2j+1) backward].
        let (re_fwd, re_rest) = zr[1..].split_at_mut(pairs);
        let (im_fwd, im_rest) = zi.split_at_mut(pairs);
        let (re_bwd, im_bwd) = if m.is_multiple_of(2) {
            (ld(&data[m]) * inv).store(&mut re_rest[0]);
            (&mut re_rest[1..], &mut im_rest[2..])
        } else {
            (ld(&data[m]) * inv).store(&mut im_rest[0]);
            (re_rest, &mut im_rest[1..])
        };
        // Zipped iterators that are all `TrustedRandomAccess` (backward ones as one-item
        // `rchunks`), so the loop keeps a single counter and no per-iterator end checks.
        let lo = data[1..1 + 2 * pairs].chunks_exact(2);
        let hi = data[n - 2 * pairs..n].rchunks_exact(2);
        let w4 = self.fold[..4 * pairs].chunks_exact(4);
        let re = re_fwd[..pairs]
            .iter_mut()
            .zip(re_bwd[..pairs].rchunks_exact_mut(1));
        let im = im_fwd[..pairs]
            .iter_mut()
            .zip(im_bwd[..pairs].rchunks_exact_mut(1));
        let mut s_odd = V::splat(0.0);
        let mut s_even = V::splat(0.0);
        for (((lo, hi), w), ((re_f, re_b), (im_f, im_b))) in lo.zip(hi).zip(w4).zip(re.zip(im)) {
            // j = 2i + 1 (odd): z_j = lo[0], z_(n−j) = hi[1].
            let (h, t, s) = fold_pair(ld(&lo[0]), ld(&hi[1]), alpha, w[0], w[1]);
            (h - t).store(im_f);
            (h + t).store(&mut im_b[0]);
            s_odd = s_odd + s;
            // j = 2i + 2 (even): z_j = lo[1], z_(n−j) = hi[0].
            let (h, t, s) = fold_pair(ld(&lo[1]), ld(&hi[0]), alpha, w[2], w[3]);
            (h - t).store(re_f);
            (h + t).store(&mut re_b[0]);
            s_even = s_even + s;
        }
        let (lo_rem, hi_rem) = (&data[1 + 2 * pairs..m], &data[m + 1..n - 2 * pairs]);
        let w_rem = &self.fold[4 * pairs..];
        if m.is_multiple_of(2) && m > 1 {
            // j = m − 1 (odd), paired with m + 1.
            let (h, t, s) = fold_pair(ld(&lo_rem[0]), ld(&hi_rem[0]), alpha, w_rem[0], w_rem[1]);
            (h - t).store(&mut im_rest[0]);
            (h + t).store(&mut im_rest[1]);
            s_odd = s_odd + s;
        }
        (d + (s_even + s_odd), d + (s_even - s_odd))
    }

    /// Even span, step 3: unpacks the FFT output `z` (`n` vectors) into chunk `c` of `data`,
    /// the odd outputs by the running sums started at `up` and `down`.
    #[inline(always)]
    fn unpack<const L: usize, const W: usize, V: Vector<W>>(
        &self,
        z: &[[f32; W]],
        data: &mut [Lanes<L>],
        c: usize,
        mut up: V,
        mut down: V,
    ) {
        let n = self.span;
        let m = n / 2;
        let st = |v: V, e: &mut Lanes<L>| v.store(&mut e.as_chunks_mut::<W>().0[c]);
        let (zr, zi) = z.split_at(m);
        let (r0, i0) = (V::load(&zr[0]), V::load(&zi[0]));
        st(r0 + i0, &mut data[0]);
        st(r0 - i0, &mut data[n]);
        st(down, &mut data[n - 1]);
        st(up, &mut data[1]);
        if m == 1 {
            return;
        }
        let k_last = (m - 1) / 2;
        let k_loop = if m.is_multiple_of(2) {
            k_last
        } else {
            k_last - 1
        };
        let (low, rest) = data[2..n - 1].split_at_mut(2 * k_loop);
        let mid = if m.is_multiple_of(2) { 1 } else { 3 };
        let (mid_s, high) = rest.split_at_mut(mid);
        let outs = low.chunks_exact_mut(2).zip(high.rchunks_exact_mut(2));
        let tw = self.unpack[..2 * k_loop].chunks_exact(2);
        let a = zr[1..=k_loop].iter().zip(&zi[1..=k_loop]);
        let b = zr[m - k_loop..]
            .rchunks_exact(1)
            .zip(zi[m - k_loop..].rchunks_exact(1));
        for (((lo, hi), w), ((ar, ai), (br, bi))) in outs.zip(tw).zip(a.zip(b)) {
            let (ye, yo, gk, gm) = unpack_pair::<V>(
                V::load(ar),
                V::load(ai),
                V::load(&br[0]),
                V::load(&bi[0]),
                w[0],
                w[1],
            );
            st(ye, &mut lo[0]);
            up = up - gk;
            st(up, &mut lo[1]);
            st(yo, &mut hi[1]);
            down = down - gm;
            st(down, &mut hi[0]);
        }
        if m.is_multiple_of(2) {
            // k = m/2 pairs with itself: Re G = 2·Re Z.
            let r = V::load(&zr[m / 2]);
            st(r + r, &mut mid_s[0]);
        } else {
            // k = (m−1)/2 and m − k = k + 1 are neighbours; both chains meet at p_m.
            let k = k_last;
            let w = &self.unpack[2 * (k - 1)..2 * k];
            let (ye, yo, gk, gm) = unpack_pair::<V>(
                V::load(&zr[k]),
                V::load(&zi[k]),
                V::load(&zr[k + 1]),
                V::load(&zi[k + 1]),
                w[0],
                w[1],
            );
            st(ye, &mut mid_s[0]);
            st(yo, &mut mid_s[2]);
            st(((up - gk) + (down - gm)) * V::splat(0.5), &mut mid_s[1]);
        }
    }

    /// Odd span on chunk `c`; `data` has `n + 1` lanes, `buf` and `work` `2n` vectors each.
    #[inline(always)]
    fn inverse_odd<const L: usize, const W: usize, V: Vector<W>>(
        &self,
        data: &mut [Lanes<L>],
        c: usize,
        buf: &mut [[f32; W]],
        work: &mut [[f32; W]],
    ) {
        let n = self.span;
        let k_max = (n - 1) / 2;
        let g = V::splat(self.half_inv);
        let ld = |e: &Lanes<L>| V::load(&e.as_chunks::<W>().0[c]);
        let (cr, ci) = buf.split_at_mut(n);
        // c_j = (x_2j, x_(2j+1))/(2n): j ≤ (n−1)/2 directly, j = n − i as (z_2i, z_(2i−1)).
        let (cr_lo, cr_hi) = cr.split_at_mut(k_max + 1);
        let (ci_lo, ci_hi) = ci.split_at_mut(k_max + 1);
        for (z, (r, i)) in data
            .chunks_exact(2)
            .zip(cr_lo.iter_mut().zip(ci_lo.iter_mut()))
        {
            (ld(&z[0]) * g).store(r);
            (ld(&z[1]) * g).store(i);
        }
        for (z, (r, i)) in data[1..n]
            .chunks_exact(2)
            .zip(cr_hi.iter_mut().rev().zip(ci_hi.iter_mut().rev()))
        {
            (ld(&z[1]) * g).store(r);
            (ld(&z[0]) * g).store(i);
        }
        self.fft.run::<W, V>(buf, work);
        let st = |v: V, e: &mut Lanes<L>| v.store(&mut e.as_chunks_mut::<W>().0[c]);
        let (zr, zi) = buf.split_at(n);
        let (r0, i0) = (V::load(&zr[0]), V::load(&zi[0]));
        st(r0 + i0, &mut data[0]);
        st(r0 - i0, &mut data[n]);
        let (lo, hi) = data[1..n].split_at_mut(k_max);
        let zs = zr[1..=k_max].iter().zip(&zi[1..=k_max]).zip(
            zr[k_max + 1..]
                .iter()
                .rev()
                .zip(zi[k_max + 1..].iter().rev()),
        );
        for (((lo, hi), w), ((ar, ai), (br, bi))) in lo
            .iter_mut()
            .zip(hi.iter_mut().rev())
            .zip(self.unpack.chunks_exact(2))
            .zip(zs)
        {
            let (ar, ai, br, bi) = (V::load(ar), V::load(ai), V::load(br), V::load(bi));
            let er = ar + br;
            let or = ar - br;
            let oi = ai + bi;
            let tr = oi * V::splat(w[0]) - or * V::splat(w[1]);
            st(er + tr, lo);
            st(er - tr, hi);
        }
    }
}

/// Fold of one pair `(x, y) = (z_j, z_(n−j))`: returns `h = α(x + y)`, `t = u·(x − y)` and
/// the anchor term `v·(x − y)`.
#[inline(always)]
fn fold_pair<V: Arith>(x: V, y: V, alpha: V, u: f32, v: f32) -> (V, V, V) {
    let a = x + y;
    let b = x - y;
    (a * alpha, b * V::splat(u), b * V::splat(v))
}

/// Unpack of the pair `(Z_k, Z_(m−k)) = (a, b)` with twiddle `(cos 2πk/n, sin 2πk/n)`:
/// returns `Re G_k`, `Re G_(m−k)`, `−Im G_k` and `Im G_(m−k)` negated, i.e. the amounts to
/// subtract from the upward and downward running sums.
#[inline(always)]
fn unpack_pair<V: Arith>(ar: V, ai: V, br: V, bi: V, c: f32, s: f32) -> (V, V, V, V) {
    let (c, s) = (V::splat(c), V::splat(s));
    let er = ar + br;
    let ei = ai - bi;
    let or = ar - br;
    let oi = ai + bi;
    let tr = oi * c - or * s;
    let tn = oi * s + or * c;
    (er + tr, er - tr, ei - tn, ei + tn)
}
