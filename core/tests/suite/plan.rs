//! Scan plans: the paper's presets, every validation rule, the sequence order and the one
//! pattern function.

use fsm_core::plan::{MAX_KERNEL_TABLE_LEN, MIN_FRINGE_COUNT};
use fsm_core::Group;
use fsm_core::{GroupCount, Method, Pattern, PlanError, ScanPlan};

#[test]
fn paper_presets_have_the_papers_image_counts() {
    let bfsm = ScanPlan::paper_bfsm();
    bfsm.validate().unwrap();
    assert_eq!(bfsm.pattern_count(), 768);
    assert_eq!(bfsm.column_resolution(), 2.0, "Δc = 2cmax/M (eq. 9)");
    // f ∈ [1/1536, 1/2] in steps of 1/1536 = 1/(2·cmax) (eqs. 5, 7).
    assert_eq!(bfsm.frequency(0), 1.0 / 1536.0);
    assert_eq!(bfsm.frequency(767), 0.5);

    let one = ScanPlan::paper_efsm(GroupCount::One);
    one.validate().unwrap();
    assert_eq!(one.pattern_count(), 76, "64 fringes + 12 masks");
    let two = ScanPlan::paper_efsm(GroupCount::Two);
    two.validate().unwrap();
    assert_eq!(two.pattern_count(), 152, "2 × (64 fringes + 12 masks)");
    // Group 2 has 13 blocks (SPEC §3) but its two half blocks share one mask.
    assert_eq!(two.block_count(Group::Two), 13);
    assert_eq!(two.mask_count(Group::Two), 12);
    assert!(two.shares_edge_mask(Group::Two));
    // References come on top of the paper's count.
    assert_eq!(two.sequence_len(), 154);
}

#[test]
fn minimal_efsm_count_matches_the_papers_formula() {
    // §IV-B: 1 + 2·f_w·cB + ceil(cmax/cB) images per group.
    for (cmax, cb) in [
        (768u16, 32u16),
        (768, 64),
        (768, 96),
        (768, 128),
        (1024, 64),
    ] {
        let plan = ScanPlan::efsm(cmax, cb, GroupCount::Two);
        plan.validate().unwrap();
        let f_w = plan.frequency(plan.band.count - 1) - plan.frequency(0);
        let per_group =
            1 + (2.0 * f_w * cb as f64).round() as usize + (cmax as usize).div_ceil(cb as usize);
        assert_eq!(plan.pattern_count(), 2 * per_group, "cmax {cmax} cB {cb}");
    }
}

#[test]
fn group_two_shares_its_edge_mask_only_when_the_half_blocks_are_disjoint() {
    // cmax = a·cB + b. Group 2's last block covers local columns [0, r) and block 0 covers
    // [cB/2, cB): they can share one mask iff r ≤ cB/2, i.e. b = 0 or b > cB/2.
    // 700 = 10·64 + 60: last block of group 2 is [672, 700), local [0, 28).
    let plan = ScanPlan::efsm(700, 64, GroupCount::Two);
    plan.validate().unwrap();
    assert_eq!(plan.block_count(Group::One), 11);
    assert_eq!(plan.block_count(Group::Two), 12);
    assert!(plan.shares_edge_mask(Group::Two));
    assert_eq!(plan.mask_count(Group::Two), 11);
    // 720 = 11·64 + 16: last block of group 2 is [672, 720), local [0, 48): overlaps [32, 64).
    let plan = ScanPlan::efsm(720, 64, GroupCount::Two);
    plan.validate().unwrap();
    assert_eq!(plan.block_count(Group::Two), 12);
    assert!(!plan.shares_edge_mask(Group::Two));
    assert_eq!(plan.mask_count(Group::Two), 12);
    assert!(!plan.shares_edge_mask(Group::One));
}

fn rejects(plan: ScanPlan, expected: PlanError) {
    let err = plan.validate().unwrap_err();
    assert_eq!(err, expected);
    // Every message names the field or rule.
    assert!(!err.to_string().is_empty());
}

