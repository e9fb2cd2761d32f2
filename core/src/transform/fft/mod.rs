//! Lane-parallel mixed-radix complex FFT of any length `len ≥ 1`.
//!
//! Forward transform `X_k = Σ_j x_j · e^(−2πi·jk/len)`, unscaled, computed for `W` pixels at
//! once by explicit vectors (`simd.rs`), one IEEE operation per lane and step.
//!
//! # Layout
//! A complex signal of length `len` lives in one slice of `2·len` vectors of `W` lanes: the
//! real parts in `[0, len)`, the imaginary parts in `[len, 2·len)`. [`Fft::forward`] takes
//! [`Lanes`] elements directly (`W = L`, portable arrays); the cosine transform runs each
//! `W`-lane chunk of its pixels on its own contiguous planes (the vector is the element).
//!
//! # Algorithm
//! Stockham autosort, decimation in frequency: stage `i` of radix `R` reads sub-sequences of
//! length `n_s` with stride `s` and writes `y[k + s(Rp + t)] = w^(pt) · DFT_R(x[k + s(p + q·r)])_t`
//! (`q = n_s/R`, `w = e^(−2πi/n_s)`), ping-ponging between the caller's buffer and a work
//! buffer, so the output comes out in natural order with no bit reversal. The last stage
//! (`q = 1`) has no twiddles and reads and writes the same places, so it can run in place:
//! that is how an odd number of stages still ends in the caller's buffer.
//!
//! Radices: 8 (and one or two 4s, or a 2) for the power of two, 6 (= 2·3 by Good–Thomas,
//! no inner twiddles) when it saves a stage (384 = 6·8·8), 3 and 5, and any other prime as
//! a direct O(p²) DFT (`generic.rs`). Few, large stages: every stage is one pass of loads
//! and stores, and every stage but the last multiplies by twiddles.
//!
//! # Kernels
//! Each butterfly loads its `R` inputs, transforms, twiddles and stores in registers. A
//! stage's inputs and outputs are `2R` strided runs; with runtime strides each run needs a
//! pointer register, more than x86-64 has for radix 8. So the stages of the plans of 32 to
//! 1024 points (spans 64 to 2048, see `shaped!`) are compiled for their constant `s` and
//! `q`: all runs are constant offsets from two pointers and the bounds checks fold away.
//! Other shapes take the general kernel (one sub-slice per run, checked once per row).
//! The plan and the operations are the same for every vector width, so every path gives
//! the same bits.
//!
//! # Tables
//! For each stage in order: the twiddles of rows `p = 1..q` (row 0 is all ones and is
//! skipped), each row `R−1` complex values `w^(pt)`, `t = 1..R`, as `(re, im)` f32 pairs;
//! a generic prime stage appends its `R` roots `(cos 2πu/R, sin 2πu/R)`, `u = 0..R`.
//! Every value is computed in f64 from an exact rational multiple of π ([`cis`]) and
//! rounded once to f32, so every machine builds the same bits.

use crate::transform::cosine::TransformError;
use crate::transform::simd::{Arith, Array, Vector};
use crate::transform::Lanes;

mod generic;
mod radix2;
mod radix3;
mod radix4;
mod radix5;
mod radix6;
mod radix8;

/// Longest supported FFT (keeps every index product far from overflow).
pub const MAX_LEN: usize = 1 << 20;

/// Upper bound on the number of stages (20 radix-2 stages for 2^20).
const MAX_STAGES: usize = 24;

/// The factorisation of a length into stage radices, in execution order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Plan {
    radices: [u32; MAX_STAGES],
    count: usize,
}

