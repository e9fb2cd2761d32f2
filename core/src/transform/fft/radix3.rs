//! Radix-3 butterfly (`ω = e^(−2πi/3) = −½ − i·√3/2`).

use super::{Butterfly, Cx};
use crate::transform::simd::Arith;

/// The radix-3 kernel.
pub(super) struct Radix;

/// sin(π/3) = √3/2, rounded once to f32.
pub(super) const SIN_PI_3: f32 = 0.866_025_403_784_438_6_f64 as f32;

impl Butterfly<3> for Radix {
    /// `t = a1 + a2`, `m = a0 − t/2`, `d = (√3/2)(a1 − a2)`, `b1,2 = m ∓ i·d`.
    #[inline(always)]
    fn run<V: Arith>(a: &mut [Cx<V>; 3]) {
        *a = dft3(*a);
    }
}

/// 3-point DFT with `ω = e^(−2πi/3)`.
#[inline(always)]
pub(super) fn dft3<V: Arith>(a: [Cx<V>; 3]) -> [Cx<V>; 3] {
    let t = a[1].add(a[2]);
    let m = a[0].sub(t.scale(V::splat(0.5)));
    let d = a[1].sub(a[2]).scale(V::splat(SIN_PI_3));
    [a[0].add(t), m.sub_i(d), m.add_i(d)]
}
