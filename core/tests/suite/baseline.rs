//! The methods FSM is compared with: phase shift (exact on direct light, wrong under
//! interreflection, paper §III-B), Micro Phase Shifting (exact on direct light, its code broken
//! by a second light) and line scanning (every light found, but with a whole sample's noise per
//! column where BFSM, with as many patterns, has `√(2/span)` of it: paper Fig. 13) and Code
//! Ensemble (its XOR codes survive broad indirect light that flips the Gray code's coarse bits;
//! a mirror brighter than the direct light wins every code).

use crate::support;

use fsm_core::baseline::code_ensemble::{self, Code, CodeEnsembleError, CODES, CODEWORDS};
use fsm_core::baseline::line_scan::{LineDetector, LineScanError};
use fsm_core::baseline::micro_phase_shift::{MicroPhaseShiftError, MAX_FREQUENCIES};
use fsm_core::baseline::phase_shift::{PhaseShiftError, PhaseShiftPattern};
use fsm_core::{
    CodeEnsemblePlan, ColumnRange, LineScanPlan, MicroPhaseShiftPlan, PatternSequence,
    PhaseShiftPlan, PixelCandidates, PixelDecoder, ScanPlan,
};
use support::{Noise, Pixel, SYNTHETIC_SENSOR};

/// 12-bit samples of a pixel under every frame of `plan`, with `sigma` DN noise.
fn samples(plan: &impl PatternSequence, pixel: &Pixel, sigma: f64, noise: &mut Noise) -> Vec<u16> {
    (0..plan.frame_count())
        .map(|i| {
            let v = pixel.ambient
                + pixel
                    .lights
                    .iter()
                    .map(|&(j, w)| w * plan.frame_intensity(i, j) as f64)
                    .sum::<f64>();
            (v + sigma * noise.normal()).round().clamp(0.0, 4095.0) as u16
        })
        .collect()
}

fn decode<P: PixelDecoder>(plan: &P, s: &[u16]) -> PixelCandidates<4> {
    let mut out = PixelCandidates::<4>::new();
    plan.decode_pixel(
        |i| s[i],
        4095,
        &ColumnRange::projector(plan.projector_columns()),
        &mut out,
    );
    out
}

/// The paper's line scan, told that its samples come from the synthetic sensor (1 DN).
fn line_scan() -> LineScanPlan {
    LineScanPlan {
        sensor: SYNTHETIC_SENSOR,
        ..LineScanPlan::paper()
    }
}

#[test]
fn the_papers_ps_is_six_offsets_and_seven_gray_codes() {
    let plan = PhaseShiftPlan::paper();
    plan.validate().unwrap();
    assert_eq!(plan.frame_count(), 2 + 6 + 7);
    assert_eq!(plan.pattern(2), Some(PhaseShiftPattern::Fringe { step: 0 }));
    assert_eq!(plan.pattern(8), Some(PhaseShiftPattern::Gray { bit: 0 }));
    let mut short = plan;
    short.period_columns = 8; // 768 columns are 192 half periods of 4 columns: 8 bits
    assert_eq!(
        short.validate(),
        Err(PhaseShiftError::Bits { bits: 7, needed: 8 })
    );
    assert!(short
        .validate()
        .unwrap_err()
        .to_string()
        .contains("8 bits needed"));
    // The FSM plans render through the same trait.
    let bfsm = ScanPlan::paper_bfsm();
    assert_eq!(bfsm.frame_count(), bfsm.sequence_len());
}

#[test]
fn every_column_decodes_under_direct_light() {
    let plan = PhaseShiftPlan::paper();
    let mut noise = Noise::new(1);
    let mut worst: f64 = 0.0;
    for c in 0..768u32 {
        let s = samples(&plan, &Pixel::column(c, 1500.0), 1.0, &mut noise);
        let out = decode(&plan, &s);
        let got = out
            .strongest()
            .unwrap_or_else(|| panic!("column {c} not decoded"));
        worst = worst.max((got.column as f64 - c as f64).abs());
        assert!((got.amplitude - 750.0).abs() < 10.0, "column {c}: {got:?}");
    }
    println!("PS every column: worst {worst:.4}");
    assert!(worst < 0.02, "worst {worst}");
    // Defocused spots: a symmetric spot's phase is its centroid's.
    for i in 0..200 {
        let centre = 2.7 + i as f64 * 3.77;
        let px = Pixel::spot(centre, 0.7, 1500.0);
        let out = decode(&plan, &samples(&plan, &px, 1.0, &mut noise));
        let e = (out.strongest().unwrap().column as f64 - px.centroid_near(centre)).abs();
        assert!(e < 0.05, "spot at {centre}: error {e}");
    }
}

