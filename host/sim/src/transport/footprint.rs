//! Where a pixel's `s × s` rays go inside its footprint.
//!
//! A fixed grid of rays — the same offsets `(i + ½)/s` in every pixel — reads an edge parallel
//! to the pixel grid at the nearest ray boundary in every pixel along it: the whole edge moves
//! in steps of `1/s` px and its position errs by up to `±1/(2s)` px, the same way in every
//! pixel, so nothing downstream (a corner detector, a decoder) can average the error away.
//!
//! Each pixel therefore gets its own pattern, deterministic from the pixel's coordinates
//! (a hash, no state: the transport of a scene is the same whatever the order rows are
//! computed in, and independent of the sensor's seed). The pattern is *multi-jittered*
//! (Chiu, Shirley & Wang 1994): one ray in each of the `s × s` cells of the pixel, and one in
//! each of the `s²` slabs of width `1/s²` along `x` and along `y` (n-rooks), at a random
//! position inside its slab. Then
//!
//! - a pixel's coverage of any straight edge is unbiased (each ray lands uniformly inside its
//!   cell), so the error of an edge's coverage is noise that is independent from pixel to
//!   pixel and averages out along the edge;
//! - for an edge parallel to the grid only one `1/s²` slab is cut, so a pixel's coverage errs
//!   by at most `1/s²` (std at most `1/(2s²)`: 0.031 of the contrast at the default `s = 4`);
//! - the pattern is point-symmetric about the pixel centre (the ray in cell `(i, j)` mirrors the
//!   one in cell `(s−1−i, s−1−j)`), so the mean offset is exactly zero: where the scene varies
//!   linearly across a pixel (its projector column, its depth), the footprint's mean is the
//!   pixel centre's value, as with the fixed grid.

/// SplitMix64 (Steele, Lea & Flood 2014): the step and the finaliser.
struct SplitMix(u64);

