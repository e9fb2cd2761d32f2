//! Byte formats: round trips, and every kind of damage is reported, never returned as data.

use crate::support;

use fsm_core::wire::candidates::{self, CandidateHeader};
use fsm_core::wire::row_dump::{self, RecordedWith, RowDumpHeader};
use fsm_core::wire::{WireError, HEADER_LEN};
use fsm_core::{
    CodeEnsemblePlan, GroupCount, LineScanPlan, Method, MicroPhaseShiftPlan, PatternSequence,
    PhaseShiftPlan, PixelCandidates, ScanPlan, Window,
};
use proptest::prelude::*;
use support::{Harness, Noise, Pixel};

/// A record's bytes are the table in `wire::candidates`, field by field: written out here by
/// hand, not by the encoder, so that a faster encoder cannot move a byte unnoticed.
#[test]
fn a_candidate_record_has_the_documented_layout() {
    use fsm_core::{Candidate, Group, GroupSet, PixelFlags};
    let header = CandidateHeader {
        capacity: 4,
        plan_fingerprint: 0x0123_4567_89ab_cdef,
        width: 2,
        height: 10,
    };
    let mut lit = PixelCandidates::<4>::new();
    lit.flags = PixelFlags(0b0100);
    lit.noise_dn = 1.5;
    for (column, amplitude, block, group) in [
        (412.25f32, 900.5f32, 0x0102u16, Group::Two),
        (3.0, 7.0, 9, Group::One),
    ] {
        let c = Candidate {
            column,
            amplitude,
            groups: GroupSet(0b11),
            group,
            peak: 2,
            block,
        };
        lit.candidates.push(c).unwrap();
    }
    let dark = PixelCandidates::<4>::new();
    let mut expected = Vec::new();
    expected.extend_from_slice(&7u32.to_le_bytes());
    expected.extend_from_slice(&((6 + 2 * 16 + 6) as u32).to_le_bytes());
    expected.extend_from_slice(&[0b0100, 2]);
    expected.extend_from_slice(&1.5f32.to_le_bytes());
    expected.extend_from_slice(&412.25f32.to_le_bytes());
    expected.extend_from_slice(&900.5f32.to_le_bytes());
    expected.extend_from_slice(&[0x02, 0x01, 0b11, 2, 2, 0, 0, 0]);
    expected.extend_from_slice(&3.0f32.to_le_bytes());
    expected.extend_from_slice(&7.0f32.to_le_bytes());
    expected.extend_from_slice(&[9, 0, 0b11, 1, 2, 0, 0, 0]);
    expected.extend_from_slice(&[0, 0]);
    expected.extend_from_slice(&0.0f32.to_le_bytes());
    let crc = fsm_core::wire::crc32(&expected);
    expected.extend_from_slice(&crc.to_le_bytes());
    let mut out = vec![0xAAu8; header.max_record_len().unwrap()];
    let n = candidates::encode_record(&header, 7, &[lit, dark], &mut out).unwrap();
    assert_eq!(&out[..n], &expected[..]);
}

#[test]
fn plans_round_trip_through_their_canonical_bytes() {
    let mut hann = ScanPlan::paper_efsm(GroupCount::One).with_clean();
    hann.decoding.window = Window::Hann;
    hann.decoding.estimator = fsm_core::PeakEstimator::BlaisRioux8;
    let mut sensor = ScanPlan::paper_bfsm();
    sensor.decoding.sensor = fsm_core::SensorNoise {
        full_scale_electrons: 32_000.0,
        read_noise_electrons: 2.5,
    };
    for plan in [
        ScanPlan::paper_bfsm(),
        ScanPlan::paper_efsm(GroupCount::Two),
        ScanPlan::paper_bfsm().with_clean(),
        hann,
        sensor,
    ] {
        let bytes = plan.to_bytes();
        assert_eq!(ScanPlan::from_bytes(&bytes).unwrap(), plan);
        assert_eq!(
            ScanPlan::from_bytes(&bytes).unwrap().fingerprint(),
            plan.fingerprint()
        );
    }
    // Different plans, different fingerprints; a changed threshold is a different plan.
    let mut other = ScanPlan::paper_bfsm();
    other.decoding.relative_floor = 0.03;
    assert_ne!(other.fingerprint(), ScanPlan::paper_bfsm().fingerprint());
    assert_ne!(sensor.fingerprint(), ScanPlan::paper_bfsm().fingerprint());
    assert_ne!(
        ScanPlan::paper_bfsm().fingerprint(),
        ScanPlan::paper_efsm(GroupCount::Two).fingerprint()
    );
}