#[test]
fn a_second_light_moves_the_decoded_column() {
    // Paper eq. 3: direct light at column 300 plus a mirror's light from column 523 at 60% of
    // it. Both have the same fringe frequency, so the pixel sees one cosine whose phase lies
    // between theirs: PS reports neither column.
    let plan = PhaseShiftPlan::paper();
    let mut noise = Noise::new(2);
    let mut off = 0;
    for i in 0..40 {
        let direct = 300.0 + i as f64 * 0.25;
        let px =
            Pixel::spot(direct, 0.7, 1500.0).plus(Pixel::spot(523.0 + i as f64 * 0.1, 0.7, 900.0));
        let out = decode(&plan, &samples(&plan, &px, 1.0, &mut noise));
        let error = out
            .strongest()
            .map_or(f64::INFINITY, |c| (c.column as f64 - direct).abs());
        off += (error > 0.5) as usize;
    }
    println!("PS with a 60% second light: {off} of 40 pixels off by more than 0.5 column");
    assert!(off > 20, "{off}");
}

#[test]
fn dim_pixels_are_not_decoded() {
    let plan = PhaseShiftPlan::paper();
    let s = samples(
        &plan,
        &Pixel {
            lights: vec![],
            ambient: 40.0,
        },
        1.0,
        &mut Noise::new(3),
    );
    assert!(decode(&plan, &s).candidates.is_empty());
}

/// A row decodes as its pixels do, for every baseline, and a row of the wrong length is refused.
fn rows_decode_like_pixels<P: PixelDecoder>(plan: &P) {
    let mut noise = Noise::new(4);
    let pixels: Vec<Vec<u16>> = (0..5)
        .map(|i| {
            samples(
                plan,
                &Pixel::spot(100.3 + 97.0 * i as f64, 0.7, 1500.0),
                1.0,
                &mut noise,
            )
        })
        .collect();
    let frames = support::row_frames(&pixels);
    let row = fsm_core::Row {
        frames: &frames,
        width: 5,
        bit_depth: 12,
        column_limits: None,
    };
    let mut out = vec![PixelCandidates::<4>::new(); 5];
    plan.decode_row(&row, &mut out).unwrap();
    for (p, s) in out.iter().zip(&pixels) {
        assert!(!p.candidates.is_empty());
        assert_eq!(p, &decode(plan, s));
    }
    let short = fsm_core::Row {
        frames: &frames[1..],
        ..row
    };
    assert!(plan.decode_row(&short, &mut out).is_err());
    // Column limits narrow what a pixel may report.
    let limits = vec![
        ColumnRange {
            first: 0.0,
            last: 50.0
        };
        5
    ];
    let limited = fsm_core::Row {
        column_limits: Some(&limits),
        ..row
    };
    plan.decode_row(&limited, &mut out).unwrap();
    assert!(out.iter().all(|p| p.candidates.is_empty()));
}

#[test]
fn rows_decode_like_their_pixels() {
    rows_decode_like_pixels(&PhaseShiftPlan::paper());
    rows_decode_like_pixels(&MicroPhaseShiftPlan::paper());
    rows_decode_like_pixels(&line_scan());
    rows_decode_like_pixels(&CodeEnsemblePlan::paper());
}

/// The worst column error over every projector column lit alone, and over 200 defocused spots
/// (whose light-weighted centre is their column), 1500 DN, 1 DN of noise.
fn worst_error_under_direct_light<P: PixelDecoder>(plan: &P, seed: u64) -> f64 {
    let mut noise = Noise::new(seed);
    let mut worst: f64 = 0.0;
    for c in 0..plan.projector_columns() as u32 {
        let s = samples(plan, &Pixel::column(c, 1500.0), 1.0, &mut noise);
        let got = decode(plan, &s);
        let got = got
            .strongest()
            .unwrap_or_else(|| panic!("column {c} not decoded"));
        worst = worst.max((got.column as f64 - c as f64).abs());
    }
    for i in 0..200 {
        let centre = 2.7 + i as f64 * 3.77;
        let px = Pixel::spot(centre, 0.7, 1500.0);
        let out = decode(plan, &samples(plan, &px, 1.0, &mut noise));
        let e = (out.strongest().unwrap().column as f64 - px.centroid_near(centre)).abs();
        worst = worst.max(e);
    }
    worst
}

#[test]
fn mps_decodes_every_column_under_direct_light() {
    let plan = MicroPhaseShiftPlan::paper();
    plan.validate().unwrap();
    assert_eq!((plan.frame_count(), plan.pattern_count()), (17, 17));
    let worst = worst_error_under_direct_light(&plan, 11);
    println!("MPS every column and 200 spots: worst {worst:.4} column");
    assert!(worst < 0.05, "worst {worst}");
}

