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

use core::fmt;

use crate::transform::fft::{cis, Fft};
use crate::transform::lanes::{add, mul_add2, mul_sub, scale, sub};
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
    pub fn inverse<const L: usize>(
        &self,
        data: &mut [Lanes<L>],
        scratch: &mut [Lanes<L>],
    ) -> Result<(), TransformError> {
        self.check(data, scratch)?;
        let n = self.span;
        if self.even {
            self.inverse_even(&mut data[..=n], &mut scratch[..n]);
        } else {
            self.inverse_odd(&mut data[..=n], &mut scratch[..4 * n]);
        }
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
        data[0] = add(data[0], data[0]);
        data[n] = add(data[n], data[n]);
        self.inverse(data, scratch)?;
        let full = n as f32;
        let half = (n / 2) as f32 + if n % 2 == 1 { 0.5 } else { 0.0 };
        data[0] = scale(data[0], full);
        data[n] = scale(data[n], full);
        for v in &mut data[1..n] {
            *v = scale(*v, half);
        }
        Ok(())
    }

    /// Even span; `data` has `n + 1` lanes, `scratch` `n`.
    #[inline(never)]
    fn inverse_even<const L: usize>(&self, data: &mut [Lanes<L>], scratch: &mut [Lanes<L>]) {
        let n = self.span;
        let m = n / 2;
        let (alpha, inv) = (self.half_inv, self.inv);

        // 1. Fold into the FFT input planes (scratch), summing the odd-output anchors.
        let (zr, zi) = scratch.split_at_mut(m);
        let f0 = data[0];
        let fe = data[n];
        zr[0] = scale(add(f0, fe), alpha);
        let d = scale(sub(f0, fe), inv);
        let pairs = (m - 1) / 2;
        // Planes: re = [g_0 | g_2j forward | (g_m) | g_(n−2j) backward],
        //         im = [g_(2j−1) forward | (g_(m−1), g_(m+1)) or (g_m) | g_(n−2j+1) backward].
        let (re_fwd, re_rest) = zr[1..].split_at_mut(pairs);
        let (im_fwd, im_rest) = zi.split_at_mut(pairs);
        let (re_bwd, im_bwd) = if m.is_multiple_of(2) {
            re_rest[0] = scale(data[m], inv);
            (&mut re_rest[1..], &mut im_rest[2..])
        } else {
            im_rest[0] = scale(data[m], inv);
            (re_rest, &mut im_rest[1..])
        };
        let lo = &data[1..m];
        let hi = &data[m + 1..n];
        let lo2 = lo.chunks_exact(2);
        let hi2 = hi.rchunks_exact(2);
        let (lo_rem, hi_rem) = (lo2.remainder(), hi2.remainder());
        let w4 = self.fold.chunks_exact(4);
        let w_rem = w4.remainder();
        let mut s_odd = [0.0; L];
        let mut s_even = [0.0; L];
        let outs = re_fwd
            .iter_mut()
            .zip(re_bwd.iter_mut().rev())
            .zip(im_fwd.iter_mut().zip(im_bwd.iter_mut().rev()));
        for (((lo, hi), w), ((re_f, re_b), (im_f, im_b))) in lo2.zip(hi2).zip(w4).zip(outs) {
            barrier();
            // j = 2i − 1 (odd): z_j = lo[0], z_(n−j) = hi[1].
            let (h, t, s) = fold_pair(lo[0], hi[1], alpha, w[0], w[1]);
            *im_f = sub(h, t);
            *im_b = add(h, t);
            s_odd = add(s_odd, s);
            barrier();
            // j = 2i (even): z_j = lo[1], z_(n−j) = hi[0].
            let (h, t, s) = fold_pair(lo[1], hi[0], alpha, w[2], w[3]);
            *re_f = sub(h, t);
            *re_b = add(h, t);
            s_even = add(s_even, s);
        }
        if m.is_multiple_of(2) && m > 1 {
            // j = m − 1 (odd), paired with m + 1.
            let (h, t, s) = fold_pair(lo_rem[0], hi_rem[0], alpha, w_rem[0], w_rem[1]);
            im_rest[0] = sub(h, t);
            im_rest[1] = add(h, t);
            s_odd = add(s_odd, s);
        }
        let mut up = add(d, add(s_even, s_odd));
        let mut down = add(d, sub(s_even, s_odd));

        // 2. FFT of m points; data[..n] is free and serves as the ping-pong buffer.
        self.fft.run(scratch, &mut data[..n]);

        // 3. Unpack with the running sums from both ends.
        let (zr, zi) = scratch.split_at(m);
        data[0] = add(zr[0], zi[0]);
        data[n] = sub(zr[0], zi[0]);
        data[n - 1] = down;
        data[1] = up;
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
        let tw = self.unpack.chunks_exact(2);
        let zs = zr[1..=k_loop].iter().zip(&zi[1..=k_loop]).zip(
            zr[m - k_loop..]
                .iter()
                .rev()
                .zip(zi[m - k_loop..].iter().rev()),
        );
        for (((lo, hi), w), ((ar, ai), (br, bi))) in low
            .chunks_exact_mut(2)
            .zip(high.rchunks_exact_mut(2))
            .zip(tw)
            .zip(zs)
        {
            barrier();
            let (ye, yo, gk, gm) = unpack_pair(*ar, *ai, *br, *bi, w[0], w[1]);
            lo[0] = ye;
            up = sub(up, gk);
            lo[1] = up;
            hi[1] = yo;
            down = sub(down, gm);
            hi[0] = down;
        }
        if m.is_multiple_of(2) {
            // k = m/2 pairs with itself: Re G = 2·Re Z.
            mid_s[0] = add(zr[m / 2], zr[m / 2]);
        } else {
            // k = (m−1)/2 and m − k = k + 1 are neighbours; both chains meet at p_m.
            let k = k_last;
            let w = &self.unpack[2 * (k - 1)..2 * k];
            let (ye, yo, gk, gm) = unpack_pair(zr[k], zi[k], zr[k + 1], zi[k + 1], w[0], w[1]);
            mid_s[0] = ye;
            mid_s[2] = yo;
            mid_s[1] = scale(add(sub(up, gk), sub(down, gm)), 0.5);
        }
    }

    /// Odd span; `data` has `n + 1` lanes, `scratch` `4n`.
    #[inline(never)]
    fn inverse_odd<const L: usize>(&self, data: &mut [Lanes<L>], scratch: &mut [Lanes<L>]) {
        let n = self.span;
        let k_max = (n - 1) / 2;
        let g = self.half_inv;
        let (buf, work) = scratch.split_at_mut(2 * n);
        let (cr, ci) = buf.split_at_mut(n);
        // c_j = (x_2j, x_(2j+1))/(2n): j ≤ (n−1)/2 directly, j = n − i as (z_2i, z_(2i−1)).
        let (cr_lo, cr_hi) = cr.split_at_mut(k_max + 1);
        let (ci_lo, ci_hi) = ci.split_at_mut(k_max + 1);
        for (z, (r, i)) in data
            .chunks_exact(2)
            .zip(cr_lo.iter_mut().zip(ci_lo.iter_mut()))
        {
            *r = scale(z[0], g);
            *i = scale(z[1], g);
        }
        for (z, (r, i)) in data[1..n]
            .chunks_exact(2)
            .zip(cr_hi.iter_mut().rev().zip(ci_hi.iter_mut().rev()))
        {
            *r = scale(z[1], g);
            *i = scale(z[0], g);
        }
        self.fft.run(buf, work);
        let (zr, zi) = buf.split_at(n);
        data[0] = add(zr[0], zi[0]);
        data[n] = sub(zr[0], zi[0]);
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
            barrier();
            let er = add(*ar, *br);
            let or = sub(*ar, *br);
            let oi = add(*ai, *bi);
            let tr = mul_sub(oi, w[0], or, w[1]);
            *lo = add(er, tr);
            *hi = sub(er, tr);
        }
    }
}

