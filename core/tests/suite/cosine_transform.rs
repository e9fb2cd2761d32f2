//! The inverse DCT-I (`transform::cosine`) against a naive O(n²) sum in `f64`, for every span
//! from 8 to 2048 (the range: powers of two, the paper's 768 = 3·256, primes), and the
//! vector path against the scalar one bit for bit. The default run takes every span to 600 and
//! every fifth above (with 768, 1024, 1536, 2048); every span to 2048 and the worst error:
//! `cargo test -p fsm-core --release --test suite cosine_transform:: -- --ignored --nocapture`
//! (worst 8.6e-6 of the profile's largest value, at span 1966).

use fsm_core::transform::{CosineTransform, Lanes};

const L: usize = 4;

/// A reproducible sample in [-1, 1) (xorshift).
fn samples(seed: u64, n: usize) -> Vec<f64> {
    let mut s = seed | 1;
    (0..n)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 52) as f64 - 1.0
        })
        .collect()
}

/// `p_j = (c_j/n)·[z_0/2 + (−1)^j·z_n/2 + Σ_(h=1..n−1) z_h·cos(πhj/n)]`, `c_j = 2` inside, `1`
/// at the ends.
fn naive_inverse(z: &[f64]) -> Vec<f64> {
    let n = z.len() - 1;
    let cos: Vec<f64> = (0..2 * n)
        .map(|k| (std::f64::consts::PI * k as f64 / n as f64).cos())
        .collect();
    (0..=n)
        .map(|j| {
            let sign = if j % 2 == 0 { 1.0 } else { -1.0 };
            let mut y = 0.5 * z[0] + 0.5 * sign * z[n];
            for (h, &zh) in z.iter().enumerate().take(n).skip(1) {
                y += zh * cos[(h * j) % (2 * n)];
            }
            let c = if j == 0 || j == n { 1.0 } else { 2.0 };
            c / n as f64 * y
        })
        .collect()
}

#[test]
fn inverse_matches_the_naive_transform_for_spans_from_8_to_2048() {
    let spans =
        (8..=2048usize).filter(|&s| s <= 600 || s % 5 == 0 || s.is_power_of_two() || s % 768 == 0);
    check_spans("8..=2048, a subset", spans);
}

#[test]
#[ignore = "every span to 2048: about 20 s in release"]
fn inverse_matches_the_naive_transform_for_every_span_from_8_to_2048() {
    check_spans("8..=2048", 8..=2048);
}

fn check_spans(label: &str, spans: impl Iterator<Item = usize>) {
    let (mut worst, mut worst_span) = (0.0f64, 0);
    for span in spans {
        let mut tables = vec![0.0f32; CosineTransform::tables_len(span)];
        CosineTransform::build(span, &mut tables).unwrap();
        let transform = CosineTransform::view(span, &tables).unwrap();
        // Lane l holds its own profile's samples.
        let z: Vec<Vec<f64>> = (0..L)
            .map(|l| samples((span * L + l) as u64, span + 1))
            .collect();
        let mut data: Vec<Lanes<L>> = (0..=span)
            .map(|h| core::array::from_fn(|l| z[l][h] as f32))
            .collect();
        let mut scalar = data.clone();
        let mut scratch = vec![[0.0f32; L]; CosineTransform::scratch_len(span)];
        transform.inverse(&mut data, &mut scratch).unwrap();
        transform.inverse_scalar(&mut scalar, &mut scratch).unwrap();
        assert!(
            data.iter()
                .flatten()
                .zip(scalar.iter().flatten())
                .all(|(a, b)| a.to_bits() == b.to_bits()),
            "span {span}: the vector path differs from the scalar one"
        );
        for (l, zl) in z.iter().enumerate() {
            // The samples are rounded to f32 before the transform: so is the reference's input.
            let rounded: Vec<f64> = zl.iter().map(|&v| v as f32 as f64).collect();
            let reference = naive_inverse(&rounded);
            let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let error = data
                .iter()
                .zip(&reference)
                .fold(0.0f64, |m, (p, r)| m.max((p[l] as f64 - r).abs()));
            let relative = error / scale;
            if relative > worst {
                (worst, worst_span) = (relative, span);
            }
        }
    }
    println!(
        "inverse DCT-I, spans {label}: worst error {worst:.2e} of the profile's largest value (span {worst_span})"
    );
    assert!(worst < 2e-5, "worst error {worst:e} at span {worst_span}");
}