#[test]
fn mps_codes_of_distinct_columns_stay_apart() {
    // The unwrapping can only be as good as the code: the cosines of the 14 single-offset
    // frequencies plus the first frequency's full phase must differ between any two columns
    // more than 1.5 apart, by more than the noise of a pixel with a few tens of DN of
    // modulation. Computed over quarter columns of the whole projector.
    let closest = closest_codes(&MicroPhaseShiftPlan::paper());
    println!("MPS paper plan: closest codes of columns >= 1.5 apart: {closest:.3}");
    assert!(closest > 0.5, "{closest}");
    // Half the band (15-17 columns) brings columns one mean period apart closer.
    let narrow = closest_codes(&MicroPhaseShiftPlan::spread(768, 16.0, 2.0, 15));
    println!("15-17 columns: {narrow:.3}");
    assert!(narrow < 0.5 * closest, "{narrow}");
    // `fsm plan --method micro-phase-shift` keeps the set for other projectors: its codes stay
    // apart up to a 1920-column one.
    let wide = closest_codes(&MicroPhaseShiftPlan::spread(1920, 16.0, 4.0, 15));
    println!("14-18 columns on 1920 columns: {wide:.3}");
    assert!(wide > 0.5, "{wide}");
}

/// The smallest distance between the codes of two columns of `plan` more than 1.5 apart, over
/// half columns.
fn closest_codes(plan: &MicroPhaseShiftPlan) -> f64 {
    let periods: Vec<f64> = plan.periods().iter().map(|&p| p as f64).collect();
    let code = |c: f64| -> Vec<f64> {
        let mut v: Vec<f64> = periods
            .iter()
            .map(|p| (std::f64::consts::TAU * c / p).cos())
            .collect();
        v.push((std::f64::consts::TAU * c / periods[0]).sin());
        v
    };
    let n = 2 * plan.projector_columns as usize;
    let codes: Vec<Vec<f64>> = (0..n).map(|i| code(i as f64 / 2.0)).collect();
    let mut closest = f64::INFINITY;
    for i in 0..n {
        for j in i + 4..n {
            let d: f64 = codes[i]
                .iter()
                .zip(&codes[j])
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            closest = closest.min(d);
        }
    }
    closest
}

#[test]
fn mps_under_a_second_light_is_wrong_or_silent() {
    // Direct light at 300 plus a mirror's light from 523 at 60% of it, as for PS: every
    // frequency sees the sum of two cosines, so the code matches no column well.
    let plan = MicroPhaseShiftPlan::paper();
    let mut noise = Noise::new(12);
    let (mut right, mut silent) = (0, 0);
    for i in 0..40 {
        let direct = 300.0 + i as f64 * 0.25;
        let px =
            Pixel::spot(direct, 0.7, 1500.0).plus(Pixel::spot(523.0 + i as f64 * 0.1, 0.7, 900.0));
        let out = decode(&plan, &samples(&plan, &px, 1.0, &mut noise));
        match out.strongest() {
            None => silent += 1,
            Some(c) => right += ((c.column as f64 - direct).abs() <= 0.5) as usize,
        }
    }
    println!("MPS with a 60% second light: {right} of 40 right, {silent} without a candidate");
    assert!(right < 20, "{right}");
}

#[test]
fn mps_plan_rules() {
    let plan = MicroPhaseShiftPlan::paper();
    let mut one = plan;
    one.frequencies = 1;
    assert_eq!(
        one.validate(),
        Err(MicroPhaseShiftError::Frequencies { frequencies: 1 })
    );
    let mut many = plan;
    many.frequencies = MAX_FREQUENCIES as u8 + 1;
    assert!(many.validate().is_err());
    let mut repeated = plan;
    repeated.periods_columns[3] = repeated.periods_columns[1];
    assert_eq!(
        repeated.validate(),
        Err(MicroPhaseShiftError::RepeatedPeriod { index: 3 })
    );
    let mut short = plan;
    short.periods_columns[2] = 1.5;
    let e = short.validate().unwrap_err();
    assert_eq!(
        e,
        MicroPhaseShiftError::Period {
            index: 2,
            period_columns: 1.5
        }
    );
    assert!(e.to_string().contains("periods_columns[2] = 1.5"), "{e}");
    assert_ne!(plan.fingerprint(), short.fingerprint());
    assert_ne!(plan.fingerprint(), PhaseShiftPlan::paper().fingerprint());
    // Thresholds a plan file could spell as nan or inf.
    let mut never = plan;
    never.max_code_residual = f32::NAN;
    assert!(matches!(
        never.validate(),
        Err(MicroPhaseShiftError::Threshold {
            field: "max_code_residual",
            ..
        })
    ));
    let mut ps = PhaseShiftPlan::paper();
    ps.min_modulation_dn = f32::INFINITY;
    assert!(ps
        .validate()
        .unwrap_err()
        .to_string()
        .starts_with("min_modulation_dn = inf"));
}

