//! The paper's local-maximum search (`PeakSearch::LocalMaxima`, `DecodeSettings::local_maxima`):
//! what it finds and how accurately, on synthetic pixels (12-bit samples, 1 DN read noise),
//! next to the default CLEAN search on the same pixels.
//!
//! `cargo test -p fsm-core --release --test suite local_maxima:: -- --nocapture` prints the figures.

use crate::support;

use fsm_core::{
    DecodeSettings, GroupCount, PeakEstimator, PeakSearch, PixelCandidates, ScanPlan, Window,
};
use support::{decode_all, nearest_error, Pixel};

fn fast(mut plan: ScanPlan) -> ScanPlan {
    plan.decoding = DecodeSettings::local_maxima();
    plan
}

/// RMS and worst error of the nearest candidate over blurred spots at fractional columns, and
/// how many pixels got exactly one candidate.
fn spots(plan: ScanPlan, seed: u64) -> (f64, f64, usize, usize) {
    let pixels: Vec<Pixel> = (0..400)
        .map(|i| Pixel::spot(20.0 + i as f64 * 1.8371, 0.6, 1200.0))
        .collect();
    let out = decode_all::<8>(plan, &pixels, seed);
    let (mut sq, mut worst, mut single) = (0.0, 0.0f64, 0);
    for (p, pixel) in out.iter().zip(&pixels) {
        let truth = pixel.centroid_near(pixel.lights[pixel.lights.len() / 2].0 as f64);
        let e = nearest_error(p, truth);
        sq += e * e;
        worst = worst.max(e);
        single += (p.candidates.len() == 1) as usize;
        if p.candidates.len() != 1 && std::env::var("DBG").is_ok() {
            println!(
                "truth {truth:.3}: {:?}",
                p.candidates
                    .iter()
                    .map(|c| (c.column, c.amplitude, c.group))
                    .collect::<Vec<_>>()
            );
        }
    }
    ((sq / out.len() as f64).sqrt(), worst, single, out.len())
}

#[test]
fn every_column_is_found_once_with_both_efsm_groups() {
    for n in [128u16, 64] {
        let mut plan = fast(ScanPlan::paper_efsm(GroupCount::Two));
        plan.transform_size = n;
        let pixels: Vec<Pixel> = (0..768).map(|c| Pixel::column(c, 1200.0)).collect();
        let out = decode_all::<8>(plan, &pixels, 3);
        let mut worst: f64 = 0.0;
        for (c, p) in out.iter().enumerate() {
            // One candidate, no sidelobe reported as light.
            assert_eq!(
                p.candidates.len(),
                1,
                "N {n} column {c}: {:?}",
                p.candidates
            );
            worst = worst.max(nearest_error(p, c as f64));
        }
        println!("local maxima, EFSM 2 groups, N {n}: every column once, worst error {worst:.4}");
        assert!(worst < 0.25, "N {n}: worst {worst}");
    }
}

#[test]
fn blurred_spots_are_located_and_clean_remains_the_more_accurate() {
    let base = ScanPlan::paper_efsm(GroupCount::Two);
    let (clean_rms, clean_worst, _, _) = spots(base, 5);
    println!("CLEAN + deconvolution: RMS {clean_rms:.4} worst {clean_worst:.4} column");
    for n in [128u16, 64] {
        for estimator in [
            PeakEstimator::Gaussian,
            PeakEstimator::Parabolic,
            PeakEstimator::BlaisRioux4,
            PeakEstimator::Deconvolution,
        ] {
            let mut plan = fast(base);
            plan.transform_size = n;
            plan.decoding.estimator = estimator;
            let (rms, worst, single, count) = spots(plan, 5);
            println!(
                "local maxima N {n} {estimator:?}: RMS {rms:.4} worst {worst:.4} column, \
                 {single}/{count} pixels with one candidate"
            );
            assert_eq!(
                single, count,
                "N {n} {estimator:?}: a spot gave several candidates"
            );
            assert!(worst < 0.5, "N {n} {estimator:?}: worst {worst}");
            assert!(
                rms > clean_rms,
                "N {n} {estimator:?}: {rms} <= CLEAN's {clean_rms}"
            );
        }
    }
}