impl Plan {
    /// Deterministic factorisation of `len` (which must be in `1..=MAX_LEN`).
    ///
    /// Order: other primes, then 5s, then 3s, then the power of two `2^t` as radix-8
    /// stages followed by one radix 4 (`t ≡ 2 mod 3`) or two (`t ≡ 1`, `t ≥ 4`); when
    /// `t ≡ 1 mod 3` and there is a 3, the lone 2 joins it as a radix 6 instead (placed
    /// after the 3s); radix 2 only for `len = 2·odd`. Ending on a fixed radix lets the
    /// in-place last stage absorb an odd stage count.
    pub fn new(len: usize) -> Plan {
        let mut plan = Plan {
            radices: [0; MAX_STAGES],
            count: 0,
        };
        let mut rest = len;
        let mut twos = 0;
        while rest.is_multiple_of(2) && rest > 1 {
            rest /= 2;
            twos += 1;
        }
        let mut threes = 0;
        while rest.is_multiple_of(3) {
            rest /= 3;
            threes += 1;
        }
        let mut fives = 0;
        while rest.is_multiple_of(5) {
            rest /= 5;
            fives += 1;
        }
        let mut p = 7;
        while rest > 1 {
            if p * p > rest {
                plan.push(rest as u32);
                break;
            }
            while rest.is_multiple_of(p) {
                plan.push(p as u32);
                rest /= p;
            }
            p += 2;
        }
        for _ in 0..fives {
            plan.push(5);
        }
        // 2^twos as radix-8 stages, with the remainder of 3 as one 4 or two 4s; a lone
        // leftover 2 joins a 3 as radix 6 (384 = 6·8·8 instead of 3·8·4·4).
        let six = twos % 3 == 1 && threes > 0;
        if six {
            twos -= 1;
            threes -= 1;
        }
        for _ in 0..threes {
            plan.push(3);
        }
        if six {
            plan.push(6);
        }
        let (eights, fours, two) = match twos % 3 {
            0 => (twos / 3, 0, false),
            2 => (twos / 3, 1, false),
            _ if twos == 1 => (0, 0, true),
            _ => (twos / 3 - 1, 2, false),
        };
        for _ in 0..eights {
            plan.push(8);
        }
        for _ in 0..fours {
            plan.push(4);
        }
        if two {
            plan.push(2);
        }
        plan
    }

    fn push(&mut self, r: u32) {
        self.radices[self.count] = r;
        self.count += 1;
    }

    /// The radices in execution order.
    pub fn radices(&self) -> &[u32] {
        &self.radices[..self.count]
    }
}

/// f32s of table storage of one stage of radix `r` with `q` rows.
fn stage_tables_len(r: usize, q: usize) -> usize {
    let twiddles = 2 * (r - 1) * (q - 1);
    if is_fixed(r) {
        twiddles
    } else {
        twiddles + 2 * r
    }
}

/// Radices with a dedicated butterfly (and an in-place last stage).
fn is_fixed(r: usize) -> bool {
    matches!(r, 2 | 3 | 4 | 5 | 6 | 8)
}

/// `(cos θ, sin θ)` of `θ = 2π·num/den`, in f64.
///
/// The angle is reduced exactly in integers to `[0, π/4]` before `libm::cos/sin`, so
/// multiples of π/2 give exact 0 and ±1 and symmetric angles give symmetric values.
pub fn cis(num: u64, den: u64) -> (f64, f64) {
    let k = num % den;
    let quadrant = (4 * k) / den;
    let r = (4 * k) % den; // angle within the quadrant is (π/2)·r/den
    let (c, s) = if 2 * r == den {
        let h = core::f64::consts::FRAC_1_SQRT_2;
        (h, h)
    } else if 2 * r < den {
        let x = core::f64::consts::FRAC_PI_2 * (r as f64) / (den as f64);
        (libm::cos(x), libm::sin(x))
    } else {
        let x = core::f64::consts::FRAC_PI_2 * ((den - r) as f64) / (den as f64);
        (libm::sin(x), libm::cos(x))
    };
    // `+ 0.0` turns a −0.0 into +0.0.
    match quadrant {
        0 => (c + 0.0, s + 0.0),
        1 => (-s + 0.0, c + 0.0),
        2 => (-c + 0.0, -s + 0.0),
        _ => (s + 0.0, -c + 0.0),
    }
}

/// A planned FFT of one length, borrowing tables built by [`Fft::build`].
#[derive(Clone, Copy, Debug)]
pub struct Fft<'t> {
    len: usize,
    plan: Plan,
    tables: &'t [f32],
}

