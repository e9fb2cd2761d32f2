//! Radix-6 butterfly by Good–Thomas (6 = 2·3, coprime, so no inner twiddles): 3-point DFTs of
//! `(a0, a2, a4)` and `(a3, a5, a1)`, then 2-point DFTs of matching outputs, written to
//! `b_((3k1 + 4k2) mod 6)`.

use super::{radix3::dft3, Butterfly, Cx};
use crate::transform::simd::Arith;

/// The radix-6 kernel.
pub(super) struct Radix;

impl Butterfly<6> for Radix {
    #[inline(always)]
    fn run<V: Arith>(a: &mut [Cx<V>; 6]) {
        let e = dft3([a[0], a[2], a[4]]);
        let o = dft3([a[3], a[5], a[1]]);
        *a = [
            e[0].add(o[0]),
            e[1].sub(o[1]),
            e[2].add(o[2]),
            e[0].sub(o[0]),
            e[1].add(o[1]),
            e[2].sub(o[2]),
        ];
    }
}
