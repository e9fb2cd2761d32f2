//! Every method's plan as bytes (`fsm_core::methods::wire`) and its row decoder
//! (`MethodDecoder`): round trips, every refusal by name, and the same candidates pixel by
//! pixel as for the whole row.

use fsm_core::baseline::line_scan::LineDetector;
use fsm_core::methods::wire::{
    CODE_ENSEMBLE_LEN, LINE_SCAN_LEN, MAX_PLAN_LEN, MICRO_PHASE_SHIFT_LEN, PHASE_SHIFT_LEN,
};
use fsm_core::wire::plan::{PLAN_LEN, PLAN_V1_LEN};
use fsm_core::wire::WireError;
use fsm_core::{
    CodeEnsemblePlan, Decoder, GroupCount, LineScanPlan, MethodDecoder, MethodPlan,
    MicroPhaseShiftPlan, PhaseShiftPlan, PixelCandidates, PixelDecoder, Row, ScanPlan, SensorNoise,
};

fn paper_plans() -> Vec<MethodPlan> {
    vec![
        ScanPlan::paper_bfsm().into(),
        ScanPlan::paper_efsm(GroupCount::One).into(),
        ScanPlan::paper_efsm(GroupCount::Two).into(),
        PhaseShiftPlan::paper().into(),
        MicroPhaseShiftPlan::paper().into(),
        LineScanPlan::paper().into(),
        CodeEnsemblePlan::paper().into(),
    ]
}

fn other_plans() -> Vec<MethodPlan> {
    let sensor = SensorNoise {
        full_scale_electrons: 12_000.0,
        read_noise_electrons: 3.5,
    };
    vec![
        ScanPlan::bfsm(256).into(),
        PhaseShiftPlan {
            steps: 4,
            min_modulation_dn: 3.5,
            sensor,
            ..PhaseShiftPlan::for_projector(300)
        }
        .into(),
        MicroPhaseShiftPlan {
            sensor,
            max_code_residual: 0.5,
            ..MicroPhaseShiftPlan::spread(256, 20.0, 6.0, 7)
        }
        .into(),
        LineScanPlan {
            projector_columns: 64,
            detector: LineDetector::CentreOfMass { points: 5 },
            noise_factor: 4.0,
            sensor,
        }
        .into(),
        LineScanPlan {
            detector: LineDetector::Gaussian,
            ..LineScanPlan::paper()
        }
        .into(),
        CodeEnsemblePlan {
            agreement_columns: 3,
            min_contrast_dn: 1.5,
            sensor,
            ..CodeEnsemblePlan::for_projector(2000)
        }
        .into(),
    ]
}

#[test]
fn every_methods_plan_round_trips_through_its_bytes() {
    for plan in paper_plans().into_iter().chain(other_plans()) {
        let bytes = plan.to_bytes();
        assert_eq!(bytes.len(), plan.wire_len(), "{plan:?}");
        assert!(bytes.len() <= MAX_PLAN_LEN);
        let back = MethodPlan::from_bytes(&bytes).unwrap();
        assert_eq!(back, plan);
        assert_eq!(back.to_bytes(), bytes);
        assert_eq!(back.fingerprint(), plan.fingerprint());
        assert_eq!(back.pattern_fingerprint(), plan.pattern_fingerprint());
        let mut out = [0xAAu8; 100];
        assert_eq!(plan.write_bytes(&mut out), Ok(bytes.len()));
        assert_eq!(&out[..bytes.len()], &bytes[..]);
        let mut short = [0u8; 10];
        assert!(matches!(
            plan.write_bytes(&mut short),
            Err(WireError::BufferTooSmall { got: 10, .. })
        ));
    }
    // The lengths the module documents; none is an FSM plan's.
    assert_eq!(
        [
            PHASE_SHIFT_LEN,
            MICRO_PHASE_SHIFT_LEN,
            LINE_SCAN_LEN,
            CODE_ENSEMBLE_LEN
        ],
        [32, 96, 32, 32]
    );
    assert_eq!(&PhaseShiftPlan::paper().to_bytes()[..4], b"PS\x01\x00");
    assert_eq!(&MicroPhaseShiftPlan::paper().to_bytes()[..4], b"MP\x01\x00");
    assert_eq!(&LineScanPlan::paper().to_bytes()[..4], b"LS\x01\x00");
    assert_eq!(&CodeEnsemblePlan::paper().to_bytes()[..4], b"CE\x01\x00");
}