impl<'t> Fft<'t> {
    /// f32s of table storage for an FFT of `len` (0 when out of range).
    pub fn tables_len(len: usize) -> usize {
        if len == 0 || len > MAX_LEN {
            return 0;
        }
        let plan = Plan::new(len);
        let mut ns = len;
        let mut total = 0;
        for &r in plan.radices() {
            let r = r as usize;
            total += stage_tables_len(r, ns / r);
            ns /= r;
        }
        total
    }

    /// Fills `tables[..tables_len(len)]` with the twiddles of `len`.
    pub fn build(len: usize, tables: &mut [f32]) -> Result<(), TransformError> {
        check_len(len)?;
        let needed = Self::tables_len(len);
        if tables.len() < needed {
            return Err(TransformError::TablesTooShort {
                needed,
                got: tables.len(),
            });
        }
        let plan = Plan::new(len);
        let mut ns = len;
        let mut out = tables[..needed].iter_mut();
        let mut put = |v: f64| {
            if let Some(slot) = out.next() {
                *slot = v as f32;
            }
        };
        for &r in plan.radices() {
            let r = r as usize;
            let q = ns / r;
            for p in 1..q {
                for t in 1..r {
                    let (c, s) = cis((p * t) as u64, ns as u64);
                    put(c);
                    put(-s + 0.0);
                }
            }
            if !is_fixed(r) {
                for u in 0..r {
                    let (c, s) = cis(u as u64, r as u64);
                    put(c);
                    put(s);
                }
            }
            ns = q;
        }
        Ok(())
    }

    /// Borrows tables built by [`Fft::build`] for `len` (checks only their length).
    pub fn view(len: usize, tables: &'t [f32]) -> Result<Self, TransformError> {
        check_len(len)?;
        let needed = Self::tables_len(len);
        if tables.len() < needed {
            return Err(TransformError::TablesTooShort {
                needed,
                got: tables.len(),
            });
        }
        Ok(Fft {
            len,
            plan: Plan::new(len),
            tables: &tables[..needed],
        })
    }

    /// The transform length.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Always false: a planned FFT has at least one point.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// The stage radices, in execution order.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// In-place forward FFT of `buf[..2·len]` (split planes), using `work[..2·len]` as the
    /// ping-pong buffer (its contents on return are unspecified).
    pub fn forward<const L: usize>(
        &self,
        buf: &mut [Lanes<L>],
        work: &mut [Lanes<L>],
    ) -> Result<(), TransformError> {
        let needed = 2 * self.len;
        if buf.len() < needed {
            return Err(TransformError::DataTooShort {
                needed,
                got: buf.len(),
            });
        }
        if work.len() < needed {
            return Err(TransformError::ScratchTooShort {
                needed,
                got: work.len(),
            });
        }
        self.run::<L, Array<L>>(&mut buf[..needed], &mut work[..needed]);
        Ok(())
    }

    /// [`Fft::forward`] on planes of `W`-lane vectors, slices of exactly `2·len`.
    #[inline(always)]
    pub(crate) fn run<const W: usize, V: Vector<W>>(
        &self,
        buf: &mut [[f32; W]],
        work: &mut [[f32; W]],
    ) {
        let n = self.len;
        let radices = self.plan.radices();
        let stages = radices.len();
        if stages == 0 || buf.len() != 2 * n || work.len() != 2 * n {
            return;
        }
        let odd = stages % 2 == 1;
        let last_fixed = is_fixed(radices[stages - 1] as usize);
        let (mut src, mut dst) = (buf, work);
        if odd && !last_fixed {
            dst.copy_from_slice(src);
            core::mem::swap(&mut src, &mut dst);
        }
        let mut s = 1;
        let mut ns = n;
        let mut offset = 0;
        for (i, &r) in radices.iter().enumerate() {
            let r = r as usize;
            let q = ns / r;
            let len = stage_tables_len(r, q);
            let tw = &self.tables[offset..offset + len];
            if i + 1 == stages && odd && last_fixed {
                last_in_place::<W, V>(src, n, s, r);
            } else {
                stage::<W, V>(src, dst, n, s, q, r, tw);
                core::mem::swap(&mut src, &mut dst);
            }
            offset += len;
            s *= r;
            ns = q;
        }
    }
}