#[test]
fn two_lights_apart_are_both_found() {
    // Direct 1200 DN and indirect 500 DN, 12.5 to 300 columns apart: beyond the Hann main lobe
    // (2·2Δc = 4 columns with BFSM's 768 fringes).
    let plan = fast(ScanPlan::paper_bfsm());
    let pixels: Vec<(Pixel, f64, f64)> = (0..60)
        .map(|i| {
            let a = 100 + 7 * i;
            let b = a + 12 + (i * 41) % 300;
            let b = if b >= 767 { a - 13 } else { b };
            let p = Pixel::column(a, 1200.0).plus(Pixel::column(b, 500.0));
            (p, a as f64, b as f64)
        })
        .collect();
    let lights: Vec<Pixel> = pixels.iter().map(|p| p.0.clone()).collect();
    let out = decode_all::<8>(plan, &lights, 7);
    for (p, (_, a, b)) in out.iter().zip(&pixels) {
        assert_eq!(p.candidates.len(), 2, "{a} + {b}: {:?}", p.candidates);
        assert!(nearest_error(p, *a) < 0.2, "{a}: {:?}", p.candidates);
        assert!(nearest_error(p, *b) < 0.2, "{b}: {:?}", p.candidates);
        // The stronger light first, with its amplitude (modulation × PB) within 3%.
        let strongest = p.strongest().unwrap();
        assert!((strongest.column as f64 - a).abs() < 0.2);
        let expected = 1200.0 * plan.levels.amplitude as f64;
        let ratio = strongest.amplitude as f64 / expected;
        assert!((ratio - 1.0).abs() < 0.03, "amplitude ratio {ratio}");
    }
}

#[test]
fn shadow_gives_nothing_and_noise_matches_clean() {
    for plan in [
        ScanPlan::paper_bfsm(),
        ScanPlan::paper_efsm(GroupCount::One),
    ] {
        let pixels: Vec<Pixel> = (0..2000)
            .map(|_| Pixel {
                lights: vec![],
                ambient: 150.0,
            })
            .collect();
        let out = decode_all::<8>(fast(plan), &pixels, 11);
        let lit = out.iter().filter(|p| !p.candidates.is_empty()).count();
        println!("shadow: {lit} of 2000 pixels with a candidate");
        assert!(lit <= 2, "{lit} of 2000 shadow pixels got candidates");
        // Both searches estimate the same sample noise (1 DN read noise plus quantisation)
        // within 10%: on a pixel in shadow there is nothing for CLEAN to remove.
        let clean = decode_all::<8>(plan, &pixels, 11);
        let mean = |o: &[PixelCandidates<8>]| {
            o.iter().map(|p| p.noise_dn as f64).sum::<f64>() / o.len() as f64
        };
        let (a, b) = (mean(&out), mean(&clean));
        println!("shadow noise: local maxima {a:.3} DN, CLEAN {b:.3} DN");
        assert!((a / b - 1.0).abs() < 0.1, "{a} vs {b}");
    }
}

#[test]
fn the_rectangular_window_reports_sidelobes_which_the_preset_avoids() {
    // Why `local_maxima()` uses the Hann window: without it a strong light's −13 dB sidelobes
    // are local maxima above a 5% floor.
    let mut plan = fast(ScanPlan::paper_bfsm());
    plan.decoding.window = Window::Rectangular;
    let pixels: Vec<Pixel> = (0..50)
        .map(|i| Pixel::column(200 + 9 * i, 3000.0))
        .collect();
    let out = decode_all::<8>(plan, &pixels, 13);
    let extra = out.iter().filter(|p| p.candidates.len() > 1).count();
    assert!(extra > 40, "only {extra} of 50 pixels showed sidelobes");
    let out = decode_all::<8>(fast(ScanPlan::paper_bfsm()), &pixels, 13);
    assert!(out.iter().all(|p| p.candidates.len() == 1));
}