#[test]
fn line_scan_decodes_every_column_under_direct_light() {
    let plan = line_scan();
    plan.validate().unwrap();
    assert_eq!((plan.frame_count(), plan.pattern_count()), (770, 768));
    assert_eq!(
        plan.pattern_count(),
        ScanPlan::paper_bfsm().pattern_count(),
        "Fig. 13 compares the two with the same number of patterns"
    );
    for detector in [
        LineDetector::Auto,
        LineDetector::Gaussian,
        LineDetector::CentreOfMass { points: 5 },
    ] {
        let plan = LineScanPlan { detector, ..plan };
        let worst = worst_error_under_direct_light(&plan, 21);
        println!("LS {detector:?}, every column and 200 spots: worst {worst:.4} column");
        assert!(worst < 0.05, "{detector:?}: worst {worst}");
    }
}

#[test]
fn line_scan_locates_a_light_wider_than_three_columns() {
    // A camera pixel that sees about 6 projector columns (a small camera, a defocused
    // projector): a 3-point Gaussian on its flat top is off by tenths of a column, the
    // automatic detector takes the centre of mass of the whole run.
    let mut noise = Noise::new(25);
    let error = |detector: LineDetector, noise: &mut Noise| {
        let plan = LineScanPlan {
            detector,
            ..line_scan()
        };
        let mut worst: f64 = 0.0;
        for i in 0..100 {
            let centre = 20.3 + i as f64 * 7.13;
            // Six columns seen evenly, each blurred by the projector's optics.
            let px = (1..6).fold(Pixel::spot(centre - 2.5, 0.7, 500.0), |p, k| {
                p.plus(Pixel::spot(centre - 2.5 + k as f64, 0.7, 500.0))
            });
            let out = decode(&plan, &samples(&plan, &px, 1.0, noise));
            assert_eq!(out.candidates.len(), 1, "{detector:?} at {centre}: {out:?}");
            let (w, m) = px
                .lights
                .iter()
                .fold((0.0, 0.0), |(w, m), &(j, l)| (w + l, m + l * j as f64));
            let e = (out.candidates[0].column as f64 - m / w).abs();
            worst = worst.max(e);
        }
        worst
    };
    let (auto, gaussian) = (
        error(LineDetector::Auto, &mut noise),
        error(LineDetector::Gaussian, &mut noise),
    );
    println!(
        "LS, lights 6 columns wide: worst error auto {auto:.4}, 3-point Gaussian {gaussian:.4}"
    );
    assert!(auto < 0.05, "{auto}");
    assert!(gaussian > 2.0 * auto, "{gaussian}");
}

#[test]
fn line_scan_finds_a_mirrors_light_beside_the_direct_one() {
    // The same pixels as PS's failure: LS sees both lights as separate temporal peaks.
    let plan = line_scan();
    let mut noise = Noise::new(22);
    for i in 0..40 {
        let direct = 300.0 + i as f64 * 0.25;
        let mirror = 523.0 + i as f64 * 0.1;
        let px = Pixel::spot(direct, 0.7, 1500.0).plus(Pixel::spot(mirror, 0.7, 900.0));
        let out = decode(&plan, &samples(&plan, &px, 1.0, &mut noise));
        assert_eq!(out.candidates.len(), 2, "{out:?}");
        assert!((out.candidates[0].column as f64 - px.centroid_near(direct)).abs() < 0.1);
        assert!((out.candidates[1].column as f64 - px.centroid_near(mirror)).abs() < 0.1);
    }
}

#[test]
fn line_scan_finds_no_light_in_sensor_noise() {
    // A dark pixel with the paper plan's own sensor noise: 768 differences of two noisy
    // samples, none of them a light.
    let plan = LineScanPlan::paper();
    let sigma = fsm_core::noise::sample_noise_dn(&plan.sensor, 12, 0.0) as f64;
    let mut noise = Noise::new(23);
    let dark = Pixel {
        lights: vec![],
        ambient: 40.0,
    };
    for _ in 0..200 {
        let out = decode(&plan, &samples(&plan, &dark, sigma, &mut noise));
        assert!(out.candidates.is_empty(), "{out:?}");
    }
}