/// Version-1 plans (64 bytes, before the cosine search and the sensor fields) still read, as
/// the same plan with the default sensor, and keep the fingerprints files recorded with them
/// carry: these are the fingerprints the presets had before version 2 (commit 7af01ba).
#[test]
fn version_one_plans_read_and_keep_their_fingerprints() {
    use fsm_core::wire::plan::PLAN_V1_LEN;
    for (plan, recorded) in [
        (
            ScanPlan::paper_bfsm().with_clean(),
            0x5fc7_0cb9_5a70_a890u64,
        ),
        (
            ScanPlan::paper_efsm(GroupCount::Two).with_clean(),
            0xf4fe_54e3_d63f_2733,
        ),
        (
            ScanPlan::paper_efsm(GroupCount::One).with_local_maxima(),
            0x201e_675e_11bf_416c,
        ),
    ] {
        assert_eq!(plan.legacy_fingerprint(), Some(recorded));
        assert!(plan.has_fingerprint(recorded) && plan.has_fingerprint(plan.fingerprint()));
        let mut v1 = [0u8; PLAN_V1_LEN];
        v1.copy_from_slice(&plan.to_bytes()[..PLAN_V1_LEN]);
        v1[60..62].copy_from_slice(&1u16.to_le_bytes());
        assert_eq!(fsm_core::wire::crc64(&v1), recorded);
        assert_eq!(ScanPlan::from_bytes(&v1).unwrap(), plan);
    }
    // What version 1 cannot say has no legacy fingerprint, and version 1 cannot name it.
    let cosine = ScanPlan::paper_bfsm();
    assert_eq!(cosine.legacy_fingerprint(), None);
    assert!(!cosine.has_fingerprint(0x5fc7_0cb9_5a70_a890));
    let mut v1 = cosine.to_bytes();
    v1[60..62].copy_from_slice(&1u16.to_le_bytes());
    assert!(matches!(
        ScanPlan::from_bytes(&v1[..PLAN_V1_LEN]),
        Err(WireError::Field {
            field: "search",
            value: 2,
            ..
        })
    ));
    let mut sensor = ScanPlan::paper_bfsm().with_clean();
    sensor.decoding.sensor.read_noise_electrons = 3.0;
    assert_eq!(sensor.legacy_fingerprint(), None);
}