#[test]
fn validation_names_the_violated_rule() {
    let base = ScanPlan::paper_efsm(GroupCount::Two);
    let coding = base.block_coding().unwrap();

    let mut p = base;
    p.method = Method::Efsm(fsm_core::BlockCoding {
        block_width: 63,
        ..coding
    });
    rejects(p, PlanError::BlockWidthOdd { block_width: 63 });

    let mut p = base;
    p.method = Method::Efsm(fsm_core::BlockCoding {
        border_guard: 16.5,
        ..coding
    });
    rejects(
        p,
        PlanError::BorderGuard {
            border_guard: 16.5,
            max: 16.0,
        },
    );
    let msg = p.validate().unwrap_err().to_string();
    assert!(
        msg.contains("border_guard") && msg.contains("cB/4"),
        "{msg}"
    );

    let mut p = base;
    p.method = Method::Efsm(fsm_core::BlockCoding {
        border_guard: 0.0,
        ..coding
    });
    rejects(
        p,
        PlanError::BorderGuard {
            border_guard: 0.0,
            max: 16.0,
        },
    );

    let mut p = base;
    p.method = Method::Efsm(fsm_core::BlockCoding {
        block_width: 768,
        ..coding
    });
    rejects(
        p,
        PlanError::BlockWidthRange {
            block_width: 768,
            projector_columns: 768,
        },
    );

    // Δf above Nyquist (eq. 7): L < 2·span.
    let mut p = ScanPlan::paper_bfsm();
    p.band.period_columns = 1535;
    rejects(
        p,
        PlanError::FrequencyStepAboveNyquist {
            period_columns: 1535,
            span_columns: 768,
        },
    );
    let msg = p.validate().unwrap_err().to_string();
    assert!(msg.contains("Nyquist"), "{msg}");

    let mut p = ScanPlan::paper_bfsm();
    p.band.first_harmonic = 2;
    rejects(
        p,
        PlanError::LastFrequencyAboveHalf {
            last_harmonic: 769,
            period_columns: 1536,
        },
    );

    let mut p = ScanPlan::paper_bfsm();
    p.band.first_harmonic = 0;
    rejects(p, PlanError::FirstHarmonicZero);

    let mut p = ScanPlan::paper_bfsm();
    p.transform_size = 512;
    rejects(
        p,
        PlanError::TransformShorterThanFringes {
            transform_size: 512,
            count: 768,
        },
    );
    let msg = p.validate().unwrap_err().to_string();
    assert!(msg.contains("N >= M"), "{msg}");

    let mut p = ScanPlan::paper_bfsm();
    p.transform_size = 1000;
    rejects(
        p,
        PlanError::TransformSize {
            transform_size: 1000,
        },
    );
    p.transform_size = 8192;
    rejects(
        p,
        PlanError::TransformSize {
            transform_size: 8192,
        },
    );

    let mut p = ScanPlan::paper_bfsm();
    p.band.count = MIN_FRINGE_COUNT - 1;
    rejects(
        p,
        PlanError::TooFewFringes {
            count: MIN_FRINGE_COUNT - 1,
            min: MIN_FRINGE_COUNT,
        },
    );

    let mut p = ScanPlan::paper_bfsm();
    p.levels.offset = 0.4;
    rejects(
        p,
        PlanError::PatternLevels {
            offset: 0.4,
            amplitude: 0.5,
        },
    );

    // A fringe a ten-millionth deep: no signal, and subnormal floats in the decoder.
    let mut p = ScanPlan::paper_bfsm();
    p.levels.amplitude = 1e-7;
    rejects(
        p,
        PlanError::PatternLevels {
            offset: 0.5,
            amplitude: 1e-7,
        },
    );
    p.levels.amplitude = fsm_core::plan::MIN_LEVEL_AMPLITUDE;
    assert_eq!(p.validate(), Ok(()));

    let mut p = base;
    p.references.dark = false;
    rejects(p, PlanError::EfsmNeedsDarkReference);

    let mut p = ScanPlan::paper_bfsm();
    p.decoding.max_peaks = 0;
    rejects(p, PlanError::MaxPeaks { max_peaks: 0 });

    let mut p = ScanPlan::paper_bfsm();
    p.decoding.relative_floor = f32::NAN;
    assert!(matches!(
        p.validate(),
        Err(PlanError::DecodeThreshold {
            field: "relative_floor",
            ..
        })
    ));

    // 912 columns: L = 1824 = 2^5·57 needs 1024·57 table entries for CLEAN's kernel; the
    // cosine search needs no kernel.
    let mut p = ScanPlan::paper_bfsm();
    p.projector_columns = 912;
    p.band = fsm_core::FringeBand {
        period_columns: 1824,
        first_harmonic: 1,
        count: 912,
    };
    p.validate().unwrap();
    rejects(
        p.with_clean(),
        PlanError::KernelTable {
            entries: 1024 * 57,
            max: MAX_KERNEL_TABLE_LEN,
        },
    );

    // The cosine search's own rules.
    let mut p = ScanPlan::paper_bfsm();
    p.band.count = 700;
    rejects(
        p,
        PlanError::CosineNeedsFullBand {
            first_harmonic: 1,
            count: 700,
            period_columns: 1536,
        },
    );
    assert!(p.with_clean().validate().is_ok());
    let mut p = ScanPlan::paper_bfsm();
    p.references.white = false;
    rejects(p, PlanError::CosineNeedsReferences);
    let mut p = ScanPlan::paper_efsm(GroupCount::Two);
    p.decoding.window = fsm_core::Window::Hann;
    rejects(p, PlanError::CosineWindow);
    let mut p = ScanPlan::paper_efsm(GroupCount::Two);
    p.decoding.estimator = fsm_core::PeakEstimator::Gaussian;
    rejects(
        p,
        PlanError::CosineEstimator {
            estimator: fsm_core::PeakEstimator::Gaussian,
        },
    );
    let msg = p.validate().unwrap_err().to_string();
    assert!(
        msg.contains("decoding.estimator") && msg.contains("Deconvolution"),
        "{msg}"
    );
    let mut p = ScanPlan::paper_bfsm();
    p.decoding.sensor.full_scale_electrons = 0.0;
    rejects(p, PlanError::SensorFullScale { value: 0.0 });
    let mut p = ScanPlan::paper_bfsm();
    p.decoding.sensor.read_noise_electrons = -1.0;
    assert!(matches!(
        p.validate(),
        Err(PlanError::DecodeThreshold {
            field: "sensor.read_noise_electrons",
            ..
        })
    ));
}

