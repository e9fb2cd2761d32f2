//! Radix-5 butterfly: symmetric sums `a1 ± a4`, `a2 ± a3` times cos/sin of 2π/5 and 4π/5.

use super::{Butterfly, Cx};
use crate::transform::simd::Arith;

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
    fn run<V: Arith>(a: &mut [Cx<V>; 5]) {
        let (c1, c2, s1, s2) = (V::splat(C1), V::splat(C2), V::splat(S1), V::splat(S2));
        let p1 = a[1].add(a[4]);
        let p2 = a[2].add(a[3]);
        let d1 = a[1].sub(a[4]);
        let d2 = a[2].sub(a[3]);
        let b0 = a[0].add(p1).add(p2);
        let a1 = a[0].add(p1.scale(c1).add(p2.scale(c2)));
        let a2 = a[0].add(p1.scale(c2).add(p2.scale(c1)));
        let b1 = d1.scale(s1).add(d2.scale(s2));
        let b2 = d1.scale(s2).sub(d2.scale(s1));
        *a = [b0, a1.sub_i(b1), a2.sub_i(b2), a2.add_i(b2), a1.add_i(b1)];
    }
}