#[test]
fn invalid_plan_bytes_are_refused() {
    let good = ScanPlan::paper_efsm(GroupCount::Two).to_bytes();
    assert!(matches!(
        ScanPlan::from_bytes(&good[..70]),
        Err(WireError::Truncated {
            needed: 80,
            got: 70,
            ..
        })
    ));
    let mut b = good;
    b[75] = 1; // reserved tail
    assert!(matches!(
        ScanPlan::from_bytes(&b),
        Err(WireError::Field {
            field: "reserved",
            value: 1,
            ..
        })
    ));
    assert!(matches!(
        ScanPlan::from_bytes(&good[..63]),
        Err(WireError::Truncated {
            needed: 64,
            got: 63,
            ..
        })
    ));
    let mut b = good;
    b[14] = 7; // method
    assert!(matches!(
        ScanPlan::from_bytes(&b),
        Err(WireError::Field {
            field: "method",
            value: 7,
            ..
        })
    ));
    let mut b = good;
    b[16] = 63; // odd block width: decodes, then fails validation, naming the rule
    let e = ScanPlan::from_bytes(&b).unwrap_err();
    assert!(e.to_string().contains("cB must be even"), "{e}");
    // BFSM carries no EFSM fields: a non-zero block width or a guard of -0.0 (which would
    // re-encode as +0.0, found by fuzzing) is refused by name.
    let bfsm = ScanPlan::paper_bfsm().to_bytes();
    let mut b = bfsm;
    b[23] = 0x80;
    assert!(matches!(
        ScanPlan::from_bytes(&b),
        Err(WireError::Field {
            field: "border_guard",
            value: 0x8000_0000,
            ..
        })
    ));
    let mut b = bfsm;
    b[16] = 64;
    assert!(matches!(
        ScanPlan::from_bytes(&b),
        Err(WireError::Field {
            field: "block_width",
            value: 64,
            ..
        })
    ));
    let mut b = good;
    b[60] = 9; // version
    assert!(matches!(
        ScanPlan::from_bytes(&b),
        Err(WireError::Version {
            version: 9,
            supported: 2,
            ..
        })
    ));
}

fn dump(plan: &ScanPlan, width: u32, height: u32) -> (Vec<u8>, Vec<Vec<u16>>) {
    let header = RowDumpHeader::for_plan(plan, width, height, 12);
    let mut bytes = header.encode().to_vec();
    let mut rows = Vec::new();
    let mut noise = Noise::new(1);
    let mut record = vec![0u8; header.record_len().unwrap()];
    for y in 0..height {
        let pixels: Vec<Vec<u16>> = (0..width)
            .map(|x| Pixel::column(50 + 37 * x + 5 * y, 900.0).samples(plan, 1.0, 12, &mut noise))
            .collect();
        let samples = support::row_frames(&pixels);
        let n = row_dump::encode_record(&header, y, &samples, &mut record).unwrap();
        bytes.extend_from_slice(&record[..n]);
        rows.push(samples);
    }
    (bytes, rows)
}

#[test]
fn row_dumps_round_trip_and_name_their_damage() {
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let (bytes, rows) = dump(&plan, 3, 2);
    let header = RowDumpHeader::decode(&bytes).unwrap();
    header.check_plan(&plan).unwrap();
    let len = header.record_len().unwrap();
    assert_eq!(bytes.len(), HEADER_LEN + 2 * len);
    for (y, expected) in rows.iter().enumerate() {
        let record = row_dump::decode_record(&header, &bytes[HEADER_LEN + y * len..]).unwrap();
        assert_eq!(record.row, y as u32);
        let mut samples = vec![0u16; record.len()];
        record.copy_to(&mut samples).unwrap();
        assert_eq!(&samples, expected);
        // A range of samples (a frame's pixels 1..3 of a row slice), and one past the end.
        let mut two = [0u16; 2];
        record.copy_range_to(5 * 3 + 1, &mut two).unwrap();
        assert_eq!(two, [record.sample(5 * 3 + 1), record.sample(5 * 3 + 2)]);
        assert_eq!(&two[..], &expected[16..18]);
        let past = record
            .copy_range_to(record.len() - 1, &mut two)
            .unwrap_err();
        assert!(
            matches!(past, WireError::Truncated { needed, got, .. }
                if needed == 2 * record.len() + 2 && got == 2 * record.len()),
            "{past}"
        );
    }

    // The wrong plan.
    let e = header.check_plan(&ScanPlan::paper_bfsm()).unwrap_err();
    assert!(
        matches!(
            e,
            WireError::Field {
                field: "pattern_fingerprint",
                ..
            }
        ),
        "{e}"
    );
    // Every single-byte flip of the header is caught.
    for i in 0..HEADER_LEN {
        let mut b = bytes.clone();
        b[i] ^= 0x40;
        assert!(
            RowDumpHeader::decode(&b).is_err(),
            "flip at header byte {i} went unnoticed"
        );
    }
    // A flipped sample byte is a CRC error of that row; a flipped row index too.
    for offset in [0usize, 1, 4, 100, len - 5, len - 1] {
        let mut b = bytes.clone();
        b[HEADER_LEN + len + offset] ^= 0x01;
        let e = row_dump::decode_record(&header, &b[HEADER_LEN + len..]).unwrap_err();
        assert!(
            matches!(e, WireError::RecordCrc { .. }),
            "offset {offset}: {e}"
        );
        assert!(e.to_string().contains("corrupted"), "{e}");
    }
    // Truncated anywhere in the last record.
    for cut in [1usize, 7, len - 1] {
        let e = row_dump::decode_record(&header, &bytes[HEADER_LEN + len..bytes.len() - cut])
            .unwrap_err();
        assert_eq!(
            e,
            WireError::Truncated {
                what: "row dump",
                needed: len,
                got: len - cut
            }
        );
    }
    assert!(matches!(
        RowDumpHeader::decode(&bytes[..40]),
        Err(WireError::Truncated { .. })
    ));
}