#[test]
fn bfsm_is_more_precise_than_line_scanning_with_as_many_patterns() {
    // Paper Fig. 13: the same 768 patterns, the same pixels and noise. A dim pixel (a light of
    // 200 DN spread by a defocused footprint), 4 DN of noise per sample: LS locates the peak
    // from three samples, BFSM from the inverse transform of all of them.
    let sensor = fsm_core::SensorNoise {
        read_noise_electrons: 4.0e6,
        ..SYNTHETIC_SENSOR
    };
    let mut bfsm = ScanPlan::paper_bfsm();
    bfsm.decoding.sensor = sensor;
    let mut tables = vec![0.0; fsm_core::Decoder::tables_len(&bfsm)];
    let decoder = fsm_core::Decoder::new(&bfsm, &mut tables).unwrap();
    let mut scratch = vec![0.0; fsm_core::Decoder::scratch_len(&bfsm)];
    let plan = LineScanPlan {
        sensor,
        ..LineScanPlan::paper()
    };
    let mut noise = Noise::new(24);
    let (mut ls, mut fsm, mut n) = (0.0f64, 0.0f64, 0usize);
    for i in 0..200 {
        let centre = 40.3 + i as f64 * 3.41;
        let px = Pixel::spot(centre, 0.8, 200.0);
        let truth = px.centroid_near(centre);
        let line = decode(&plan, &samples(&plan, &px, 4.0, &mut noise));
        let frames = px.samples(&bfsm, 4.0, 12, &mut noise);
        let row = fsm_core::Row {
            frames: &frames,
            width: 1,
            bit_depth: 12,
            column_limits: None,
        };
        let mut shifted = [PixelCandidates::<4>::new()];
        decoder
            .decode_row(&row, &mut scratch, &mut shifted)
            .unwrap();
        let shifted = &shifted[0];
        let (Some(l), Some(f)) = (line.strongest(), shifted.strongest()) else {
            panic!("spot {centre}: LS {line:?} BFSM {shifted:?}");
        };
        ls += (l.column as f64 - truth).powi(2);
        fsm += (f.column as f64 - truth).powi(2);
        n += 1;
    }
    let (ls, fsm) = ((ls / n as f64).sqrt(), (fsm / n as f64).sqrt());
    println!(
        "768 patterns, 4 DN noise: column RMS LS {ls:.4}, BFSM {fsm:.4} ({:.1}x)",
        ls / fsm
    );
    assert!(ls > 4.0 * fsm, "LS {ls} vs BFSM {fsm}");
}

#[test]
fn line_scan_plan_rules() {
    let plan = LineScanPlan::paper();
    let narrow = LineScanPlan {
        projector_columns: 2,
        ..plan
    };
    assert_eq!(
        narrow.validate(),
        Err(LineScanError::Columns {
            projector_columns: 2
        })
    );
    let even = LineScanPlan {
        detector: LineDetector::CentreOfMass { points: 4 },
        ..plan
    };
    let e = even.validate().unwrap_err();
    assert_eq!(e, LineScanError::DetectorPoints { points: 4 });
    assert!(e.to_string().contains("3, 5 or 7"), "{e}");
    let never = LineScanPlan {
        noise_factor: f32::NAN,
        ..plan
    };
    assert!(never.validate().is_err());
    let mut deaf = plan;
    deaf.sensor.full_scale_electrons = 0.0;
    assert_eq!(
        deaf.validate(),
        Err(LineScanError::Sensor {
            field: "sensor.full_scale_electrons",
            value: 0.0
        })
    );
    let fingerprints = [
        plan.fingerprint(),
        even.fingerprint(),
        line_scan().fingerprint(),
        ScanPlan::paper_bfsm().fingerprint(),
    ];
    for (i, a) in fingerprints.iter().enumerate() {
        for b in &fingerprints[i + 1..] {
            assert_ne!(a, b);
        }
    }
}

/// Widths of the runs of equal bits of pattern `bit` of `code` over the codewords, the first and
/// last (cut by the projector's edges) left out.
fn interior_runs(code: Code, bit: usize) -> Vec<usize> {
    let value = |k: usize| (code.patterns(k) >> bit) & 1;
    let mut runs = Vec::new();
    let mut start = 0;
    for k in 1..=CODEWORDS {
        if k == CODEWORDS || value(k) != value(k - 1) {
            runs.push(k - start);
            start = k;
        }
    }
    runs[1..runs.len() - 1].to_vec()
}