#[test]
fn sequence_indices_round_trip() {
    for plan in [
        ScanPlan::paper_bfsm(),
        ScanPlan::paper_efsm(GroupCount::One),
        ScanPlan::paper_efsm(GroupCount::Two),
        ScanPlan::efsm(700, 64, GroupCount::Two),
        ScanPlan::efsm(720, 64, GroupCount::Two),
    ] {
        let mut seen = 0;
        for (i, p) in plan.sequence().enumerate() {
            assert_eq!(plan.index_of(p), Some(i), "{p:?}");
            seen += 1;
        }
        assert_eq!(seen, plan.sequence_len());
        assert_eq!(plan.pattern(plan.sequence_len()), None);
        assert_eq!(plan.pattern(0), Some(Pattern::Dark));
        assert_eq!(plan.pattern(1), Some(Pattern::White));
        assert_eq!(
            plan.pattern(2),
            Some(Pattern::Fringe {
                group: Group::One,
                index: 0
            })
        );
    }
    let bfsm = ScanPlan::paper_bfsm();
    assert_eq!(
        bfsm.index_of(Pattern::Mask {
            group: Group::One,
            index: 0
        }),
        None
    );
    assert_eq!(
        bfsm.index_of(Pattern::Fringe {
            group: Group::Two,
            index: 0
        }),
        None
    );
}

