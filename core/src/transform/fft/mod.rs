//! Lane-parallel mixed-radix complex FFT of any length `len ≥ 1`.
//!
//! Forward transform `X_k = Σ_j x_j · e^(−2πi·jk/len)`, unscaled, computed for `L` pixels at once.
//!
//! # Layout
//! A complex signal of length `len` lives in one slice of `2·len` [`Lanes`]: the real parts in
//! `[0, len)`, the imaginary parts in `[len, 2·len)` (split planes: every inner-loop access is
//! a plain `slice[k]` with `k < slice.len()` known, so no bounds checks stay in the loops).
//!
//! # Algorithm
//! Stockham autosort, decimation in frequency: stage `i` of radix `R` reads sub-sequences of
//! length `n_s` with stride `s` and writes `y[k + s(Rp + t)] = w^(pt) · DFT_R(x[k + s(p + q·r)])_t`
//! (`q = n_s/R`, `w = e^(−2πi/n_s)`), ping-ponging between the caller's buffer and a work
//! buffer, so the output comes out in natural order with no bit reversal. The last stage
//! (`q = 1`) has no twiddles and reads and writes the same places, so it can run in place:
//! that is how an odd number of stages still ends in the caller's buffer.
//!
//! Radices: 8, 4 and 2 for the power of two, 3 and 5, and any other prime as a direct
//! O(p²) DFT (`generic.rs`).
//!
//! # Tables
//! For each stage in order: the twiddles of rows `p = 1..q` (row 0 is all ones and is
//! skipped), each row `R−1` complex values `w^(pt)`, `t = 1..R`, as `(re, im)` f32 pairs;
//! a generic prime stage appends its `R` roots `(cos 2πu/R, sin 2πu/R)`, `u = 0..R`.
//! Every value is computed in f64 from an exact rational multiple of π ([`cis`]) and
//! rounded once to f32, so every machine builds the same bits.

use crate::transform::cosine::TransformError;
use crate::transform::lanes::{add, mul_add2, mul_sub, scale, sub};
use crate::transform::Lanes;

