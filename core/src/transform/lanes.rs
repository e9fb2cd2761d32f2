//! Per-lane arithmetic. Every helper is a plain `for l in 0..L` loop over arrays, so each lane
//! runs the same scalar IEEE operation: LLVM turns the loops into packed SSE/AVX on x86 and
//! leaves them scalar on the camera's VFP. Never `mul_add`: the results must not depend on
//! whether the target has FMA.
#![allow(clippy::needless_range_loop)]

use crate::transform::Lanes;

/// Lane-wise `a + b`.
#[inline(always)]
pub(crate) fn add<const L: usize>(a: Lanes<L>, b: Lanes<L>) -> Lanes<L> {
    let mut r = [0.0; L];
    for l in 0..L {
        r[l] = a[l] + b[l];
    }
    r
}

/// Lane-wise `a - b`.
#[inline(always)]
pub(crate) fn sub<const L: usize>(a: Lanes<L>, b: Lanes<L>) -> Lanes<L> {
    let mut r = [0.0; L];
    for l in 0..L {
        r[l] = a[l] - b[l];
    }
    r
}

/// Lane-wise `a * w` with one scalar `w` (a table entry) for all lanes.
#[inline(always)]
pub(crate) fn scale<const L: usize>(a: Lanes<L>, w: f32) -> Lanes<L> {
    let mut r = [0.0; L];
    for l in 0..L {
        r[l] = a[l] * w;
    }
    r
}

/// Lane-wise `a * wa - b * wb` (the products rounded separately, then the difference).
#[inline(always)]
pub(crate) fn mul_sub<const L: usize>(a: Lanes<L>, wa: f32, b: Lanes<L>, wb: f32) -> Lanes<L> {
    let mut r = [0.0; L];
    for l in 0..L {
        r[l] = a[l] * wa - b[l] * wb;
    }
    r
}

/// Lane-wise `a * wa + b * wb`.
#[inline(always)]
pub(crate) fn mul_add2<const L: usize>(a: Lanes<L>, wa: f32, b: Lanes<L>, wb: f32) -> Lanes<L> {
    let mut r = [0.0; L];
    for l in 0..L {
        r[l] = a[l] * wa + b[l] * wb;
    }
    r
}
