//! Radix-3 stage (`ω = e^(−2πi/3) = −½ − i·√3/2`).

use super::{cadd, cadd_i, cscale, csub, csub_i, last_fixed, pass_fixed, Butterfly, C};

use crate::transform::Lanes;

const R: usize = 3;

/// The radix-3 kernel.
pub(super) struct Radix;

/// sin(π/3) = √3/2, rounded once to f32.
pub(super) const SIN_PI_3: f32 = 0.866_025_403_784_438_6_f64 as f32;

impl Butterfly<3> for Radix {
    /// `t = a1 + a2`, `m = a0 − t/2`, `d = (√3/2)(a1 − a2)`, `b1,2 = m ∓ i·d`.
    #[inline(always)]
    fn run<const L: usize>(a: &mut [C<L>; 3]) {
        let t = cadd(a[1], a[2]);
        let m = csub(a[0], cscale(t, 0.5));
        let d = cscale(csub(a[1], a[2]), SIN_PI_3);
        *a = [cadd(a[0], t), csub_i(m, d), cadd_i(m, d)];
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
