//! No input makes the decoder panic, saturated pixels are flagged, and malformed rows are
//! refused with an error that says what is wrong.

use crate::support;

use fsm_core::{
    ColumnRange, Decoder, DecoderError, GroupCount, PixelCandidates, PixelFlags, PlanError, Row,
    RowError, ScanPlan, Window,
};
use proptest::prelude::*;
use support::{Harness, Noise, Pixel};

/// The cosine search's presets, and CLEAN with and without a window.
fn plans() -> Vec<ScanPlan> {
    let mut hann = ScanPlan::paper_efsm(GroupCount::Two).with_clean();
    hann.decoding.window = Window::Hann;
    vec![
        ScanPlan::paper_bfsm(),
        ScanPlan::paper_efsm(GroupCount::Two),
        hann,
        ScanPlan::efsm(700, 32, GroupCount::Two),
        ScanPlan::paper_bfsm().with_clean(),
    ]
}

#[test]
fn degenerate_rows_decode_to_nothing() {
    for plan in plans() {
        let mut h = Harness::new(plan);
        let n = plan.sequence_len();
        let rows = vec![
            vec![0u16; n],
            vec![777u16; n],
            vec![4095u16; n],
            vec![65535u16; n],
        ];
        let out = h.decode::<8>(&rows, 12);
        for (i, p) in out.iter().enumerate() {
            assert!(
                p.candidates.is_empty(),
                "{:?} row {i}: {:?}",
                plan.method,
                p.candidates
            );
            assert!(p.noise_dn.is_finite());
        }
        // 4095 is the saturation code of a 12-bit sensor, and 65535 above it.
        assert!(!out[1].flags.contains(PixelFlags::SATURATED));
        assert!(out[2].flags.contains(PixelFlags::SATURATED));
        assert!(out[3].flags.contains(PixelFlags::SATURATED));
    }
}

#[test]
fn clipped_fringes_are_flagged_saturated() {
    let plan = ScanPlan::paper_bfsm();
    let mut h = Harness::new(plan);
    let bright = Pixel::column(300, 5000.0); // peaks at 5020 DN, a 12-bit sensor clips at 4095
    let s = bright.samples(&plan, 0.0, 12, &mut Noise::new(1));
    let out: PixelCandidates<8> = h.decode_one(s, 12);
    assert!(out.flags.contains(PixelFlags::SATURATED));
    // Still decoded: the clipped pixel's column is there, flagged for the host to judge.
    assert!(
        out.candidates
            .iter()
            .any(|c| (c.column - 300.0).abs() < 0.1),
        "{:?}",
        out.candidates
    );
}

#[test]
fn too_many_candidates_keep_the_strongest_and_flag_truncation() {
    let plan = ScanPlan::paper_efsm(GroupCount::One);
    let mut h = Harness::new(plan);
    // Three columns in three different blocks: 3 peaks × 3 lit blocks = 9 candidates.
    let pixel = Pixel::column(100, 1500.0)
        .plus(Pixel::column(300, 1000.0))
        .plus(Pixel::column(530, 600.0));
    let s = pixel.samples(&plan, 1.0, 12, &mut Noise::new(2));
    let all: PixelCandidates<16> = h.decode_one(s.clone(), 12);
    assert_eq!(all.candidates.len(), 9);
    assert!(!all.flags.contains(PixelFlags::TRUNCATED));
    let few: PixelCandidates<4> = h.decode_one(s, 12);
    assert!(few.flags.contains(PixelFlags::TRUNCATED));
    assert_eq!(
        &few.candidates[..],
        &all.candidates[..4],
        "the four strongest, in order"
    );
}

#[test]
fn malformed_rows_are_refused_with_their_reason() {
    let plan = ScanPlan::paper_bfsm();
    let mut tables = vec![0.0; Decoder::tables_len(&plan)];
    let decoder = Decoder::new(&plan, &mut tables).unwrap();
    let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
    let frames = vec![0u16; plan.sequence_len() * 3];
    let mut out = vec![PixelCandidates::<4>::new(); 3];
    let ok = Row {
        frames: &frames,
        width: 3,
        bit_depth: 12,
        column_limits: None,
    };
    decoder.decode_row(&ok, &mut scratch, &mut out).unwrap();

    let short = Row {
        frames: &frames[1..],
        ..ok
    };
    let e = decoder
        .decode_row(&short, &mut scratch, &mut out)
        .unwrap_err();
    assert_eq!(
        e,
        RowError::FramesLength {
            expected: 770 * 3,
            actual: 770 * 3 - 1
        }
    );
    assert!(
        e.to_string().contains("2309") && e.to_string().contains("2310"),
        "{e}"
    );

    let bad_bits = Row {
        bit_depth: 17,
        ..ok
    };
    assert_eq!(
        decoder
            .decode_row(&bad_bits, &mut scratch, &mut out)
            .unwrap_err(),
        RowError::BitDepth { bit_depth: 17 }
    );
    let empty = Row {
        frames: &[],
        width: 0,
        ..ok
    };
    assert_eq!(
        decoder
            .decode_row(&empty, &mut scratch, &mut out)
            .unwrap_err(),
        RowError::EmptyRow
    );
    let limits = [ColumnRange::projector(768)];
    let bad_limits = Row {
        column_limits: Some(&limits),
        ..ok
    };
    assert_eq!(
        decoder
            .decode_row(&bad_limits, &mut scratch, &mut out)
            .unwrap_err(),
        RowError::ColumnLimitsLength {
            expected: 3,
            actual: 1
        }
    );
    assert_eq!(
        decoder
            .decode_row(&ok, &mut scratch, &mut out[..2])
            .unwrap_err(),
        RowError::OutputLength {
            expected: 3,
            actual: 2
        }
    );
    assert_eq!(
        decoder
            .decode_row(&ok, &mut scratch[..10], &mut out)
            .unwrap_err(),
        RowError::ScratchTooShort {
            needed: Decoder::scratch_len(&plan),
            got: 10
        }
    );
    assert_eq!(
        decoder
            .decode_pixel(&ok, 3, &mut scratch, &mut out[0])
            .unwrap_err(),
        RowError::Pixel { x: 3, width: 3 }
    );

    let mut short_tables = vec![0.0; 10];
    assert_eq!(
        Decoder::new(&plan, &mut short_tables).unwrap_err(),
        DecoderError::TablesTooShort {
            needed: Decoder::tables_len(&plan),
            got: 10
        }
    );
    let mut bad = plan;
    bad.transform_size = 100;
    assert_eq!(
        Decoder::new(&bad, &mut tables).unwrap_err(),
        DecoderError::Plan(PlanError::TransformSize {
            transform_size: 100
        })
    );
}