#[test]
fn the_ensembles_codes_have_their_stripe_widths_and_decode_every_codeword() {
    let stripes = |code: Code| {
        let runs: Vec<usize> = (0..code_ensemble::BITS)
            .flat_map(|b| interior_runs(code, b))
            .collect();
        (*runs.iter().min().unwrap(), *runs.iter().max().unwrap())
    };
    for code in CODES {
        let mut seen = vec![false; CODEWORDS];
        for k in 0..CODEWORDS {
            let word = code.patterns(k);
            assert!(
                !seen[word as usize],
                "{}: codeword {k} repeats",
                code.name()
            );
            seen[word as usize] = true;
            assert_eq!(code.index(word), k, "{}", code.name());
        }
        println!(
            "CE {}: stripes {:?} columns wide",
            code.name(),
            stripes(code)
        );
    }
    // The Gray codes change one bit from column to column, the long-run one cyclically too.
    for code in [Code::Gray, Code::LongRun] {
        for k in 1..CODEWORDS {
            assert_eq!((code.patterns(k) ^ code.patterns(k - 1)).count_ones(), 1);
        }
    }
    let lr = code_ensemble::LONG_RUN.codeword;
    assert_eq!((lr[0] ^ lr[CODEWORDS - 1]).count_ones(), 1);
    // The long-run code read cyclically: every bit keeps its value at least 8 codewords, also
    // across the wrap from the last codeword to the first.
    for bit in 0..code_ensemble::BITS {
        let changes: Vec<usize> = (0..CODEWORDS)
            .filter(|&k| ((lr[k] ^ lr[(k + 1) % CODEWORDS]) >> bit) & 1 == 1)
            .collect();
        assert!(
            changes.len() >= 2,
            "bit {bit} changes {} times",
            changes.len()
        );
        for (i, &k) in changes.iter().enumerate() {
            let next = changes[(i + 1) % changes.len()];
            let run = (next + CODEWORDS - k) % CODEWORDS;
            assert!(
                (8..=16).contains(&run),
                "bit {bit}: a run of {run} after codeword {k}"
            );
        }
    }
    assert_eq!(stripes(Code::Gray), (2, 512));
    // The narrowest stripe is 8 columns, the most 10 bits allow (Goddyn & Gvozdjak 2003); the
    // widest measures 16.
    assert_eq!(stripes(Code::LongRun).0, 8);
    assert!(
        stripes(Code::LongRun).1 <= 16,
        "{:?}",
        stripes(Code::LongRun)
    );
    // The XOR codes hold no stripe wider than their base's.
    assert_eq!(stripes(Code::Xor2), (1, 2));
    assert_eq!(stripes(Code::Xor4), (2, 4));
}

#[test]
fn the_long_run_codes_high_seed_has_the_properties_its_construction_needs() {
    use code_ensemble::{high_shift, high_symmetry, HIGH_OFFSET, HIGH_SEED};
    let n = HIGH_SEED.len();
    // The whole high walk: the seed, then its 7 copies with every bit moved by `high_shift`.
    let walk: Vec<u8> = (0..8 * n)
        .map(|k| (0..k / n).fold(HIGH_SEED[k % n], |b, _| high_shift(b)))
        .collect();
    // No bit changes twice within 4 steps, cyclically (so within 8 columns of the code).
    for k in 0..walk.len() {
        for d in 1..4 {
            assert_ne!(
                walk[k],
                walk[(k + d) % walk.len()],
                "steps {k} and {}",
                k + d
            );
        }
    }
    // The seed's walk from 0 ends at HIGH_OFFSET.
    let mut words = vec![0u8];
    for &b in HIGH_SEED.iter() {
        words.push(words.last().unwrap() ^ (1 << b));
    }
    assert_eq!(words[n], HIGH_OFFSET);
    // Words 32 steps apart lie in different orbits of the symmetry (8 words each).
    let orbit = |w: u8| {
        let mut o = vec![w];
        while let Some(&x) = o.last().filter(|&&x| high_symmetry(x) != w) {
            o.push(high_symmetry(x));
        }
        o
    };
    for w in 0..32u8 {
        assert_eq!(orbit(w).len(), 8, "{w:05b}");
    }
    for r in 0..n / 2 {
        assert!(!orbit(words[r]).contains(&words[r + n / 2]), "step {r}");
    }
}

