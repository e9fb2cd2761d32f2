//! Monte-Carlo scatter against paper §VI: the DFT magnitude's variance σ²/(2M) (eq. 21) and the
//! 3-point Gaussian estimator's column variance (eq. 22); and against SPEC §2b: the cosine
//! profile's column noise `σ·√(2/span)`, which sets the cosine search's threshold. The tests
//! fail if the measured variance leaves ±25% of the prediction (±10% for the profile). And the
//! scale a point's quality is measured in under the DFT searches.

use crate::support;

use fsm_core::noise::{dft_magnitude_variance, gaussian_column_variance, profile_noise_dn};
use fsm_core::{Decoder, FringeBand, Group, Method, PeakEstimator, Row, ScanPlan};
use support::{Noise, Pixel};

/// Quantising to integers adds a uniform error of variance 1/12 DN².
const QUANTISATION_VARIANCE: f64 = 1.0 / 12.0;

fn variance(xs: &[f64]) -> f64 {
    let mean = xs.iter().sum::<f64>() / xs.len() as f64;
    xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (xs.len() - 1) as f64
}

#[test]
fn dft_magnitude_scatter_follows_eq_21() {
    let plan = ScanPlan::paper_bfsm();
    let mut tables = vec![0.0; Decoder::tables_len(&plan)];
    let decoder = Decoder::new(&plan, &mut tables).unwrap();
    let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
    // Column 300 sits exactly on bin 200 (bins are 1.5 columns apart).
    let pixel = Pixel::column(300, 800.0);
    let bin = 200;
    for sigma in [2.0, 6.0] {
        let mut noise = Noise::new(21);
        let magnitudes: Vec<f64> = (0..600)
            .map(|_| {
                let s = pixel.samples(&plan, sigma, 16, &mut noise);
                let row = Row {
                    frames: &s,
                    width: 1,
                    bit_depth: 16,
                    column_limits: None,
                };
                decoder
                    .spectrum(&row, 0, Group::One, &mut scratch)
                    .unwrap()
                    .magnitude(bin) as f64
            })
            .collect();
        let measured = variance(&magnitudes);
        let effective = sigma * sigma + QUANTISATION_VARIANCE;
        let predicted = dft_magnitude_variance(effective as f32, plan.band.count as usize) as f64;
        let ratio = measured / predicted;
        println!("eq. 21, σ = {sigma} DN: measured {measured:.3e}, predicted {predicted:.3e}, ratio {ratio:.3}");
        assert!((0.75..=1.25).contains(&ratio), "σ {sigma}: ratio {ratio}");
    }
}

#[test]
fn gaussian_estimator_scatter_follows_eq_22() {
    // Eq. 22 assumes independent noise in F_l, F, F_r: no zero padding (N = M), so bins are
    // Δc = 2 columns apart and orthogonal.
    let plan = ScanPlan {
        projector_columns: 64,
        band: FringeBand {
            period_columns: 128,
            first_harmonic: 1,
            count: 64,
        },
        transform_size: 64,
        method: Method::Bfsm,
        ..ScanPlan::paper_bfsm().with_clean()
    };
    let mut plan = plan;
    plan.decoding.estimator = PeakEstimator::Gaussian;
    plan.validate().unwrap();
    let mut tables = vec![0.0; Decoder::tables_len(&plan)];
    let decoder = Decoder::new(&plan, &mut tables).unwrap();
    let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
    let bw = plan.bin_width();
    for column in [27u32, 31] {
        let pixel = Pixel::column(column, 600.0);
        // Noise-free magnitudes around the peak (16-bit, large signal: quantisation negligible).
        let clean = pixel.samples(&plan, 0.0, 16, &mut Noise::new(0));
        let row = Row {
            frames: &clean,
            width: 1,
            bit_depth: 16,
            column_limits: None,
        };
        let spectrum = decoder.spectrum(&row, 0, Group::One, &mut scratch).unwrap();
        let p = (column as f32 / bw).floor() as usize;
        let (fl, f, fr) = (
            spectrum.magnitude(p - 1),
            spectrum.magnitude(p),
            spectrum.magnitude(p + 1),
        );
        for sigma in [3.0, 8.0] {
            let effective = sigma * sigma + QUANTISATION_VARIANCE;
            let dft_var = dft_magnitude_variance(effective as f32, plan.band.count as usize);
            let predicted = gaussian_column_variance(fl, f, fr, dft_var, bw) as f64;
            let mut noise = Noise::new(22);
            let columns: Vec<f64> = (0..1500)
                .map(|_| {
                    let s = pixel.samples(&plan, sigma, 16, &mut noise);
                    let row = Row {
                        frames: &s,
                        width: 1,
                        bit_depth: 16,
                        column_limits: None,
                    };
                    let peaks = decoder.peaks(&row, 0, Group::One, &mut scratch).unwrap();
                    peaks.peaks[0].column as f64
                })
                .collect();
            let measured = variance(&columns);
            let ratio = measured / predicted;
            println!(
                "eq. 22, column {column}, σ = {sigma} DN: measured {measured:.3e}, predicted {predicted:.3e} \
                 (the paper's (2Δc)² prefactor would predict {:.3e}), ratio {ratio:.3}",
                4.0 * predicted
            );
            assert!(
                (0.75..=1.25).contains(&ratio),
                "column {column} σ {sigma}: ratio {ratio}"
            );
        }
    }
}