#[test]
fn candidate_rows_round_trip_bit_for_bit() {
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let mut h = Harness::new(plan);
    let mut noise = Noise::new(3);
    let pixels: Vec<Vec<u16>> = [
        Pixel::column(100, 1200.0),
        Pixel::column(100, 1200.0).plus(Pixel::column(300, 700.0)),
        Pixel {
            lights: vec![],
            ambient: 30.0,
        },
        Pixel::column(5000, 0.0),
    ]
    .iter()
    .map(|p| p.samples(&plan, 1.0, 12, &mut noise))
    .collect();
    let decoded = h.decode::<8>(&pixels, 12);
    let header = CandidateHeader {
        capacity: 8,
        plan_fingerprint: plan.fingerprint(),
        width: 4,
        height: 10,
    };
    let hb = header.encode();
    assert_eq!(CandidateHeader::decode(&hb).unwrap(), header);
    let mut buf = vec![0u8; header.max_record_len().unwrap()];
    let n = candidates::encode_record(&header, 7, &decoded, &mut buf).unwrap();
    assert_eq!(n, candidates::record_len(&decoded));
    let record = candidates::decode_record(&header, &buf[..n]).unwrap();
    assert_eq!((record.row, record.len), (7, n));
    let mut back = vec![PixelCandidates::<8>::new(); 4];
    record.read_into(&header, &mut back).unwrap();
    for (a, b) in back.iter().zip(&decoded) {
        assert_eq!(a.flags, b.flags);
        assert_eq!(a.noise_dn.to_bits(), b.noise_dn.to_bits());
        assert_eq!(a.candidates.len(), b.candidates.len());
        for (x, y) in a.candidates.iter().zip(&b.candidates) {
            assert_eq!(x.column.to_bits(), y.column.to_bits());
            assert_eq!(x.amplitude.to_bits(), y.amplitude.to_bits());
            assert_eq!(
                (x.groups, x.group, x.peak, x.block),
                (y.groups, y.group, y.peak, y.block)
            );
        }
    }
    // Re-encoding what was read gives the same bytes.
    let mut again = vec![0u8; n];
    candidates::encode_record(&header, 7, &back, &mut again).unwrap();
    assert_eq!(again, buf[..n]);
    // Capacity limits what a pixel carries, not the writer's list type (found by fuzzing).
    let narrow = CandidateHeader {
        capacity: 4,
        ..header
    };
    let mut nb = vec![0u8; narrow.max_record_len().unwrap()];
    candidates::encode_record(&narrow, 7, &decoded, &mut nb).unwrap();
    let mut crowded = decoded.clone();
    while crowded[1].candidates.len() < 5 {
        let c = crowded[1].candidates[0];
        crowded[1].candidates.push(c).unwrap();
    }
    let e = candidates::encode_record(&narrow, 7, &crowded, &mut nb).unwrap_err();
    assert!(
        matches!(
            e,
            WireError::Field {
                field: "count",
                value: 5,
                ..
            }
        ),
        "{e}"
    );
    // A pixel with more candidates than the reader's capacity is an error, not a truncation.
    let mut small = vec![PixelCandidates::<1>::new(); 4];
    assert!(record.read_into(&header, &mut small).is_err());
    // Damage anywhere in the record is detected.
    for i in 0..n {
        let mut b = buf[..n].to_vec();
        b[i] ^= 0x10;
        assert!(
            candidates::decode_record(&header, &b).is_err(),
            "flip at byte {i} went unnoticed"
        );
    }
    for cut in 1..n {
        assert!(
            candidates::decode_record(&header, &buf[..n - cut]).is_err(),
            "cut {cut}"
        );
    }
}

