//! Stage of any other (prime) radix `R` as a direct DFT, O(R²) per butterfly.
//!
//! With `h = (R−1)/2`, sums `a_r + a_(R−r)` and differences `a_r − a_(R−r)` pair the roots:
//! `b_t = A_t − i·B_t`, `b_(R−t) = A_t + i·B_t` with `A_t = a0 + Σ (a_r + a_(R−r))·cos(2πrt/R)`
//! and `B_t = Σ (a_r − a_(R−r))·sin(2πrt/R)`. No temporaries (the sums are recomputed per
//! `t`), so it needs no scratch of its own; it is the slow path for awkward lengths.

use super::Cx;
use crate::transform::simd::Vector;

/// Out-of-place stage on split planes of `n`; `tables` holds the twiddle rows then the roots.
#[inline(never)]
pub(super) fn pass<const W: usize, V: Vector<W>>(
    x: &[[f32; W]],
    y: &mut [[f32; W]],
    n: usize,
    s: usize,
    q: usize,
    radix: usize,
    tables: &[f32],
) {
    let (xr, xi) = x.split_at(n);
    let (yr, yi) = y.split_at_mut(n);
    let blk = q * s;
    let row_len = 2 * (radix - 1);
    let (tw, roots) = tables.split_at(row_len * (q - 1));
    let roots = &roots[..2 * radix];
    let h = (radix - 1) / 2;
    for p in 0..q {
        let row = if p == 0 {
            &[][..]
        } else {
            &tw[row_len * (p - 1)..][..row_len]
        };
        for k in 0..s {
            let base = p * s + k;
            let x = |r: usize| -> Cx<V> {
                Cx {
                    re: V::load(&xr[r * blk + base]),
                    im: V::load(&xi[r * blk + base]),
                }
            };
            let mut out = |t: usize, v: Cx<V>| {
                let at = (p * radix + t) * s + k;
                v.re.store(&mut yr[at]);
                v.im.store(&mut yi[at]);
            };
            let a0 = x(0);
            let mut b0 = a0;
            for r in 1..=h {
                b0 = b0.add(x(r).add(x(radix - r)));
            }
            out(0, b0);
            for t in 1..=h {
                let mut ar = a0;
                let mut bi = Cx {
                    re: V::splat(0.0),
                    im: V::splat(0.0),
                };
                let mut u = 0;
                for r in 1..=h {
                    u += t;
                    if u >= radix {
                        u -= radix;
                    }
                    let (c, sn) = (V::splat(roots[2 * u]), V::splat(roots[2 * u + 1]));
                    ar = ar.add(x(r).add(x(radix - r)).scale(c));
                    bi = bi.add(x(r).sub(x(radix - r)).scale(sn));
                }
                let mut lo = ar.sub_i(bi);
                let mut hi = ar.add_i(bi);
                if p > 0 {
                    lo = lo.mul(Cx::splat(row[2 * (t - 1)], row[2 * (t - 1) + 1]));
                    let u = radix - t;
                    hi = hi.mul(Cx::splat(row[2 * (u - 1)], row[2 * (u - 1) + 1]));
                }
                out(t, lo);
                out(radix - t, hi);
            }
        }
    }
}