#[test]
fn fringes_follow_eq_4_and_eq_14() {
    let bfsm = ScanPlan::paper_bfsm();
    for m in [0u16, 1, 100, 767] {
        for c in [0u32, 1, 37, 400, 767] {
            let expected = 0.5 + 0.5 * (std::f64::consts::TAU * bfsm.frequency(m) * c as f64).cos();
            let got = bfsm.intensity(
                Pattern::Fringe {
                    group: Group::One,
                    index: m,
                },
                c,
            ) as f64;
            assert!(
                (got - expected).abs() < 1e-6,
                "m {m} c {c}: {got} vs {expected}"
            );
        }
    }
    // EFSM: the fringe repeats every cB columns, group 2 shifted by cB/2 (eq. 14, SPEC §3).
    let efsm = ScanPlan::paper_efsm(GroupCount::Two);
    for m in [0u16, 5, 63] {
        for c in [0u32, 10, 63, 64, 100, 767] {
            let g1 = efsm.intensity(
                Pattern::Fringe {
                    group: Group::One,
                    index: m,
                },
                c,
            );
            let g2 = efsm.intensity(
                Pattern::Fringe {
                    group: Group::Two,
                    index: m,
                },
                c,
            );
            let local1 = (c % 64) as f64;
            let local2 = ((c + 32) % 64) as f64;
            let e1 = 0.5 + 0.5 * (std::f64::consts::TAU * efsm.frequency(m) * local1).cos();
            let e2 = 0.5 + 0.5 * (std::f64::consts::TAU * efsm.frequency(m) * local2).cos();
            assert!((g1 as f64 - e1).abs() < 1e-6 && (g2 as f64 - e2).abs() < 1e-6);
        }
    }
    assert_eq!(bfsm.intensity(Pattern::Dark, 5), 0.0);
    assert_eq!(bfsm.intensity(Pattern::White, 5), 1.0);
    assert_eq!(
        bfsm.intensity(Pattern::White, 768),
        0.0,
        "outside the projector"
    );
}

#[test]
fn masks_light_exactly_their_blocks() {
    for plan in [
        ScanPlan::efsm(700, 64, GroupCount::Two),
        ScanPlan::efsm(720, 64, GroupCount::Two),
    ] {
        for group in plan.groups() {
            for c in 0..plan.projector_columns as u32 {
                let n = (0..plan.mask_count(group))
                    .filter(|&i| plan.intensity(Pattern::Mask { group, index: i }, c) == 1.0)
                    .count();
                assert_eq!(
                    n, 1,
                    "cmax {} column {c} group {group:?}",
                    plan.projector_columns
                );
            }
        }
    }
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    for group in plan.groups() {
        for mask in 0..plan.mask_count(group) {
            let blocks = plan.mask_blocks(group, mask);
            for c in 0..768u32 {
                let (block, _) = plan.block_of(c, group);
                let lit = plan.intensity(Pattern::Mask { group, index: mask }, c) == 1.0;
                assert_eq!(
                    lit,
                    blocks.contains(block),
                    "group {group:?} mask {mask} column {c}"
                );
            }
        }
    }
    // The shared edge mask of group 2 lights columns 0..32 and 736..768.
    let edge = Pattern::Mask {
        group: Group::Two,
        index: 0,
    };
    let lit: Vec<u32> = (0..768)
        .filter(|&c| plan.intensity(edge, c) == 1.0)
        .collect();
    assert_eq!(lit, (0..32).chain(736..768).collect::<Vec<_>>());
    // Every column is lit by exactly one mask of each group.
    for group in plan.groups() {
        for c in 0..768u32 {
            let n = (0..plan.mask_count(group))
                .filter(|&i| plan.intensity(Pattern::Mask { group, index: i }, c) == 1.0)
                .count();
            assert_eq!(n, 1, "column {c} group {group:?}");
        }
    }
}

#[test]
fn block_and_column_round_trip_eqs_19_20() {
    let plan = ScanPlan::efsm(768, 32, GroupCount::Two);
    for group in plan.groups() {
        for c in 0..768u32 {
            let (block, local) = plan.block_of(c, group);
            assert_eq!(plan.column_of(local as f32, block, group), c as f32);
        }
    }
    // SPEC §3 worked example: 694.9 is c̃ 22.9 in block 21 (group 1), c̃ 6.9 in block 22 (group 2).
    assert!((plan.column_of(22.9, 21, Group::One) - 694.9).abs() < 1e-3);
    assert!((plan.column_of(6.9, 22, Group::Two) - 694.9).abs() < 1e-3);
}