/// Every frame of a sequence at every column, as bits: what a camera is shown.
fn frames_of(seq: &dyn PatternSequence) -> Vec<u32> {
    (0..seq.frame_count())
        .flat_map(|f| (0..seq.projector_columns() as u32).map(move |c| (f, c)))
        .map(|(f, c)| seq.frame_intensity(f, c).to_bits())
        .collect()
}

/// Checks that `changed` shows the same frames as `base` exactly when their pattern
/// fingerprints agree, and that its plan fingerprint differs (every change here changes
/// some setting).
fn assert_pattern_identity(what: &str, base: &dyn PatternSequence, changed: &dyn PatternSequence) {
    let same_frames = base.frame_count() == changed.frame_count()
        && base.projector_columns() == changed.projector_columns()
        && frames_of(base) == frames_of(changed);
    let same_fingerprint = base.pattern_fingerprint() == changed.pattern_fingerprint();
    assert_eq!(
        same_frames,
        same_fingerprint,
        "{what}: frames {} but pattern fingerprints {}",
        if same_frames { "equal" } else { "differ" },
        if same_fingerprint { "equal" } else { "differ" }
    );
    assert_ne!(
        base.fingerprint(),
        changed.fingerprint(),
        "{what}: plan fingerprint"
    );
    assert_ne!(base.pattern_fingerprint(), base.fingerprint(), "{what}");
}