#[test]
fn light_wider_than_a_few_columns_splits_into_its_edges() {
    // The limit of any magnitude detector: adjacent columns' kernels differ in phase by
    // 2π·f_centre per column (a quarter turn with the full band), so a wide light's magnitude
    // cancels in its middle and peaks at its edges. CLEAN fits the complex spectrum and is not
    // affected. What a camera pixel sees is about `projector columns / camera columns` wide.
    let fast_plan = fast(ScanPlan::paper_efsm(GroupCount::Two));
    let clean_plan = ScanPlan::paper_efsm(GroupCount::Two);
    let light = |width: u32| {
        (1..width).fold(Pixel::column(300, 300.0), |p, j| {
            p.plus(Pixel::column(300 + j, 300.0))
        })
    };
    for (width, splits) in [(1u32, false), (3, false), (6, true), (8, true)] {
        let truth = 300.0 + (width as f64 - 1.0) / 2.0;
        let pixels = [light(width)];
        let fast = &decode_all::<8>(fast_plan, &pixels, 17)[0];
        let clean = &decode_all::<8>(clean_plan, &pixels, 17)[0];
        let columns: Vec<f32> = fast.candidates.iter().map(|c| c.column).collect();
        println!("{width} columns wide, centre {truth}: local maxima {columns:?}");
        assert_eq!(
            clean.candidates.len(),
            1,
            "CLEAN, {width}: {:?}",
            clean.candidates
        );
        assert!(nearest_error(clean, truth) < 0.05, "CLEAN, {width}");
        if splits {
            assert_eq!(columns.len(), 2, "{width}: {columns:?}");
            assert!(nearest_error(fast, truth) > 2.0, "{width}: {columns:?}");
        } else {
            assert_eq!(columns.len(), 1, "{width}: {columns:?}");
            assert!(nearest_error(fast, truth) < 0.1, "{width}: {columns:?}");
        }
    }
}

#[test]
fn sequences_too_short_to_measure_noise_beside_a_light_are_refused() {
    let mut plan = ScanPlan::efsm(768, 16, GroupCount::Two).with_local_maxima();
    let e = plan.validate().unwrap_err().to_string();
    assert!(
        e.contains("band.count = 16") && e.contains("LocalMaxima"),
        "{e}"
    );
    plan.decoding.search = PeakSearch::Clean;
    assert!(plan.validate().is_ok());
    assert!(ScanPlan::efsm(768, 32, GroupCount::Two)
        .with_local_maxima()
        .validate()
        .is_ok());
}

#[test]
fn the_search_is_part_of_the_plan_and_its_wire_form() {
    let clean = ScanPlan::paper_efsm(GroupCount::One).with_clean();
    let plan = fast(clean);
    assert_eq!(plan.decoding.search, PeakSearch::LocalMaxima);
    assert_ne!(plan.fingerprint(), clean.fingerprint());
    let bytes = plan.to_bytes();
    assert_eq!(bytes[18], 1);
    assert_eq!(ScanPlan::from_bytes(&bytes).unwrap(), plan);
    // A CLEAN plan's bytes are those of plans written before the field existed (byte 18 was
    // reserved, 0), so their fingerprints are unchanged; the cosine search is 2.
    assert_eq!(clean.to_bytes()[18], 0);
    assert_eq!(ScanPlan::paper_efsm(GroupCount::One).to_bytes()[18], 2);
    let mut bad = bytes;
    bad[18] = 3;
    let e = ScanPlan::from_bytes(&bad).unwrap_err().to_string();
    assert!(e.contains("search"), "{e}");
    let mut bad = bytes;
    bad[19] = 1;
    let e = ScanPlan::from_bytes(&bad).unwrap_err().to_string();
    assert!(e.contains("reserved"), "{e}");
}