impl SplitMix {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`, 53 bits.
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `0..n` (`n ≤ 64`: the modulo bias is below 2⁻⁵⁸).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }

    /// A uniformly random permutation of `0..n` (Fisher–Yates).
    fn permutation(&mut self, n: usize) -> Vec<usize> {
        let mut p: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            p.swap(i, self.below(i + 1));
        }
        p
    }

    /// A random permutation `π` of `0..n` that commutes with the reflection `j ↦ n−1−j`
    /// (`π(n−1−j) = n−1−π(j)`; for odd `n` it fixes the middle).
    fn symmetric_permutation(&mut self, n: usize) -> Vec<usize> {
        let h = n / 2;
        let tau = self.permutation(h);
        let mut p = vec![0; n];
        for j in 0..h {
            let v = if self.next() & 1 == 1 {
                n - 1 - tau[j]
            } else {
                tau[j]
            };
            p[j] = v;
            p[n - 1 - j] = n - 1 - v;
        }
        if n % 2 == 1 {
            p[h] = h;
        }
        p
    }
}

/// Per-cell permutations of the sub-slabs along one axis: `perms[i][j]` is the sub-slab, within
/// cell column (row) `i`, of the ray of cell `(i, j)`. Point symmetry needs
/// `perms[s−1−i][s−1−j] = s−1−perms[i][j]`.
fn slab_permutations(rng: &mut SplitMix, s: usize) -> Vec<Vec<usize>> {
    let mut perms = vec![Vec::new(); s];
    for i in 0..s / 2 {
        let p = rng.permutation(s);
        perms[s - 1 - i] = (0..s).map(|j| s - 1 - p[s - 1 - j]).collect();
        perms[i] = p;
    }
    if s % 2 == 1 {
        perms[s / 2] = rng.symmetric_permutation(s);
    }
    perms
}

/// The `s × s` ray offsets of pixel `(x, y)` from its centre, each in `(−½, ½)` px, in cell
/// order (`cell (i, j)` at index `j·s + i`, `i` along `x`). Deterministic; see the module.
pub fn offsets(x: u32, y: u32, s: u32) -> Vec<(f64, f64)> {
    let s = s as usize;
    let mut rng = SplitMix(
        0x6673_6d2d_7369_6d00 ^ ((x as u64) << 32 | y as u64).wrapping_mul(0xD6E8_FEB8_6659_FD93),
    );
    // Decorrelate neighbouring seeds before the first draw.
    rng.next();
    let px = slab_permutations(&mut rng, s); // px[i][j]: x sub-slab of cell (i, j)
    let py = slab_permutations(&mut rng, s); // py[j][i]: y sub-slab of cell (i, j)
    let n = s * s;
    let mut jitter = vec![(0.5, 0.5); n];
    for k in 0..n / 2 {
        let (u, v) = (rng.unit(), rng.unit());
        jitter[k] = (u, v);
        jitter[n - 1 - k] = (1.0 - u, 1.0 - v);
    }
    let sf = s as f64;
    (0..n)
        .map(|k| {
            let (i, j) = (k % s, k / s);
            let (u, v) = jitter[k];
            let fx = (i as f64 + (px[i][j] as f64 + u) / sf) / sf;
            let fy = (j as f64 + (py[j][i] as f64 + v) / sf) / sf;
            (fx - 0.5, fy - 0.5)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One ray per cell, one per `1/s²` slab along each axis, point-symmetric, zero mean, for
    /// odd and even `s` and many pixels.
    #[test]
    fn patterns_are_multi_jittered_and_point_symmetric() {
        for s in 1..=9u32 {
            for (x, y) in [(0, 0), (1, 0), (0, 1), (319, 239), (1234, 5678)] {
                let o = offsets(x, y, s);
                let n = (s * s) as usize;
                assert_eq!(o.len(), n);
                let mut slabs_x = vec![0; n];
                let mut slabs_y = vec![0; n];
                for (k, &(dx, dy)) in o.iter().enumerate() {
                    assert!(
                        dx > -0.5 && dx < 0.5 && dy > -0.5 && dy < 0.5,
                        "s {s}: {dx} {dy}"
                    );
                    let (fx, fy) = (dx + 0.5, dy + 0.5);
                    let (i, j) = (k % s as usize, k / s as usize);
                    assert_eq!((fx * s as f64).floor() as usize, i, "s {s} cell {k}: x");
                    assert_eq!((fy * s as f64).floor() as usize, j, "s {s} cell {k}: y");
                    slabs_x[(fx * n as f64).floor() as usize] += 1;
                    slabs_y[(fy * n as f64).floor() as usize] += 1;
                    let (mx, my) = o[n - 1 - k];
                    assert!(
                        (mx + dx).abs() < 1e-12 && (my + dy).abs() < 1e-12,
                        "s {s}: mirror"
                    );
                }
                assert!(
                    slabs_x.iter().all(|&c| c == 1),
                    "s {s}: x slabs {slabs_x:?}"
                );
                assert!(
                    slabs_y.iter().all(|&c| c == 1),
                    "s {s}: y slabs {slabs_y:?}"
                );
                let mean = o.iter().fold((0.0, 0.0), |m, p| (m.0 + p.0, m.1 + p.1));
                assert!(mean.0.abs() < 1e-12 && mean.1.abs() < 1e-12);
            }
        }
        assert_eq!(offsets(3, 4, 1), vec![(0.0, 0.0)]);
    }

    /// Deterministic per pixel, different from pixel to pixel.
    #[test]
    fn patterns_are_per_pixel_and_repeatable() {
        assert_eq!(offsets(17, 42, 4), offsets(17, 42, 4));
        let mut distinct = std::collections::HashSet::new();
        for y in 0..20 {
            for x in 0..20 {
                let o = offsets(x, y, 4);
                distinct.insert(o.iter().map(|p| p.1.to_bits()).collect::<Vec<_>>());
            }
        }
        assert_eq!(distinct.len(), 400);
    }

    /// The coverage of an edge parallel to the pixel rows at any phase, averaged along a row of
    /// pixels, is the true share (the fixed grid's is off by up to 1/(2s)); one pixel's error
    /// is within 1/s².
    #[test]
    fn coverage_of_a_grid_aligned_edge_is_unbiased() {
        let s = 4;
        let pixels = 4000u32;
        for phase in [0.03, 0.125, 0.2, 0.37, 0.5, 0.81, 0.97] {
            let mut sum = 0.0;
            let mut sum2 = 0.0;
            for x in 0..pixels {
                let o = offsets(x, 7, s);
                let covered =
                    o.iter().filter(|p| p.1 + 0.5 < phase).count() as f64 / o.len() as f64;
                let e = covered - phase;
                assert!(e.abs() <= 1.0 / 16.0 + 1e-12, "phase {phase}: {e}");
                sum += e;
                sum2 += e * e;
            }
            let mean = sum / pixels as f64;
            let std = (sum2 / pixels as f64 - mean * mean).sqrt();
            // Standard error of the mean: std / √4000 ≤ 0.031 / 63 ≈ 0.0005.
            assert!(mean.abs() < 0.002, "phase {phase}: mean error {mean}");
            assert!(std <= 1.0 / 32.0 + 1e-3, "phase {phase}: std {std}");
            let fixed = (0..s)
                .filter(|i| (*i as f64 + 0.5) / (s as f64) < phase)
                .count() as f64
                / s as f64
                - phase;
            eprintln!("phase {phase}: mean {mean:+.5}, std {std:.4}; fixed grid {fixed:+.4}");
        }
    }
}