#[test]
fn ce_decodes_every_column_under_direct_light() {
    for columns in [768u16, 256, 1024] {
        let plan = CodeEnsemblePlan::for_projector(columns);
        plan.validate().unwrap();
        assert_eq!(plan.frame_count(), 80);
        let mut noise = Noise::new(20);
        for c in 0..columns as u32 {
            let s = samples(&plan, &Pixel::column(c, 1500.0), 1.0, &mut noise);
            let got = decode(&plan, &s);
            let got = got.strongest().unwrap_or_else(|| panic!("column {c}"));
            assert_eq!(got.column, c as f32, "{columns} columns");
            assert!((got.amplitude - 1500.0).abs() < 5.0, "{got:?}");
        }
    }
    // A projector wider than the codes: a codeword covers about 1.9 columns, decoded as its
    // columns' centre.
    let plan = CodeEnsemblePlan::for_projector(1920);
    let mut noise = Noise::new(21);
    let mut worst: f64 = 0.0;
    for c in 0..1920u32 {
        let s = samples(&plan, &Pixel::column(c, 1500.0), 1.0, &mut noise);
        let got = decode(&plan, &s).strongest().expect("decoded").column as f64;
        worst = worst.max((got - c as f64).abs());
    }
    println!("CE on 1920 columns: worst error {worst} columns");
    assert!(worst <= 0.5, "{worst}");
}

#[test]
fn ce_keeps_the_direct_column_under_broad_indirect_light() {
    // Direct light at column c, plus indirect light spread evenly over 300 columns away from
    // it, 1.5 times the direct light in all: in a coarse Gray pattern the unlit half receives
    // more light than the lit one, so the conventional code's high bits flip; the XOR codes'
    // stripes split the broad light evenly between a pattern and its inverse.
    let plan = CodeEnsemblePlan::paper();
    let mut noise = Noise::new(22);
    let (mut gray_wrong, mut ensemble_wrong, mut silent, mut n) = (0, 0, 0, 0);
    for c in (20..360u32).step_by(3) {
        let mut px = Pixel::column(c, 1000.0);
        for j in 420..720u32 {
            px.lights.push((j, 1500.0 / 300.0));
        }
        let s = samples(&plan, &px, 1.0, &mut noise);
        n += 1;
        // The conventional Gray code alone: frames 0..20.
        let mut bits = 0u16;
        for b in 0..code_ensemble::BITS {
            bits |= ((s[2 * b] > s[2 * b + 1]) as u16) << b;
        }
        gray_wrong += (Code::Gray.index(bits) != c as usize) as usize;
        match decode(&plan, &s).strongest() {
            Some(got) => ensemble_wrong += (got.column != c as f32) as usize,
            None => silent += 1,
        }
    }
    println!(
        "CE under broad indirect light: Gray alone wrong at {gray_wrong} of {n}, \
         the ensemble wrong at {ensemble_wrong}, silent at {silent}"
    );
    assert!(gray_wrong * 2 > n, "{gray_wrong} of {n}");
    assert_eq!(ensemble_wrong, 0);
    assert!(silent * 20 < n, "{silent} of {n}");
}

#[test]
fn ce_reports_a_mirror_brighter_than_the_direct_light() {
    // A mirror's narrow light is a second column, not a broad glow: every code reads whichever
    // light is brighter. Weaker, the ensemble keeps the direct column; stronger, all four codes
    // agree on the mirror's column, a wrong point FSM's candidates avoid.
    let plan = CodeEnsemblePlan::paper();
    let mut noise = Noise::new(23);
    for (mirror_dn, expect_mirror) in [(600.0, false), (1500.0, true)] {
        for i in 0..20u32 {
            let (direct, mirror) = (100 + 7 * i, 523 + 5 * i);
            let px = Pixel::column(direct, 1000.0).plus(Pixel::column(mirror, mirror_dn));
            let got = decode(&plan, &samples(&plan, &px, 1.0, &mut noise));
            let want = if expect_mirror { mirror } else { direct };
            assert_eq!(got.strongest().map(|c| c.column), Some(want as f32));
        }
    }
}

#[test]
fn ce_leaves_dark_pixels_and_disagreement_without_a_column() {
    let plan = CodeEnsemblePlan::paper();
    let dark = Pixel {
        lights: vec![],
        ambient: 40.0,
    };
    let s = samples(&plan, &dark, 1.0, &mut Noise::new(24));
    assert!(decode(&plan, &s).candidates.is_empty());
    // Codes that point four ways: no column.
    assert_eq!(plan.agreed([10, 200, 400, 600]), None);
    // Two agreeing codes win, in the authors' precedence.
    assert_eq!(plan.agreed([10, 200, 400, 11]), Some(11));
    assert_eq!(plan.agreed([10, 11, 400, 600]), Some(11));
    assert_eq!(plan.agreed([10, 200, 11, 10]), Some(11));
    assert_eq!(plan.agreed([5, 5, 5, 5]), Some(5));
}