fn check_len(len: usize) -> Result<(), TransformError> {
    if len == 0 || len > MAX_LEN {
        Err(TransformError::LengthOutOfRange { len, max: MAX_LEN })
    } else {
        Ok(())
    }
}

/// Stage shapes `(radix, s, q)` with a kernel compiled for constant `s` and `q` (all offsets
/// immediates, two pointers): the out-of-place stages of the plans of 32, 64, 128, 256, 384,
/// 512 and 1024 points (spans 64 to 2048; the in-place last stages are in
/// [`last_in_place`]). Other shapes take the general kernel.
macro_rules! shaped {
    ($r:expr, $s:expr, $q:expr, $x:expr, $y:expr, $tw:expr, $other:block,
     $(($R:literal, $B:ty, $S:literal, $Q:literal)),* $(,)?) => {
        match ($r, $s, $q) {
            $(($R, $S, $Q) => pass_shaped::<W, V, $R, $B, $S, $Q>($x, $y, $tw),)*
            _ => $other,
        }
    };
}

/// One out-of-place stage, dispatched on the radix (and the shape).
#[inline(always)]
fn stage<const W: usize, V: Vector<W>>(
    x: &[[f32; W]],
    y: &mut [[f32; W]],
    n: usize,
    s: usize,
    q: usize,
    r: usize,
    tw: &[f32],
) {
    shaped!(
        r,
        s,
        q,
        x,
        y,
        tw,
        {
            match r {
                2 => pass_fixed::<W, V, 2, radix2::Radix>(x, y, n, s, q, tw),
                3 => pass_fixed::<W, V, 3, radix3::Radix>(x, y, n, s, q, tw),
                4 => pass_fixed::<W, V, 4, radix4::Radix>(x, y, n, s, q, tw),
                5 => pass_fixed::<W, V, 5, radix5::Radix>(x, y, n, s, q, tw),
                6 => pass_fixed::<W, V, 6, radix6::Radix>(x, y, n, s, q, tw),
                8 => pass_fixed::<W, V, 8, radix8::Radix>(x, y, n, s, q, tw),
                _ => generic::pass::<W, V>(x, y, n, s, q, r, tw),
            }
        },
        (8, radix8::Radix, 1, 4),
        (4, radix4::Radix, 8, 1),
        (8, radix8::Radix, 1, 8),
        (8, radix8::Radix, 8, 1),
        (8, radix8::Radix, 1, 16),
        (4, radix4::Radix, 8, 4),
        (8, radix8::Radix, 1, 32),
        (8, radix8::Radix, 8, 4),
        (6, radix6::Radix, 1, 64),
        (8, radix8::Radix, 6, 8),
        (8, radix8::Radix, 1, 64),
        (8, radix8::Radix, 8, 8),
        (8, radix8::Radix, 1, 128),
        (8, radix8::Radix, 8, 16),
        (4, radix4::Radix, 64, 4),
        (4, radix4::Radix, 256, 1),
    )
}

/// The last stage (`q = 1`, no twiddles) in place, for a fixed radix.
#[inline(always)]
fn last_in_place<const W: usize, V: Vector<W>>(y: &mut [[f32; W]], n: usize, s: usize, r: usize) {
    match (r, s) {
        (8, 48) => last_shaped::<W, V, 8, radix8::Radix, 48>(y),
        (8, 64) => last_shaped::<W, V, 8, radix8::Radix, 64>(y),
        (4, 32) => last_shaped::<W, V, 4, radix4::Radix, 32>(y),
        (4, 64) => last_shaped::<W, V, 4, radix4::Radix, 64>(y),
        (2, _) => last_fixed::<W, V, 2, radix2::Radix>(y, n, s),
        (3, _) => last_fixed::<W, V, 3, radix3::Radix>(y, n, s),
        (4, _) => last_fixed::<W, V, 4, radix4::Radix>(y, n, s),
        (5, _) => last_fixed::<W, V, 5, radix5::Radix>(y, n, s),
        (6, _) => last_fixed::<W, V, 6, radix6::Radix>(y, n, s),
        _ => last_fixed::<W, V, 8, radix8::Radix>(y, n, s),
    }
}

