//! Radix-8 butterfly: two 4-point DFTs (even and odd inputs) joined by `ω^t`, `ω = e^(−2πi/8)`;
//! `ω` and `ω³` cost two adds and two multiplies by √½ each, `ω² = −i` is free.

use super::{radix4::dft4, Butterfly, Cx};
use crate::transform::simd::Arith;

/// The radix-8 kernel.
pub(super) struct Radix;

/// √½, rounded once to f32.
pub(super) const FRAC_1_SQRT_2: f32 = core::f64::consts::FRAC_1_SQRT_2 as f32;

impl Butterfly<8> for Radix {
    #[inline(always)]
    fn run<V: Arith>(a: &mut [Cx<V>; 8]) {
        let h = V::splat(FRAC_1_SQRT_2);
        let e = dft4([a[0], a[2], a[4], a[6]]);
        let o = dft4([a[1], a[3], a[5], a[7]]);
        // ω·z = ((re + im) + i(im − re))·√½
        let o1 = Cx {
            re: o[1].re + o[1].im,
            im: o[1].im - o[1].re,
        }
        .scale(h);
        // ω³·z = ((im − re) − i(re + im))·√½, kept as (re, −im) and signed in the joins.
        let o3 = Cx {
            re: o[3].im - o[3].re,
            im: o[3].re + o[3].im,
        }
        .scale(h);
        *a = [
            e[0].add(o[0]),
            e[1].add(o1),
            e[2].sub_i(o[2]),
            Cx {
                re: e[3].re + o3.re,
                im: e[3].im - o3.im,
            },
            e[0].sub(o[0]),
            e[1].sub(o1),
            e[2].add_i(o[2]),
            Cx {
                re: e[3].re - o3.re,
                im: e[3].im + o3.im,
            },
        ]
    }
}
