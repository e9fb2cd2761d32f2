//! The phase-shift baseline: exact on direct light, wrong under interreflection (paper §III-B).

use crate::support;

use fsm_core::phase_shift::{PhaseShiftError, PhaseShiftPattern};
use fsm_core::{ColumnRange, PatternSequence, PhaseShiftPlan, PixelCandidates, ScanPlan};
use support::{Noise, Pixel};

/// 12-bit samples of a pixel under every frame of `plan`, with `sigma` DN noise.
fn samples(plan: &PhaseShiftPlan, pixel: &Pixel, sigma: f64, noise: &mut Noise) -> Vec<u16> {
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

fn decode(plan: &PhaseShiftPlan, s: &[u16]) -> PixelCandidates<2> {
    let mut out = PixelCandidates::<2>::new();
    plan.decode_pixel(
        |i| s[i],
        4095,
        &ColumnRange::projector(plan.projector_columns),
        &mut out,
    );
    out
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

#[test]
fn rows_decode_like_their_pixels() {
    let plan = PhaseShiftPlan::paper();
    let mut noise = Noise::new(4);
    let pixels: Vec<Vec<u16>> = (0..5)
        .map(|i| samples(&plan, &Pixel::column(100 + 97 * i, 1500.0), 1.0, &mut noise))
        .collect();
    let frames = support::row_frames(&pixels);
    let row = fsm_core::Row {
        frames: &frames,
        width: 5,
        bit_depth: 12,
        column_limits: None,
    };
    let mut out = vec![PixelCandidates::<2>::new(); 5];
    plan.decode_row(&row, &mut out).unwrap();
    for (p, s) in out.iter().zip(&pixels) {
        assert_eq!(p, &decode(&plan, s));
    }
    let short = fsm_core::Row {
        frames: &frames[1..],
        ..row
    };
    assert!(plan.decode_row(&short, &mut out).is_err());
}