/// An empty optimisation barrier at the top of each element loop: LLVM's loop vectoriser
/// would otherwise vectorise across elements (strided gathers) instead of across lanes;
/// with it, each iteration's lane arithmetic is packed by the SLP vectoriser. No instructions.
#[inline(always)]
pub(crate) fn barrier() {
    core::hint::black_box(0u32);
}

/// Fold of one pair `(x, y) = (z_j, z_(n−j))`: returns `h = α(x + y)`, `t = u·(x − y)` and
/// the anchor term `v·(x − y)`.
#[inline(always)]
fn fold_pair<const L: usize>(
    x: Lanes<L>,
    y: Lanes<L>,
    alpha: f32,
    u: f32,
    v: f32,
) -> (Lanes<L>, Lanes<L>, Lanes<L>) {
    let a = add(x, y);
    let b = sub(x, y);
    (scale(a, alpha), scale(b, u), scale(b, v))
}

/// Unpack of the pair `(Z_k, Z_(m−k)) = (a, b)` with twiddle `(cos 2πk/n, sin 2πk/n)`:
/// returns `Re G_k`, `Re G_(m−k)`, `−Im G_k` and `Im G_(m−k)` negated, i.e. the amounts to
/// subtract from the upward and downward running sums.
#[inline(always)]
fn unpack_pair<const L: usize>(
    ar: Lanes<L>,
    ai: Lanes<L>,
    br: Lanes<L>,
    bi: Lanes<L>,
    c: f32,
    s: f32,
) -> (Lanes<L>, Lanes<L>, Lanes<L>, Lanes<L>) {
    let er = add(ar, br);
    let ei = sub(ai, bi);
    let or = sub(ar, br);
    let oi = add(ai, bi);
    let tr = mul_sub(oi, c, or, s);
    let tn = mul_add2(oi, s, or, c);
    (add(er, tr), sub(er, tr), sub(ei, tn), add(ei, tn))
}