#[test]
fn fsm_plans_decode_as_they_always_did() {
    for plan in [
        ScanPlan::paper_bfsm(),
        ScanPlan::paper_efsm(GroupCount::Two),
    ] {
        let bytes = plan.to_bytes();
        assert_eq!(bytes.len(), PLAN_LEN);
        assert_eq!(MethodPlan::from_bytes(&bytes), Ok(MethodPlan::Fsm(plan)));
        assert_eq!(MethodPlan::Fsm(plan).to_bytes().as_slice(), &bytes[..]);
        assert_eq!(MethodPlan::Fsm(plan).fingerprint(), plan.fingerprint());
        // 80 bytes that start with a baseline's tag are still read as an FSM plan.
        let mut tagged = bytes;
        tagged[..2].copy_from_slice(b"PS");
        assert_eq!(
            MethodPlan::from_bytes(&tagged),
            ScanPlan::from_bytes(&tagged).map(MethodPlan::Fsm)
        );
        // Version 1, 64 bytes: read as ScanPlan::from_bytes reads it.
        let mut v1 = [0u8; PLAN_V1_LEN];
        v1.copy_from_slice(&bytes[..PLAN_V1_LEN]);
        v1[60] = 1;
        assert_eq!(
            MethodPlan::from_bytes(&v1),
            ScanPlan::from_bytes(&v1).map(MethodPlan::Fsm)
        );
        // A damaged FSM plan keeps its own error.
        let mut bad = bytes;
        bad[19] = 1;
        assert_eq!(
            MethodPlan::from_bytes(&bad),
            ScanPlan::from_bytes(&bad).map(MethodPlan::Fsm)
        );
        assert!(MethodPlan::from_bytes(&bad).is_err());
    }
}

/// The field a refusal names.
fn field_of(e: WireError) -> &'static str {
    match e {
        WireError::Field { field, .. } | WireError::Rule { field, .. } => field,
        WireError::Truncated { .. } => "(truncated)",
        WireError::Magic { .. } => "(magic)",
        WireError::Version { .. } => "(version)",
        other => panic!("unexpected error {other:?}"),
    }
}

#[test]
fn bad_baseline_bytes_are_refused_by_name() {
    for plan in paper_plans().into_iter().skip(3) {
        let good = plan.to_bytes().as_slice().to_vec();
        let n = good.len();
        let refused = |bytes: &[u8]| {
            let e = MethodPlan::from_bytes(bytes).unwrap_err();
            assert!(!e.to_string().is_empty());
            e
        };
        // Length: short, long (through the method's own reader: the tag is known).
        assert!(matches!(
            refused(&good[..n - 1]),
            WireError::Truncated { needed, got, .. } if needed == n && got == n - 1
        ));
        let mut long = good.clone();
        long.push(0);
        assert_eq!(field_of(refused(&long)), "length");
        // Version.
        let mut v = good.clone();
        v[2] = 2;
        assert!(matches!(
            refused(&v),
            WireError::Version {
                version: 2,
                supported: 1,
                ..
            }
        ));
        // Every reserved byte, found by flipping each byte that is 0 and seeing which ones
        // no field claims: the trailing ones at least.
        for at in n - 8..n {
            let mut r = good.clone();
            r[at] = 7;
            assert_eq!(
                field_of(refused(&r)),
                "reserved",
                "{} byte {at}",
                plan.name()
            );
        }
        // Tag: the method's own reader says magic; the dispatcher names the tag.
        let mut t = good.clone();
        t[0] = b'X';
        assert_eq!(field_of(refused(&t)), "tag");
    }
    // Lengths that are nobody's.
    assert_eq!(
        field_of(MethodPlan::from_bytes(&[0; 40]).unwrap_err()),
        "length"
    );
    assert_eq!(
        field_of(MethodPlan::from_bytes(&[0; 81]).unwrap_err()),
        "length"
    );
    assert!(matches!(
        MethodPlan::from_bytes(b"PS"),
        Err(WireError::Truncated {
            needed: 32,
            got: 2,
            ..
        })
    ));
    assert!(matches!(
        PhaseShiftPlan::from_bytes(&LineScanPlan::paper().to_bytes()),
        Err(WireError::Magic { .. })
    ));
    // Reserved bytes inside the plans.
    let mut ps = PhaseShiftPlan::paper().to_bytes();
    ps[11] = 1;
    assert_eq!(
        field_of(PhaseShiftPlan::from_bytes(&ps).unwrap_err()),
        "reserved"
    );
    let mut mps = MicroPhaseShiftPlan::paper().to_bytes();
    mps[7] = 1;
    assert_eq!(
        field_of(MicroPhaseShiftPlan::from_bytes(&mps).unwrap_err()),
        "reserved"
    );
}

