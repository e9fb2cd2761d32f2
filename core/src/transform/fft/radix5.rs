//! Radix-5 stage: symmetric sums `a1 ± a4`, `a2 ± a3` times cos/sin of 2π/5 and 4π/5.

use super::{cadd, cadd_i, cscale, csub, csub_i, last_fixed, pass_fixed, Butterfly, C};

use crate::transform::Lanes;

const R: usize = 5;

/// The radix-5 kernel.
pub(super) struct Radix;

/// cos(2π/5), cos(4π/5), sin(2π/5), sin(4π/5), each rounded once to f32.
pub(super) const C1: f32 = 0.309_016_994_374_947_45_f64 as f32;
pub(super) const C2: f32 = -0.809_016_994_374_947_5_f64 as f32;
pub(super) const S1: f32 = 0.951_056_516_295_153_5_f64 as f32;
pub(super) const S2: f32 = 0.587_785_252_292_473_1_f64 as f32;

impl Butterfly<5> for Radix {
    /// `b_t = A_t ∓ i·B_t` with `A = a0 + c·s1 + c'·s2` (products first), `B = s·d1 ± s'·d2`.
    #[inline(always)]
    fn run<const L: usize>(a: &mut [C<L>; 5]) {
        let s1 = cadd(a[1], a[4]);
        let s2 = cadd(a[2], a[3]);
        let d1 = csub(a[1], a[4]);
        let d2 = csub(a[2], a[3]);
        let b0 = cadd(cadd(a[0], s1), s2);
        let a1 = cadd(a[0], cadd(cscale(s1, C1), cscale(s2, C2)));
        let a2 = cadd(a[0], cadd(cscale(s1, C2), cscale(s2, C1)));
        let b1 = cadd(cscale(d1, S1), cscale(d2, S2));
        let b2 = csub(cscale(d1, S2), cscale(d2, S1));
        *a = [
            b0,
            csub_i(a1, b1),
            csub_i(a2, b2),
            cadd_i(a2, b2),
            cadd_i(a1, b1),
        ];
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