#[test]
fn profile_columns_carry_the_predicted_noise() {
    for plan in [
        ScanPlan::paper_bfsm(),
        ScanPlan::efsm(768, 64, fsm_core::GroupCount::One),
    ] {
        let mut tables = vec![0.0; Decoder::tables_len(&plan)];
        let decoder = Decoder::new(&plan, &mut tables).unwrap();
        let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
        let span = plan.full_band_span().unwrap();
        // A lit column, and unlit ones beside and far from it.
        let lit = (span / 3) as usize;
        let pixel = Pixel::column(lit as u32, 900.0);
        let watched = [lit, lit + 4, (2 * span / 3) as usize];
        for sigma in [2.0, 6.0] {
            let mut noise = Noise::new(23);
            let mut values = vec![Vec::new(); watched.len()];
            for _ in 0..1500 {
                let s = pixel.samples(&plan, sigma, 16, &mut noise);
                let row = Row {
                    frames: &s,
                    width: 1,
                    bit_depth: 16,
                    column_limits: None,
                };
                let profile = decoder
                    .profile(&row, 0, Group::One, &mut scratch)
                    .unwrap()
                    .unwrap();
                for (v, &j) in values.iter_mut().zip(&watched) {
                    v.push(profile[j] as f64);
                }
            }
            let effective = (sigma * sigma + QUANTISATION_VARIANCE).sqrt() as f32;
            let predicted = (profile_noise_dn(effective, span) as f64).powi(2);
            for (v, &j) in values.iter().zip(&watched) {
                let ratio = variance(v) / predicted;
                println!(
                    "profile, span {span}, column {j}, σ = {sigma} DN: variance ratio {ratio:.3}"
                );
                assert!(
                    (0.9..=1.1).contains(&ratio),
                    "span {span} column {j}: {ratio}"
                );
            }
        }
    }
}

/// Under a DFT search a point's quality is its amplitude (a fringe modulation, `2|X|`) over
/// the noise one bin gives a modulation ([`Decoder::dark_column_noise_dn`]: `σ·√(2·Σh²)/Σh`).
/// The local-maximum search's amplitude is `2|X|` at the parabola's vertex, so it scatters by
/// about that much, with and without the Hann window; CLEAN's is the sum of the fitted column
/// weights, which scatters more (as the cosine search's sum over a run's columns does over one
/// column's noise).
#[test]
fn the_dft_searches_quality_scale_is_one_bins_noise() {
    let lm = support::synthetic(ScanPlan::paper_bfsm().with_local_maxima());
    assert_eq!(lm.decoding.window, fsm_core::Window::Hann);
    let mut lm_rectangular = lm;
    lm_rectangular.decoding.window = fsm_core::Window::Rectangular;
    let clean = support::synthetic(ScanPlan::paper_bfsm().with_clean());
    // Measured: 0.97 with either window, and 1.72 for CLEAN (its amplitude sums the weights of
    // several columns).
    for (name, plan, expected) in [
        ("local maxima, Hann", lm, 0.8..=1.25),
        ("local maxima, rectangular", lm_rectangular, 0.8..=1.25),
        ("CLEAN, rectangular", clean, 1.4..=2.0),
    ] {
        plan.validate().unwrap();
        let mut tables = vec![0.0; Decoder::tables_len(&plan)];
        let decoder = Decoder::new(&plan, &mut tables).unwrap();
        let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
        let pixel = Pixel::column(301, 800.0);
        let mut noise = Noise::new(23);
        let amplitudes: Vec<f64> = (0..600)
            .map(|_| {
                let s = pixel.samples(&plan, 1.0, 12, &mut noise);
                let row = Row {
                    frames: &s,
                    width: 1,
                    bit_depth: 12,
                    column_limits: None,
                };
                let peaks = decoder.peaks(&row, 0, Group::One, &mut scratch).unwrap();
                peaks.peaks[0].amplitude as f64
            })
            .collect();
        let scatter = variance(&amplitudes).sqrt();
        let scale = Decoder::dark_column_noise_dn(&plan, 12) as f64;
        let ratio = scatter / scale;
        println!(
            "{name}: amplitude scatter {scatter:.4} DN, scale {scale:.4} DN, ratio {ratio:.2}"
        );
        assert!(expected.contains(&ratio), "{name}: ratio {ratio:.2}");
    }
}