/// Out-of-place stage of radix `R` written with plain indices: called with constant `s` and
/// `q`, every index is a constant offset from two pointers and every bounds check folds away.
#[inline(always)]
fn pass_shaped<
    const W: usize,
    V: Vector<W>,
    const R: usize,
    B: Butterfly<R>,
    const S: usize,
    const Q: usize,
>(
    x: &[[f32; W]],
    y: &mut [[f32; W]],
    tw: &[f32],
) {
    let (s, q) = (S, Q);
    let n = R * s * q;
    let blk = q * s;
    let rl = 2 * (R - 1);
    let (x, y, tw) = (&x[..2 * n], &mut y[..2 * n], &tw[..rl * (q - 1)]);
    let one = [Cx::<V>::splat(1.0, 0.0); R];
    shaped_row::<W, V, R, B, false>(x, y, s, blk, 0, &one);
    for p in 1..q {
        let w = row_twiddles::<V, R>(&tw[rl * (p - 1)..][..rl]);
        shaped_row::<W, V, R, B, true>(x, y, s, blk, p, &w);
    }
}

/// Row `p` of [`pass_shaped`]: `s` butterflies, twiddled by `w` if `TW`.
#[inline(always)]
fn shaped_row<const W: usize, V: Vector<W>, const R: usize, B: Butterfly<R>, const TW: bool>(
    x: &[[f32; W]],
    y: &mut [[f32; W]],
    s: usize,
    blk: usize,
    p: usize,
    w: &[Cx<V>; R],
) {
    let n = R * blk;
    for k in 0..s {
        let i = p * s + k;
        let mut a = [Cx::<V>::splat(0.0, 0.0); R];
        for r in 0..R {
            a[r] = load(&x[r * blk + i], &x[n + r * blk + i]);
        }
        B::run(&mut a);
        let o = p * R * s + k;
        for t in 0..R {
            let v = if TW && t > 0 { a[t].mul(w[t]) } else { a[t] };
            v.re.store(&mut y[o + t * s]);
            v.im.store(&mut y[n + o + t * s]);
        }
    }
}

/// The in-place last stage (`q = 1`) of radix `R` for a constant `s`.
#[inline(always)]
fn last_shaped<const W: usize, V: Vector<W>, const R: usize, B: Butterfly<R>, const S: usize>(
    y: &mut [[f32; W]],
) {
    let s = S;
    let n = R * s;
    let y = &mut y[..2 * n];
    for k in 0..s {
        let mut a = [Cx::<V>::splat(0.0, 0.0); R];
        for r in 0..R {
            a[r] = load(&y[r * s + k], &y[n + r * s + k]);
        }
        B::run(&mut a);
        for t in 0..R {
            a[t].re.store(&mut y[t * s + k]);
            a[t].im.store(&mut y[n + t * s + k]);
        }
    }
}

/// One complex value per lane.
#[derive(Clone, Copy)]
pub(crate) struct Cx<V> {
    pub(crate) re: V,
    pub(crate) im: V,
}

impl<V: Arith> Cx<V> {
    /// `a + b`.
    #[inline(always)]
    pub(crate) fn add(self, b: Self) -> Self {
        Cx {
            re: self.re + b.re,
            im: self.im + b.im,
        }
    }

    /// `a − b`.
    #[inline(always)]
    pub(crate) fn sub(self, b: Self) -> Self {
        Cx {
            re: self.re - b.re,
            im: self.im - b.im,
        }
    }

    /// `a − i·b`.
    #[inline(always)]
    pub(crate) fn sub_i(self, b: Self) -> Self {
        Cx {
            re: self.re + b.im,
            im: self.im - b.re,
        }
    }

