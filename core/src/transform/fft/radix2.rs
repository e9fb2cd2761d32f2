//! Radix-2 butterfly: `b0 = a0 + a1`, `b1 = a0 − a1`.

use super::{Butterfly, Cx};
use crate::transform::simd::Arith;

/// The radix-2 kernel.
pub(super) struct Radix;

impl Butterfly<2> for Radix {
    #[inline(always)]
    fn run<V: Arith>(a: &mut [Cx<V>; 2]) {
        *a = [a[0].add(a[1]), a[0].sub(a[1])];
    }
}