#[test]
fn ce_plan_rules() {
    let mut plan = CodeEnsemblePlan::paper();
    plan.validate().unwrap();
    plan.projector_columns = 1;
    assert_eq!(
        plan.validate(),
        Err(CodeEnsembleError::Columns {
            projector_columns: 1
        })
    );
    plan = CodeEnsemblePlan::paper();
    plan.agreement_columns = 300;
    assert!(plan
        .validate()
        .unwrap_err()
        .to_string()
        .contains("agreement_columns"));
    plan = CodeEnsemblePlan::paper();
    plan.min_contrast_dn = f32::NAN;
    assert!(plan
        .validate()
        .unwrap_err()
        .to_string()
        .contains("min_contrast_dn"));
    // The fingerprint follows every field and differs from the other methods'.
    let base = CodeEnsemblePlan::paper().fingerprint();
    assert_ne!(base, CodeEnsemblePlan::for_projector(767).fingerprint());
    assert_ne!(base, PhaseShiftPlan::paper().fingerprint());
    let mut other = CodeEnsemblePlan::paper();
    other.agreement_columns = 2;
    assert_ne!(base, other.fingerprint());
    // Both fingerprints name the long-run code: captures and decodes made before 2026-12-08,
    // with the code whose narrowest stripe was 7 columns, are refused. Those of the paper's plan
    // then were eaf07a70a2e75731 (the plan's bytes without the code's digest) and the pattern
    // fingerprint of the columns alone.
    assert_eq!(code_ensemble::long_run_digest(), 0xc5ee_fc81);
    assert_eq!(base, 0xe169_fddf_fb6a_0538);
    assert_ne!(base, 0xeaf0_7a70_a2e7_5731);
    let paper = CodeEnsemblePlan::paper();
    assert_ne!(
        paper.pattern_fingerprint(),
        fsm_core::wire::pattern_fingerprint(b"CE", &768u16.to_le_bytes())
    );
    let mut agreeing = paper;
    agreeing.agreement_columns = 2;
    assert_eq!(paper.pattern_fingerprint(), agreeing.pattern_fingerprint());
}

/// A point's quality is its light's amplitude over [`PixelDecoder::dark_amplitude_noise_dn`]:
/// that scale must be the scatter of the amplitude each decoder reports. Measured on a pixel
/// lit by one column through the synthetic sensor (1 DN read noise), 1,500 noisy captures.
#[test]
fn each_baselines_quality_scale_is_the_scatter_of_its_amplitude() {
    fn ratio<P: PixelDecoder>(name: &str, plan: &P, column: u32) -> f64 {
        let mut noise = Noise::new(31);
        let pixel = Pixel::column(column, 1600.0);
        let amplitudes: Vec<f64> = (0..1500)
            .map(|_| {
                let s = samples(plan, &pixel, 1.0, &mut noise);
                let got = decode(plan, &s);
                got.strongest()
                    .unwrap_or_else(|| panic!("{name}: no light"))
                    .amplitude as f64
            })
            .collect();
        let mean = amplitudes.iter().sum::<f64>() / amplitudes.len() as f64;
        let variance = amplitudes.iter().map(|a| (a - mean).powi(2)).sum::<f64>()
            / (amplitudes.len() - 1) as f64;
        let predicted = plan.dark_amplitude_noise_dn(12) as f64;
        let ratio = variance.sqrt() / predicted;
        println!(
            "{name}: amplitude {mean:.1} DN, scatter {:.3} DN, noise scale {predicted:.3} DN, ratio {ratio:.2}",
            variance.sqrt()
        );
        ratio
    }
    let ps = PhaseShiftPlan {
        sensor: SYNTHETIC_SENSOR,
        ..PhaseShiftPlan::paper()
    };
    let mps = MicroPhaseShiftPlan {
        sensor: SYNTHETIC_SENSOR,
        ..MicroPhaseShiftPlan::paper()
    };
    let ce = CodeEnsemblePlan {
        sensor: SYNTHETIC_SENSOR,
        ..CodeEnsemblePlan::paper()
    };
    // The three codes' amplitudes are linear in the samples: the scale is exact (measured
    // 1.01, 0.98, 1.00). Line scanning's peak stands over the lowest of its surroundings, a
    // minimum of several samples, which scatters less than one sample (measured 0.87).
    let ratios = [
        ("PS", ratio("PS", &ps, 301), 0.9..=1.1),
        ("MPS", ratio("MPS", &mps, 301), 0.9..=1.1),
        ("CE", ratio("CE", &ce, 301), 0.9..=1.1),
        ("LS", ratio("LS", &line_scan(), 301), 0.75..=1.0),
    ];
    for (name, r, expected) in ratios {
        assert!(expected.contains(&r), "{name}: ratio {r:.2}");
    }
}