    /// `a + i·b`.
    #[inline(always)]
    pub(crate) fn add_i(self, b: Self) -> Self {
        Cx {
            re: self.re - b.im,
            im: self.im + b.re,
        }
    }

    /// `a·w` for a real `w`.
    #[inline(always)]
    pub(crate) fn scale(self, w: V) -> Self {
        Cx {
            re: self.re * w,
            im: self.im * w,
        }
    }

    /// `a·w`: four products, a difference and a sum (never fused).
    #[inline(always)]
    pub(crate) fn mul(self, w: Self) -> Self {
        Cx {
            re: self.re * w.re - self.im * w.im,
            im: self.re * w.im + self.im * w.re,
        }
    }

    /// A twiddle from its table entry `(re, im)`.
    #[inline(always)]
    pub(crate) fn splat(re: f32, im: f32) -> Self {
        Cx {
            re: V::splat(re),
            im: V::splat(im),
        }
    }
}

/// Loads element `k` of the split planes `re`, `im`.
#[inline(always)]
fn load<const W: usize, V: Vector<W>>(re: &[f32; W], im: &[f32; W]) -> Cx<V> {
    Cx {
        re: V::load(re),
        im: V::load(im),
    }
}

/// Stores `a` to element `k` of the split planes.
#[inline(always)]
fn store<const W: usize, V: Vector<W>>(a: Cx<V>, re: &mut [f32; W], im: &mut [f32; W]) {
    a.re.store(re);
    a.im.store(im);
}

/// A fixed-radix DFT kernel, in place on `R` values. A trait (not a closure) so that
/// `#[inline(always)]` reaches into every pass.
pub(crate) trait Butterfly<const R: usize> {
    /// `a ← DFT_R(a)` with `ω = e^(−2πi/R)`.
    fn run<V: Arith>(a: &mut [Cx<V>; R]);
}

/// The `R` runs `x[r·stride..][..len]`.
#[inline(always)]
fn runs<T, const R: usize>(x: &[T], stride: usize, len: usize) -> [&[T]; R] {
    let mut out: [&[T]; R] = [&[]; R];
    for (r, o) in out.iter_mut().enumerate() {
        *o = &x[r * stride..][..len];
    }
    out
}

/// Splits `rest` into `R` consecutive mutable pieces of `len`.
#[inline(always)]
fn split_mut<T, const R: usize>(mut rest: &mut [T], len: usize) -> [&mut [T]; R] {
    core::array::from_fn(|_| {
        let (head, tail) = core::mem::take(&mut rest).split_at_mut(len);
        rest = tail;
        head
    })
}

/// The twiddles of one row, `w^(pt)` for `t = 1..R` (`a[0]` is unused).
#[inline(always)]
fn row_twiddles<V: Arith, const R: usize>(row: &[f32]) -> [Cx<V>; R] {
    let mut w = [Cx::splat(1.0, 0.0); R];
    for t in 1..R {
        w[t] = Cx::splat(row[2 * (t - 1)], row[2 * (t - 1) + 1]);
    }
    w
}

/// Loads element `k` of the `R` runs `re[r]`, `im[r]`.
#[inline(always)]
fn load_runs<const W: usize, V: Vector<W>, const R: usize>(
    re: &[&[[f32; W]]; R],
    im: &[&[[f32; W]]; R],
    k: usize,
) -> [Cx<V>; R] {
    let mut a = [Cx::splat(0.0, 0.0); R];
    for r in 0..R {
        a[r] = load(&re[r][k], &im[r][k]);
    }
    a
}

