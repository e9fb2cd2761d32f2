//! Radix-4 butterfly (`ω = −i`): two levels of radix-2 with the inner `−i` folded into adds.

use super::{Butterfly, Cx};
use crate::transform::simd::Arith;

/// The radix-4 kernel.
pub(super) struct Radix;

impl Butterfly<4> for Radix {
    #[inline(always)]
    fn run<V: Arith>(a: &mut [Cx<V>; 4]) {
        *a = dft4(*a);
    }
}

/// 4-point DFT with `ω = e^(−2πi/4) = −i`.
#[inline(always)]
pub(super) fn dft4<V: Arith>(a: [Cx<V>; 4]) -> [Cx<V>; 4] {
    let t0 = a[0].add(a[2]);
    let t1 = a[0].sub(a[2]);
    let t2 = a[1].add(a[3]);
    let t3 = a[1].sub(a[3]);
    [t0.add(t2), t1.sub_i(t3), t0.sub(t2), t1.add_i(t3)]
}
