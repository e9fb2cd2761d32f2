//! Radix-8 stage: two 4-point DFTs (even and odd inputs) joined by `ω^t`, `ω = e^(−2πi/8)`;
//! `ω` and `ω³` cost two adds and two multiplies by √½ each, `ω² = −i` is free.

use super::{
    cadd, cadd_i, cscale, csub, csub_i, last_fixed, pass_fixed, radix4::dft4, Butterfly, C,
};

use crate::transform::lanes::{add, sub};
use crate::transform::Lanes;

const R: usize = 8;

/// The radix-8 kernel.
pub(super) struct Radix;

/// √½, rounded once to f32.
pub(super) const FRAC_1_SQRT_2: f32 = core::f64::consts::FRAC_1_SQRT_2 as f32;

impl Butterfly<8> for Radix {
    #[inline(always)]
    fn run<const L: usize>(a: &mut [C<L>; 8]) {
        let e = dft4([a[0], a[2], a[4], a[6]]);
        let o = dft4([a[1], a[3], a[5], a[7]]);
        // ω·z = ((re + im) + i(im − re))·√½
        let o1 = cscale(
            [add(o[1][0], o[1][1]), sub(o[1][1], o[1][0])],
            FRAC_1_SQRT_2,
        );
        // ω³·z = ((im − re) − i(re + im))·√½, kept as (re, −im) and signed in the joins.
        let o3 = cscale(
            [sub(o[3][1], o[3][0]), add(o[3][0], o[3][1])],
            FRAC_1_SQRT_2,
        );
        *a = [
            cadd(e[0], o[0]),
            cadd(e[1], o1),
            csub_i(e[2], o[2]),
            [add(e[3][0], o3[0]), sub(e[3][1], o3[1])],
            csub(e[0], o[0]),
            csub(e[1], o1),
            cadd_i(e[2], o[2]),
            [sub(e[3][0], o3[0]), add(e[3][1], o3[1])],
        ]
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
