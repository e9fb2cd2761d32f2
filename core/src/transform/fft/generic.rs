//! Stage of any other (prime) radix `R` as a direct DFT, O(R²) per butterfly.
//!
//! With `h = (R−1)/2`, sums `a_r + a_(R−r)` and differences `a_r − a_(R−r)` pair the roots:
//! `b_t = A_t − i·B_t`, `b_(R−t) = A_t + i·B_t` with `A_t = a0 + Σ (a_r + a_(R−r))·cos(2πrt/R)`
//! and `B_t = Σ (a_r − a_(R−r))·sin(2πrt/R)`. No temporaries (the sums are recomputed per
//! `t`), so it needs no scratch of its own; it is the slow path for awkward lengths.

use super::{cadd, cadd_i, cmul, cscale, csub, csub_i, C};

/// Out-of-place stage on flattened planes; `tables` holds the twiddle rows then the roots.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
pub(super) fn pass<const L: usize>(
    xr: &[f32],
    xi: &[f32],
    yr: &mut [f32],
    yi: &mut [f32],
    s: usize,
    q: usize,
    radix: usize,
    tables: &[f32],
) {
    let unit = s * L;
    let blk = q * unit;
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
        for i in 0..unit {
            let base = p * unit + i;
            let x = |r: usize| -> C<1> { [[xr[r * blk + base]], [xi[r * blk + base]]] };
            let out = |t: usize| (p * radix + t) * unit + i;
            let a0 = x(0);
            let mut b0 = a0;
            for r in 1..=h {
                b0 = cadd(b0, cadd(x(r), x(radix - r)));
            }
            yr[out(0)] = b0[0][0];
            yi[out(0)] = b0[1][0];
            for t in 1..=h {
                let mut ar = a0;
                let mut bi: C<1> = [[0.0], [0.0]];
                let mut u = 0;
                for r in 1..=h {
                    u += t;
                    if u >= radix {
                        u -= radix;
                    }
                    let (c, sn) = (roots[2 * u], roots[2 * u + 1]);
                    ar = cadd(ar, cscale(cadd(x(r), x(radix - r)), c));
                    bi = cadd(bi, cscale(csub(x(r), x(radix - r)), sn));
                }
                let mut lo = csub_i(ar, bi);
                let mut hi = cadd_i(ar, bi);
                if p > 0 {
                    lo = cmul(lo, row[2 * (t - 1)], row[2 * (t - 1) + 1]);
                    let u = radix - t;
                    hi = cmul(hi, row[2 * (u - 1)], row[2 * (u - 1) + 1]);
                }
                yr[out(t)] = lo[0][0];
                yi[out(t)] = lo[1][0];
                yr[out(radix - t)] = hi[0][0];
                yi[out(radix - t)] = hi[1][0];
            }
        }
    }
}
