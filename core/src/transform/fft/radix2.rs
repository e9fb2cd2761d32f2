//! Radix-2 stage: `b0 = a0 + a1`, `b1 = a0 − a1`.

use super::{cadd, csub, last_fixed, pass_fixed, Butterfly, C};

use crate::transform::Lanes;

const R: usize = 2;

/// The radix-2 kernel.
pub(super) struct Radix;

impl Butterfly<2> for Radix {
    #[inline(always)]
    fn run<const L: usize>(a: &mut [C<L>; 2]) {
        *a = [cadd(a[0], a[1]), csub(a[0], a[1])];
    }
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
