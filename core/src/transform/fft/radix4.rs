//! Radix-4 stage (`ω = −i`): two levels of radix-2 with the inner `−i` folded into adds.

use super::{cadd, cadd_i, csub, csub_i, last_fixed, pass_fixed, Butterfly, C};

use crate::transform::Lanes;

const R: usize = 4;

/// The radix-4 kernel.
pub(super) struct Radix;

impl Butterfly<4> for Radix {
    #[inline(always)]
    fn run<const L: usize>(a: &mut [C<L>; 4]) {
        *a = dft4(*a);
    }
}

/// 4-point DFT with `ω = e^(−2πi/4) = −i`.
#[inline(always)]
pub(super) fn dft4<const L: usize>(a: [C<L>; 4]) -> [C<L>; 4] {
    let t0 = cadd(a[0], a[2]);
    let t1 = csub(a[0], a[2]);
    let t2 = cadd(a[1], a[3]);
    let t3 = csub(a[1], a[3]);
    [cadd(t0, t2), csub_i(t1, t3), csub(t0, t2), cadd_i(t1, t3)]
}

/// Out-of-place stage (see [`super`] for the indexing).
#[inline(never)]
pub(super) fn pass<const L: usize>(
    xr: &[Lanes<L>],
    xi: &[Lanes<L>],
    yr: &mut [Lanes<L>],
    yi: &mut [Lanes<L>],
    s: usize,
    q: usize,
    tw: &[f32],
) {
    pass_fixed::<L, R, Radix>(xr, xi, yr, yi, s, q, tw);
}

/// In-place last stage.
#[inline(never)]
pub(super) fn last<const L: usize>(yr: &mut [Lanes<L>], yi: &mut [Lanes<L>], s: usize) {
    last_fixed::<L, R, Radix>(yr, yi, s);
}