#[test]
fn tables_built_once_serve_many_decoders_of_their_plan_only() {
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let mut tables = vec![0.0; Decoder::tables_len(&plan)];
    Decoder::build_tables(&plan, &mut tables).unwrap();
    let pixel = Pixel::column(333, 1200.0).samples(&plan, 1.0, 12, &mut Noise::new(9));
    let row = Row {
        frames: &pixel,
        width: 1,
        bit_depth: 12,
        column_limits: None,
    };
    let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
    let (mut a, mut b) = (PixelCandidates::<8>::new(), PixelCandidates::<8>::new());
    Decoder::from_tables(&plan, &tables)
        .unwrap()
        .decode_pixel(&row, 0, &mut scratch, &mut a)
        .unwrap();
    Decoder::from_tables(&plan, &tables)
        .unwrap()
        .decode_pixel(&row, 0, &mut scratch, &mut b)
        .unwrap();
    assert_eq!(a, b);
    assert!((a.strongest().unwrap().column - 333.0).abs() < 0.02);
    // The same tables read with another plan (here: one threshold differs) are refused.
    let mut other = plan;
    other.decoding.relative_floor = 0.05;
    assert_eq!(
        Decoder::from_tables(&other, &tables).unwrap_err(),
        DecoderError::TablesOfAnotherPlan
    );
}

#[test]
fn column_limits_drop_candidates_outside_them() {
    let plan = ScanPlan::paper_efsm(GroupCount::One);
    let mut tables = vec![0.0; Decoder::tables_len(&plan)];
    let decoder = Decoder::new(&plan, &mut tables).unwrap();
    let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
    let pixel = Pixel::column(100, 1500.0).plus(Pixel::column(300, 1000.0));
    let s = pixel.samples(&plan, 1.0, 12, &mut Noise::new(3));
    let limits = [ColumnRange {
        first: 80.0,
        last: 200.0,
    }];
    let row = Row {
        frames: &s,
        width: 1,
        bit_depth: 12,
        column_limits: Some(&limits),
    };
    let mut out = PixelCandidates::<8>::new();
    decoder
        .decode_pixel(&row, 0, &mut scratch, &mut out)
        .unwrap();
    let mut columns: Vec<f32> = out.candidates.iter().map(|c| c.column.round()).collect();
    columns.sort_by(f32::total_cmp);
    // Peaks at c̃ 36 and 44, blocks 1 and 4: of 100, 108, 292, 300 only the first two remain.
    assert_eq!(columns, vec![100.0, 108.0]);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    /// Arbitrary samples of any bit depth never panic and give finite candidates.
    #[test]
    fn arbitrary_rows_never_panic(
        plan_index in 0usize..5,
        seed in any::<u64>(),
        bits in 1u8..=16,
        width in 1usize..4,
        kind in 0u8..4,
    ) {
        let plan = plans()[plan_index];
        let mut noise = Noise::new(seed);
        let max = (1u32 << bits) - 1;
        let frames: Vec<u16> = (0..plan.sequence_len() * width)
            .map(|i| match kind {
                0 => (noise.uniform() * 65536.0) as u16,
                1 => (noise.uniform() * (max + 1) as f64) as u16,
                2 => if noise.uniform() < 0.5 { 0 } else { max as u16 },
                _ => ((i % 7) as u32 * max / 6) as u16,
            })
            .collect();
        let mut tables = vec![0.0; Decoder::tables_len(&plan)];
        let decoder = Decoder::new(&plan, &mut tables).unwrap();
        let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
        let mut out = vec![PixelCandidates::<8>::new(); width];
        let row = Row { frames: &frames, width, bit_depth: bits, column_limits: None };
        decoder.decode_row(&row, &mut scratch, &mut out).unwrap();
        for p in &out {
            prop_assert!(p.noise_dn.is_finite());
            for c in &p.candidates {
                prop_assert!(c.column.is_finite() && c.amplitude.is_finite() && c.amplitude > 0.0);
                prop_assert!(c.column >= -0.5 && c.column <= plan.projector_columns as f32 - 0.5);
            }
        }
    }
}