mod generic;
mod radix2;
mod radix3;
mod radix4;
mod radix5;
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
    /// Order: other primes, then 5s, then 3s, then the power of two as one radix-8 stage
    /// when the exponent is odd followed by radix-4 stages (radix 2 only for len 2·odd).
    /// Ending on a fixed radix lets the in-place last stage absorb an odd stage count.
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
        for _ in 0..threes {
            plan.push(3);
        }
        if twos == 1 {
            plan.push(2);
        } else {
            if twos % 2 == 1 {
                plan.push(8);
                twos -= 3;
            }
            for _ in 0..twos / 2 {
                plan.push(4);
            }
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
    matches!(r, 2 | 3 | 4 | 5 | 8)
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
        self.run(&mut buf[..needed], &mut work[..needed]);
        Ok(())
    }

    /// [`Fft::forward`] on slices of exactly `2·len` (checked by the callers).
    pub(crate) fn run<const L: usize>(&self, buf: &mut [Lanes<L>], work: &mut [Lanes<L>]) {
        let n = self.len;
        let radices = self.plan.radices();
        let stages = radices.len();
        if stages == 0 {
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
                let (yr, yi) = src.split_at_mut(n);
                last_in_place(yr, yi, s, r);
            } else {
                let (xr, xi) = src.split_at(n);
                let (yr, yi) = dst.split_at_mut(n);
                stage(xr, xi, yr, yi, s, q, r, tw);
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

/// One out-of-place stage, dispatched on the radix.
#[allow(clippy::too_many_arguments)]
fn stage<const L: usize>(
    xr: &[Lanes<L>],
    xi: &[Lanes<L>],
    yr: &mut [Lanes<L>],
    yi: &mut [Lanes<L>],
    s: usize,
    q: usize,
    r: usize,
    tw: &[f32],
) {
    match r {
        2 => radix2::pass(xr, xi, yr, yi, s, q, tw),
        3 => radix3::pass(xr, xi, yr, yi, s, q, tw),
        4 => radix4::pass(xr, xi, yr, yi, s, q, tw),
        5 => radix5::pass(xr, xi, yr, yi, s, q, tw),
        8 => radix8::pass(xr, xi, yr, yi, s, q, tw),
        _ => {
            let (xr, xi) = (xr.as_flattened(), xi.as_flattened());
            let (yr, yi) = (yr.as_flattened_mut(), yi.as_flattened_mut());
            generic::pass::<L>(xr, xi, yr, yi, s, q, r, tw)
        }
    }
}

/// The last stage (`q = 1`, no twiddles) in place, for a fixed radix.
fn last_in_place<const L: usize>(yr: &mut [Lanes<L>], yi: &mut [Lanes<L>], s: usize, r: usize) {
    match r {
        2 => radix2::last(yr, yi, s),
        3 => radix3::last(yr, yi, s),
        4 => radix4::last(yr, yi, s),
        5 => radix5::last(yr, yi, s),
        _ => radix8::last(yr, yi, s),
    }
}

/// One complex value per lane, `[re, im]`.
pub(crate) type C<const L: usize> = [Lanes<L>; 2];

/// `a + b`.
#[inline(always)]
pub(crate) fn cadd<const L: usize>(a: C<L>, b: C<L>) -> C<L> {
    [add(a[0], b[0]), add(a[1], b[1])]
}

/// `a − b`.
#[inline(always)]
pub(crate) fn csub<const L: usize>(a: C<L>, b: C<L>) -> C<L> {
    [sub(a[0], b[0]), sub(a[1], b[1])]
}

/// `a − i·b`.
#[inline(always)]
pub(crate) fn csub_i<const L: usize>(a: C<L>, b: C<L>) -> C<L> {
    [add(a[0], b[1]), sub(a[1], b[0])]
}

/// `a + i·b`.
#[inline(always)]
pub(crate) fn cadd_i<const L: usize>(a: C<L>, b: C<L>) -> C<L> {
    [sub(a[0], b[1]), add(a[1], b[0])]
}

/// `a·w` for a real scalar `w`.
#[inline(always)]
pub(crate) fn cscale<const L: usize>(a: C<L>, w: f32) -> C<L> {
    [scale(a[0], w), scale(a[1], w)]
}

/// `a·(wr + i·wi)` for a scalar twiddle: four products, a difference and a sum (never fused).
#[inline(always)]
pub(crate) fn cmul<const L: usize>(a: C<L>, wr: f32, wi: f32) -> C<L> {
    [mul_sub(a[0], wr, a[1], wi), mul_add2(a[0], wi, a[1], wr)]
}

/// A fixed-radix DFT kernel, in place on `R` values of `L` lanes. A trait (not a closure)
/// so that `#[inline(always)]` reaches into every pass.
pub(crate) trait Butterfly<const R: usize> {
    /// `a ← DFT_R(a)` with `ω = e^(−2πi/R)`.
    fn run<const L: usize>(a: &mut [C<L>; R]);
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

/// One butterfly: loads element `k` of the `R` input runs, transforms, twiddles (if `TW`),
/// stores element `k` of the `R` output runs. Loads all come before stores, so LLVM's SLP
/// vectoriser packs the lanes of each value; `black_box` keeps the loop vectoriser from
/// instead vectorising across `k` (strided gathers), at no instruction cost.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn kernel<const L: usize, const R: usize, B: Butterfly<R>, const TW: bool>(
    xr: &[&[Lanes<L>]; R],
    xi: &[&[Lanes<L>]; R],
    yr: &mut [&mut [Lanes<L>]; R],
    yi: &mut [&mut [Lanes<L>]; R],
    w: &[[f32; 2]; R],
    k: usize,
) {
    core::hint::black_box(k);
    let mut a = [[[0.0f32; L]; 2]; R];
    for r in 0..R {
        a[r] = [xr[r][k], xi[r][k]];
    }
    B::run(&mut a);
    if TW {
        for t in 1..R {
            a[t] = cmul(a[t], w[t][0], w[t][1]);
        }
    }
    for t in 0..R {
        yr[t][k] = a[t][0];
        yi[t][k] = a[t][1];
    }
}

/// Generic body of an out-of-place stage with a fixed radix `R` and butterfly `B`:
/// row `p` reads the runs of `s` elements at `(r·q + p)·s` and writes `(p·R + t)·s`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn pass_fixed<const L: usize, const R: usize, B: Butterfly<R>>(
    xr: &[Lanes<L>],
    xi: &[Lanes<L>],
    yr: &mut [Lanes<L>],
    yi: &mut [Lanes<L>],
    s: usize,
    q: usize,
    tw: &[f32],
) {
    let blk = q * s;
    let row_len = 2 * (R - 1);
    let tw = &tw[..row_len * (q - 1)];
    let mut yr_rest = &mut yr[..R * blk];
    let mut yi_rest = &mut yi[..R * blk];
    let mut w = [[1.0f32, 0.0]; R];
    for p in 0..q {
        let (yr_p, t) = core::mem::take(&mut yr_rest).split_at_mut(R * s);
        yr_rest = t;
        let (yi_p, t) = core::mem::take(&mut yi_rest).split_at_mut(R * s);
        yi_rest = t;
        let mut yr_t: [&mut [Lanes<L>]; R] = split_mut(yr_p, s);
        let mut yi_t: [&mut [Lanes<L>]; R] = split_mut(yi_p, s);
        let at = p * s;
        let xr_p: [&[Lanes<L>]; R] = core::array::from_fn(|r| &xr[r * blk + at..][..s]);
        let xi_p: [&[Lanes<L>]; R] = core::array::from_fn(|r| &xi[r * blk + at..][..s]);
        if p == 0 {
            for k in 0..s {
                kernel::<L, R, B, false>(&xr_p, &xi_p, &mut yr_t, &mut yi_t, &w, k);
            }
        } else {
            let row = &tw[row_len * (p - 1)..][..row_len];
            for t in 1..R {
                w[t] = [row[2 * (t - 1)], row[2 * (t - 1) + 1]];
            }
            for k in 0..s {
                kernel::<L, R, B, true>(&xr_p, &xi_p, &mut yr_t, &mut yi_t, &w, k);
            }
        }
    }
}

/// Generic body of the in-place last stage (`q = 1`) of a fixed radix `R`.
#[inline(always)]
fn last_fixed<const L: usize, const R: usize, B: Butterfly<R>>(
    yr: &mut [Lanes<L>],
    yi: &mut [Lanes<L>],
    s: usize,
) {
    let yr_t: [&mut [Lanes<L>]; R] = split_mut(&mut yr[..R * s], s);
    let yi_t: [&mut [Lanes<L>]; R] = split_mut(&mut yi[..R * s], s);
    for k in 0..s {
        core::hint::black_box(k);
        let mut a = [[[0.0f32; L]; 2]; R];
        for r in 0..R {
            a[r] = [yr_t[r][k], yi_t[r][k]];
        }
        B::run(&mut a);
        for t in 0..R {
            yr_t[t][k] = a[t][0];
            yi_t[t][k] = a[t][1];
        }
    }
}