#[test]
fn pattern_fingerprints_change_with_the_frames_and_with_nothing_else() {
    type Change = fn(&mut ScanPlan);
    // Decoder settings (the frames stay) and pattern fields (the frames change).
    let changes: [(&str, Change); 15] = [
        ("noise_factor", |p| p.decoding.noise_factor *= 1.5),
        ("max_peaks", |p| p.decoding.max_peaks -= 1),
        ("min_amplitude_dn", |p| p.decoding.min_amplitude_dn += 1.0),
        ("read noise", |p| {
            p.decoding.sensor.read_noise_electrons += 1.0
        }),
        ("CLEAN", |p| *p = p.with_clean()),
        ("local maxima", |p| *p = p.with_local_maxima()),
        ("transform_size", |p| p.transform_size *= 2),
        ("border_guard", |p| {
            if let Method::Efsm(b) = &mut p.method {
                b.border_guard *= 0.5;
            } else {
                p.decoding.merge_tolerance += 0.1;
            }
        }),
        ("offset PA", |p| p.levels.offset -= 0.05),
        ("modulation PB", |p| p.levels.amplitude -= 0.05),
        ("no white frame", |p| p.references.white = false),
        ("first harmonic", |p| p.band.first_harmonic += 1),
        ("fringe count", |p| p.band.count -= 1),
        ("period", |p| p.band.period_columns += 2),
        ("groups", |p| {
            if let Method::Efsm(b) = &mut p.method {
                b.groups = match b.groups {
                    GroupCount::One => GroupCount::Two,
                    GroupCount::Two => GroupCount::One,
                };
            } else {
                p.projector_columns -= 2;
            }
        }),
    ];
    let plans = [
        ScanPlan::bfsm(96),
        ScanPlan::efsm(256, 32, GroupCount::One),
        ScanPlan::efsm(256, 32, GroupCount::Two),
    ];
    for base in plans {
        for (name, change) in changes {
            let mut changed = base;
            change(&mut changed);
            assert_pattern_identity(&format!("{:?} / {name}", base.method), &base, &changed);
        }
    }
    // The baselines: decoder settings keep the pattern fingerprint, pattern fields change it.
    let ps = PhaseShiftPlan::paper();
    assert_pattern_identity(
        "PS min_modulation_dn",
        &ps,
        &PhaseShiftPlan {
            min_modulation_dn: 9.0,
            ..ps
        },
    );
    assert_pattern_identity(
        "PS steps",
        &ps,
        &PhaseShiftPlan {
            steps: ps.steps + 1,
            ..ps
        },
    );
    assert_pattern_identity(
        "PS bits",
        &ps,
        &PhaseShiftPlan {
            bits: ps.bits - 1,
            ..ps
        },
    );
    let mps = MicroPhaseShiftPlan::paper();
    assert_pattern_identity(
        "MPS max_code_residual",
        &mps,
        &MicroPhaseShiftPlan {
            max_code_residual: 0.3,
            ..mps
        },
    );
    let mut periods = mps.periods_columns;
    periods[0] += 1.0;
    assert_pattern_identity(
        "MPS period",
        &mps,
        &MicroPhaseShiftPlan {
            periods_columns: periods,
            ..mps
        },
    );
    let ls = LineScanPlan::paper();
    assert_pattern_identity(
        "LS noise_factor",
        &ls,
        &LineScanPlan {
            noise_factor: 7.0,
            ..ls
        },
    );
    assert_pattern_identity(
        "LS columns",
        &ls,
        &LineScanPlan {
            projector_columns: 512,
            ..ls
        },
    );
    let ce = CodeEnsemblePlan::paper();
    assert_pattern_identity(
        "CE agreement",
        &ce,
        &CodeEnsemblePlan {
            agreement_columns: 2,
            ..ce
        },
    );
    assert_pattern_identity(
        "CE columns",
        &ce,
        &CodeEnsemblePlan {
            projector_columns: 512,
            ..ce
        },
    );
    // The sensor of PS, MPS and CE only scales the points' quality: no candidate depends on
    // it, so candidate files decoded under another sensor still name the plan.
    let sensor = fsm_core::SensorNoise {
        read_noise_electrons: 20.0,
        ..Default::default()
    };
    let resensed: [(&dyn PatternSequence, &dyn PatternSequence); 3] = [
        (&ps, &PhaseShiftPlan { sensor, ..ps }),
        (&mps, &MicroPhaseShiftPlan { sensor, ..mps }),
        (&ce, &CodeEnsemblePlan { sensor, ..ce }),
    ];
    for (base, changed) in resensed {
        assert_eq!(base.identity(), changed.identity());
    }
}