#[test]
fn invalid_baseline_plans_are_refused_naming_the_field() {
    let expect = |bytes: &[u8], field: &str| {
        let e = MethodPlan::from_bytes(bytes).unwrap_err();
        assert_eq!(field_of(e), field, "{e}");
        assert!(e.to_string().contains(field), "{e}");
    };
    let ps = PhaseShiftPlan::paper();
    expect(&PhaseShiftPlan { steps: 2, ..ps }.to_bytes(), "steps");
    expect(
        &PhaseShiftPlan {
            period_columns: 1,
            ..ps
        }
        .to_bytes(),
        "period_columns",
    );
    expect(&PhaseShiftPlan { bits: 3, ..ps }.to_bytes(), "bits");
    expect(
        &PhaseShiftPlan {
            min_modulation_dn: f32::NAN,
            ..ps
        }
        .to_bytes(),
        "min_modulation_dn",
    );
    let mps = MicroPhaseShiftPlan::paper();
    expect(
        &MicroPhaseShiftPlan {
            frequencies: 1,
            ..mps
        }
        .to_bytes(),
        "frequencies",
    );
    let mut repeated = mps;
    repeated.periods_columns[2] = repeated.periods_columns[1];
    expect(&repeated.to_bytes(), "periods_columns");
    // A period past `frequencies` must be 0 (to_bytes writes it so; these bytes do not).
    let mut unused = mps.to_bytes();
    let at = 16 + 4 * mps.frequencies as usize;
    unused[at..at + 4].copy_from_slice(&16.5f32.to_le_bytes());
    expect(&unused, "periods_columns");
    let mut negative_zero = mps.to_bytes();
    negative_zero[at + 3] = 0x80;
    expect(&negative_zero, "periods_columns");
    let ls = LineScanPlan::paper();
    expect(
        &LineScanPlan {
            projector_columns: 2,
            ..ls
        }
        .to_bytes(),
        "projector_columns",
    );
    expect(
        &LineScanPlan {
            detector: LineDetector::CentreOfMass { points: 4 },
            ..ls
        }
        .to_bytes(),
        "points",
    );
    expect(
        &LineScanPlan {
            noise_factor: 0.0,
            ..ls
        }
        .to_bytes(),
        "noise_factor",
    );
    let mut detector = ls.to_bytes();
    detector[6] = 3;
    expect(&detector, "detector");
    let mut points = ls.to_bytes();
    points[7] = 3; // Auto takes no points
    expect(&points, "points");
    let ce = CodeEnsemblePlan::paper();
    expect(
        &CodeEnsemblePlan {
            agreement_columns: 300,
            ..ce
        }
        .to_bytes(),
        "agreement_columns",
    );
    expect(
        &CodeEnsemblePlan {
            projector_columns: 1,
            ..ce
        }
        .to_bytes(),
        "projector_columns",
    );
    expect(
        &CodeEnsemblePlan {
            sensor: SensorNoise {
                full_scale_electrons: -1.0,
                ..ce.sensor
            },
            ..ce
        }
        .to_bytes(),
        "sensor.full_scale_electrons",
    );
}

/// A row of `width` pixels of `plan`, pixel `x` lit at column `4 + 2.5·x` (dark for the last).
fn row_of(plan: &MethodPlan, width: usize) -> Vec<u16> {
    let seq = plan.patterns();
    let frames = seq.frame_count();
    let mut out = vec![0u16; frames * width];
    for x in 0..width {
        let column = 4 + (5 * x / 2) as u32;
        for i in 0..frames {
            let lit = if x + 1 == width {
                0.0
            } else {
                seq.frame_intensity(i, column)
            };
            out[i * width + x] = (60.0 + 900.0 * lit).round() as u16;
        }
    }
    out
}