/// Out-of-place stage of a fixed radix `R`: row `p` reads the runs of `s` elements at
/// `(r·q + p)·s` and writes `(p·R + t)·s`. Planes: `x[..n]` real parts, `x[n..]` imaginary.
#[inline(always)]
fn pass_fixed<const W: usize, V: Vector<W>, const R: usize, B: Butterfly<R>>(
    x: &[[f32; W]],
    y: &mut [[f32; W]],
    n: usize,
    s: usize,
    q: usize,
    tw: &[f32],
) {
    let (xr, xi) = x.split_at(n);
    let (yr, yi) = y.split_at_mut(n);
    let blk = q * s;
    let row_len = 2 * (R - 1);
    if s == 1 {
        // First stage: one butterfly per row, inputs strided by q, outputs contiguous.
        let xr: [&[[f32; W]]; R] = runs(xr, q, q);
        let xi: [&[[f32; W]]; R] = runs(xi, q, q);
        let (yr, _) = yr[..R * q].as_chunks_mut::<R>();
        let (yi, _) = yi[..R * q].as_chunks_mut::<R>();
        let rows = tw.chunks_exact(row_len);
        let outs = yr.iter_mut().zip(yi.iter_mut()).enumerate().skip(1);
        for ((p, (yr, yi)), row) in outs.zip(rows) {
            let mut a = load_runs::<W, V, R>(&xr, &xi, p);
            B::run(&mut a);
            let w = row_twiddles::<V, R>(row);
            for t in 0..R {
                let v = if t == 0 { a[t] } else { a[t].mul(w[t]) };
                store(v, &mut yr[t], &mut yi[t]);
            }
        }
        if let (Some(yr), Some(yi)) = (yr.first_mut(), yi.first_mut()) {
            let mut a = load_runs::<W, V, R>(&xr, &xi, 0);
            B::run(&mut a);
            for t in 0..R {
                store(a[t], &mut yr[t], &mut yi[t]);
            }
        }
        return;
    }
    let tw = &tw[..row_len * (q - 1)];
    let mut yr_rest = &mut yr[..R * blk];
    let mut yi_rest = &mut yi[..R * blk];
    for p in 0..q {
        let (yr_p, t) = core::mem::take(&mut yr_rest).split_at_mut(R * s);
        yr_rest = t;
        let (yi_p, t) = core::mem::take(&mut yi_rest).split_at_mut(R * s);
        yi_rest = t;
        let yr_t: [&mut [[f32; W]]; R] = split_mut(yr_p, s);
        let yi_t: [&mut [[f32; W]]; R] = split_mut(yi_p, s);
        let at = p * s;
        let xr_p: [&[[f32; W]]; R] = runs(&xr[at..], blk, s);
        let xi_p: [&[[f32; W]]; R] = runs(&xi[at..], blk, s);
        if p == 0 {
            for k in 0..s {
                let mut a = load_runs::<W, V, R>(&xr_p, &xi_p, k);
                B::run(&mut a);
                for t in 0..R {
                    a[t].re.store(&mut yr_t[t][k]);
                    a[t].im.store(&mut yi_t[t][k]);
                }
            }
        } else {
            let w = row_twiddles::<V, R>(&tw[row_len * (p - 1)..][..row_len]);
            for k in 0..s {
                let mut a = load_runs::<W, V, R>(&xr_p, &xi_p, k);
                B::run(&mut a);
                for t in 0..R {
                    let v = if t == 0 { a[t] } else { a[t].mul(w[t]) };
                    v.re.store(&mut yr_t[t][k]);
                    v.im.store(&mut yi_t[t][k]);
                }
            }
        }
    }
}

/// The in-place last stage (`q = 1`) of a fixed radix `R`.
#[inline(always)]
fn last_fixed<const W: usize, V: Vector<W>, const R: usize, B: Butterfly<R>>(
    y: &mut [[f32; W]],
    n: usize,
    s: usize,
) {
    let (yr, yi) = y.split_at_mut(n);
    let yr_t: [&mut [[f32; W]]; R] = split_mut(&mut yr[..R * s], s);
    let yi_t: [&mut [[f32; W]]; R] = split_mut(&mut yi[..R * s], s);
    for k in 0..s {
        let mut a = [Cx::<V>::splat(0.0, 0.0); R];
        for r in 0..R {
            a[r] = load(&yr_t[r][k], &yi_t[r][k]);
        }
        B::run(&mut a);
        for t in 0..R {
            a[t].re.store(&mut yr_t[t][k]);
            a[t].im.store(&mut yi_t[t][k]);
        }
    }
}