#[test]
fn dumps_decode_under_other_decoder_settings_and_version_1_dumps_only_with_their_plan() {
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let mut retuned = plan;
    retuned.decoding.noise_factor *= 2.0;
    retuned.decoding.max_peaks -= 1;
    let other_patterns = ScanPlan::paper_efsm(GroupCount::One);

    let header = RowDumpHeader::for_plan(&plan, 3, 2, 12);
    let read = RowDumpHeader::decode(&header.encode()).unwrap();
    assert_eq!(
        read.recorded_with,
        RecordedWith::Patterns(plan.pattern_fingerprint())
    );
    read.check_plan(&plan).unwrap();
    read.check_plan(&retuned).unwrap();
    let e = read.check_plan(&other_patterns).unwrap_err();
    assert!(e.to_string().contains("pattern_fingerprint"), "{e}");

    // A version-1 header (as dumps were written before the split) names the whole plan.
    let v1 = RowDumpHeader {
        recorded_with: RecordedWith::Plan(plan.fingerprint()),
        ..header
    };
    let bytes = v1.encode();
    assert_eq!(u16::from_le_bytes([bytes[8], bytes[9]]), 1);
    let read = RowDumpHeader::decode(&bytes).unwrap();
    assert_eq!(read, v1);
    read.check_plan(&plan).unwrap();
    let e = read.check_plan(&retuned).unwrap_err();
    assert!(
        matches!(e, WireError::Field { field: "plan_fingerprint", value, .. } if value == plan.fingerprint()),
        "{e}"
    );

    // A version this build does not know is refused by number.
    let mut future = header.encode();
    future[8] = 3;
    let crc = fsm_core::wire::crc32(&future[..60]);
    future[60..].copy_from_slice(&crc.to_le_bytes());
    let e = RowDumpHeader::decode(&future).unwrap_err();
    assert_eq!(
        e,
        WireError::Version {
            what: "row dump",
            version: 3,
            supported: 2
        }
    );
    assert!(e.to_string().contains("versions 1 to 2"), "{e}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// No byte string makes a reader panic.
    #[test]
    fn readers_never_panic_on_arbitrary_bytes(bytes in prop::collection::vec(any::<u8>(), 0..400), width in 1u32..4) {
        let _ = ScanPlan::from_bytes(&bytes);
        let _ = RowDumpHeader::decode(&bytes);
        let _ = CandidateHeader::decode(&bytes);
        let dump_header = RowDumpHeader { bit_depth: 12, recorded_with: RecordedWith::Patterns(1), width, height: 4, frames: 3 };
        let _ = row_dump::decode_record(&dump_header, &bytes);
        let cand_header = CandidateHeader { capacity: 4, plan_fingerprint: 1, width, height: 4 };
        if let Ok(r) = candidates::decode_record(&cand_header, &bytes) {
            let mut out = vec![PixelCandidates::<4>::new(); width as usize];
            r.read_into(&cand_header, &mut out).unwrap();
        }
    }

    /// Payloads behind a correct CRC reach the structural checks: they decode or are refused,
    /// and whatever decodes re-encodes to the same bytes.
    #[test]
    fn crc_valid_candidate_records_are_checked_field_by_field(
        payload in prop::collection::vec(any::<u8>(), 0..120),
        width in 1u32..4,
    ) {
        let header = CandidateHeader { capacity: 4, plan_fingerprint: 1, width, height: 4 };
        let mut bytes = 2u32.to_le_bytes().to_vec();
        bytes.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        bytes.extend_from_slice(&payload);
        let crc = fsm_core::wire::crc32(&bytes);
        bytes.extend_from_slice(&crc.to_le_bytes());
        if let Ok(record) = candidates::decode_record(&header, &bytes) {
            let mut out = vec![PixelCandidates::<4>::new(); width as usize];
            record.read_into(&header, &mut out).unwrap();
            let mut again = vec![0u8; bytes.len()];
            let n = candidates::encode_record(&header, 2, &out, &mut again).unwrap();
            prop_assert_eq!(&again[..n], &bytes[..]);
        }
    }

    /// Valid headers decode to what was written.
    #[test]
    fn headers_round_trip(bit_depth in 1u8..=16, w in 1u32..5000, h in 1u32..5000, frames in 1u32..5000, fp in any::<u64>(), v1 in any::<bool>()) {
        let recorded_with = if v1 { RecordedWith::Plan(fp) } else { RecordedWith::Patterns(fp) };
        let header = RowDumpHeader { bit_depth, recorded_with, width: w, height: h, frames };
        prop_assert_eq!(RowDumpHeader::decode(&header.encode()).unwrap(), header);
    }
}
