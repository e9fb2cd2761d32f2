//! Bias and scatter of every sub-pixel estimator, measured, on four kinds of light:
//! pure tones across a whole bin, two adjacent columns with known weights, three adjacent
//! columns with known weights, and a defocused spot across a column. The cosine search (the
//! centroid of the light's columns in the exact profile, the default) beside CLEAN with each
//! estimator; the default estimator of CLEAN is the one with the smallest error on the light a
//! projector can actually produce (mixtures of whole columns).
//! `cargo test -p fsm-core --test suite estimators:: -- --nocapture` prints the table.

use crate::support;

use fsm_core::{Group, GroupCount, Pattern, PeakEstimator, PeakSearch, ScanPlan};
use support::{Harness, Noise, Pixel};

const ESTIMATORS: [PeakEstimator; 5] = [
    PeakEstimator::Deconvolution,
    PeakEstimator::Gaussian,
    PeakEstimator::Parabolic,
    PeakEstimator::BlaisRioux4,
    PeakEstimator::BlaisRioux8,
];
const TRIALS: usize = 8;
const NOISE_DN: f64 = 1.0;

/// One light configuration: samples of every frame and the true light-weighted column.
struct Case {
    truth: f64,
    intensities: Vec<f64>,
}

/// Pure tone `A + B cos(2π f_m c)` at any real `c` (not something a projector of discrete
/// columns can emit, but the classic test of a frequency estimator).
fn tone(plan: &ScanPlan, c: f64) -> Case {
    let intensities = plan
        .sequence()
        .map(|p| match p {
            Pattern::Fringe { index, .. } => {
                100.0 + 600.0 * (1.0 + (std::f64::consts::TAU * plan.frequency(index) * c).cos())
            }
            _ => 100.0,
        })
        .collect();
    Case {
        truth: c,
        intensities,
    }
}

fn mixture(plan: &ScanPlan, first: u32, weights: &[f64]) -> Case {
    let lights = weights
        .iter()
        .enumerate()
        .map(|(i, &w)| (first + i as u32, 1200.0 * w))
        .collect();
    let pixel = Pixel {
        lights,
        ambient: 100.0,
    };
    let truth = pixel.centroid_near(first as f64 + 1.0);
    Case {
        truth,
        intensities: pixel.intensities(plan),
    }
}

fn spot(plan: &ScanPlan, c: f64) -> Case {
    let pixel = Pixel::spot(c, 0.6, 1200.0);
    Case {
        truth: pixel.centroid_near(c),
        intensities: pixel.intensities(plan),
    }
}

/// Cases of each kind, placed away from the ends of the span.
fn cases(plan: &ScanPlan) -> Vec<(&'static str, Vec<Case>)> {
    let base = (plan.span_columns() / 2) as f64 - 0.3;
    let bw = plan.bin_width() as f64;
    let j = base.floor() as u32;
    let tones = (0..=20)
        .map(|t| tone(plan, base + bw * t as f64 / 20.0))
        .collect();
    let pairs = (0..=10).map(|t| {
        let a = t as f64 / 10.0;
        mixture(plan, j, &[1.0 - a, a])
    });
    let triples = [0.0, 0.25, 0.5]
        .into_iter()
        .flat_map(|a| [0.0, 0.25, 0.5].into_iter().map(move |b| (a, b)));
    let triples = triples
        .map(|(a, b)| mixture(plan, j, &[a, 1.0, b]))
        .collect();
    let spots = (0..=20)
        .map(|t| spot(plan, base + t as f64 / 20.0))
        .collect();
    vec![
        ("pure tone across a bin", tones),
        ("2 adjacent columns", pairs.collect()),
        ("3 adjacent columns", triples),
        ("defocused spot", spots),
    ]
}

/// (largest |mean error| over the cases, pooled scatter, RMS error).
fn measure(plan: &ScanPlan, cases: &[Case], seed: u64) -> (f64, f64, f64) {
    let mut h = Harness::new(*plan);
    let mut noise = Noise::new(seed);
    let (mut worst_bias, mut var_sum, mut sq_sum, mut n) = (0.0f64, 0.0, 0.0, 0.0);
    for case in cases {
        let errors: Vec<f64> = (0..TRIALS)
            .map(|_| {
                let s: Vec<u16> = case
                    .intensities
                    .iter()
                    .map(|v| (v + NOISE_DN * noise.normal()).round().clamp(0.0, 4095.0) as u16)
                    .collect();
                let peaks = h.peaks(&s, Group::One, 12);
                let strongest = peaks.peaks.first().map_or(f64::NAN, |p| p.column as f64);
                strongest - case.truth
            })
            .collect();
        let mean = errors.iter().sum::<f64>() / TRIALS as f64;
        let var = errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (TRIALS - 1) as f64;
        worst_bias = worst_bias.max(mean.abs());
        var_sum += var;
        sq_sum += errors.iter().map(|e| e * e).sum::<f64>();
        n += TRIALS as f64;
    }
    (
        worst_bias,
        (var_sum / cases.len() as f64).sqrt(),
        (sq_sum / n).sqrt(),
    )
}

#[test]
fn the_profile_and_the_deconvolution_are_the_most_accurate_on_light_from_projector_columns() {
    for plan in [
        ScanPlan::paper_bfsm(),
        ScanPlan::paper_efsm(GroupCount::One),
    ] {
        println!(
            "\n{:?}, N = {}, bins {} column apart, {NOISE_DN} DN noise, {TRIALS} trials per case",
            plan.method,
            plan.transform_size,
            plan.bin_width()
        );
        println!(
            "{:<24} {:<20} {:>10} {:>10} {:>10}",
            "light", "estimator", "max|bias|", "scatter", "RMS"
        );
        assert_eq!(plan.decoding.search, PeakSearch::Cosine);
        for (name, cases) in cases(&plan) {
            let (bias, scatter, cosine) = measure(&plan, &cases, 11);
            println!(
                "{name:<24} {:<20} {bias:>10.4} {scatter:>10.4} {cosine:>10.4}",
                "cosine"
            );
            let mut rms = Vec::new();
            for estimator in ESTIMATORS {
                let mut p = plan.with_clean();
                p.decoding.estimator = estimator;
                let (bias, scatter, r) = measure(&p, &cases, 11);
                println!(
                    "{name:<24} {:<20} {bias:>10.4} {scatter:>10.4} {r:>10.4}",
                    format!("CLEAN {estimator:?}")
                );
                rms.push(r);
            }
            let deconvolution = rms[0];
            if name != "pure tone across a bin" {
                // Light from whole projector columns: the profile and the deconvolution are
                // exact up to noise.
                for (what, r) in [("cosine", cosine), ("deconvolution", deconvolution)] {
                    assert!(r < 0.01, "{name}: {what} RMS {r}");
                }
                for (e, r) in ESTIMATORS.iter().zip(&rms).skip(1) {
                    assert!(
                        deconvolution.max(cosine) * 3.0 < *r,
                        "{name}: cosine {cosine}, deconvolution {deconvolution} vs {e:?} {r}"
                    );
                }
            } else {
                // Not a physical light, but every estimator still lands within a quarter bin.
                for (e, r) in ESTIMATORS.iter().zip(&rms) {
                    assert!(
                        *r < 0.25 * plan.bin_width() as f64 + 0.05,
                        "{name}: {e:?} RMS {r}"
                    );
                }
                assert!(cosine < 0.25, "{name}: cosine RMS {cosine}");
            }
        }
    }
}