#[test]
fn any_methods_rows_decode_the_same_whole_and_pixel_by_pixel() {
    let plans = [
        MethodPlan::Fsm(ScanPlan::paper_efsm(GroupCount::Two)),
        PhaseShiftPlan::for_projector(64).into(),
        MicroPhaseShiftPlan::spread(64, 16.0, 4.0, 5).into(),
        LineScanPlan {
            projector_columns: 64,
            ..LineScanPlan::paper()
        }
        .into(),
        CodeEnsemblePlan::for_projector(64).into(),
    ];
    for plan in plans {
        let width = 9;
        let samples = row_of(&plan, width);
        let row = Row {
            frames: &samples,
            width,
            bit_depth: 12,
            column_limits: None,
        };
        let mut tables = vec![0.0; plan.tables_len()];
        let decoder = MethodDecoder::new(&plan, &mut tables).unwrap();
        assert_eq!(decoder.plan(), plan);
        let mut scratch = vec![0.0; plan.scratch_len_lanes::<{ fsm_core::decoder::MAX_LANES }>()];
        let mut whole = vec![PixelCandidates::<8>::new(); width];
        decoder.decode_row(&row, &mut scratch, &mut whole).unwrap();
        // The method's own decoder gives the same.
        let mut own = vec![PixelCandidates::<8>::new(); width];
        match plan {
            MethodPlan::Fsm(p) => {
                let mut t = vec![0.0; Decoder::tables_len(&p)];
                let d = Decoder::new(&p, &mut t).unwrap();
                d.decode_row(&row, &mut scratch, &mut own).unwrap()
            }
            MethodPlan::PhaseShift(p) => p.decode_row(&row, &mut own).unwrap(),
            MethodPlan::MicroPhaseShift(p) => p.decode_row(&row, &mut own).unwrap(),
            MethodPlan::LineScan(p) => p.decode_row(&row, &mut own).unwrap(),
            MethodPlan::CodeEnsemble(p) => p.decode_row(&row, &mut own).unwrap(),
        }
        assert_eq!(own, whole, "{}", plan.name());
        // Lit pixels have their column, the dark one nothing.
        for (x, p) in whole.iter().enumerate().take(width - 1) {
            let column = (4 + 5 * x / 2) as f32;
            assert!(
                p.candidates.iter().any(|c| (c.column - column).abs() < 0.6),
                "{} pixel {x}: {p:?}",
                plan.name()
            );
        }
        assert!(whole[width - 1].candidates.is_empty(), "{}", plan.name());
        // Pixel by pixel, and in lanes: the same bits.
        let mut lanes = vec![PixelCandidates::<8>::new(); width];
        decoder
            .decode_row_lanes::<4, 8>(&row, &mut scratch, &mut lanes)
            .unwrap();
        assert_eq!(lanes, whole);
        for (x, expected) in whole.iter().enumerate() {
            let mut one = PixelCandidates::<8>::new();
            decoder
                .decode_pixel(&row, x, &mut scratch, &mut one)
                .unwrap();
            assert_eq!(&one, expected);
        }
        let mut one = PixelCandidates::<8>::new();
        assert_eq!(
            decoder.decode_pixel(&row, width, &mut scratch, &mut one),
            Err(fsm_core::RowError::Pixel { x: width, width })
        );
        // A row dump of the plan's frames is the plan's, and not another's.
        let header = plan.row_dump_header(width as u32, 1, 12);
        assert_eq!(header.frames as usize, plan.frame_count());
        assert_eq!(plan.check_row_dump(&header), Ok(()));
        let other: MethodPlan = LineScanPlan::paper().into();
        assert!(other.check_row_dump(&header).is_err());
    }
}

#[test]
fn an_invalid_plan_builds_no_decoder() {
    let plan: MethodPlan = PhaseShiftPlan {
        steps: 1,
        ..PhaseShiftPlan::paper()
    }
    .into();
    let e = MethodDecoder::new(&plan, &mut []).unwrap_err();
    assert!(e.to_string().contains("steps"), "{e}");
    assert!(plan.check().is_err());
}
