//! Row dumps on disk: round trip, and the right error — naming the record and the row — for
//! flipped bytes, truncation, padding, duplicates and a foreign plan; arbitrary bytes never
//! panic the reader.

use crate::support;

use std::io::Cursor;
use std::path::Path;

use fsm_core::wire::row_dump::{RecordedWith, RowDumpHeader};
use fsm_core::wire::{WireError, HEADER_LEN};
use fsm_core::{GroupCount, ScanPlan};
use fsm_io::capture::{BadRows, Capture};
use fsm_io::decode::{self, DecodeOptions};
use fsm_io::dump::{DumpError, DumpReader, DumpWriter};
use fsm_io::progress::Progress;
use fsm_io::Error;
use proptest::prelude::*;

/// A small dump of `plan` with deterministic samples, rows written in the order given.
fn dump_bytes(plan: &ScanPlan, width: u32, height: u32, order: &[u32]) -> (Vec<u8>, Vec<Vec<u16>>) {
    let header = RowDumpHeader::for_plan(plan, width, height, 12);
    let row_len = header.samples_per_row();
    let rows: Vec<Vec<u16>> = (0..height)
        .map(|y| {
            (0..row_len)
                .map(|i| ((i as u32 * 7919 + y * 104729) % 4096) as u16)
                .collect()
        })
        .collect();
    let mut writer = DumpWriter::new(Vec::new(), header).unwrap();
    for &y in order {
        writer.write_row(y, &rows[y as usize]).unwrap();
    }
    (writer.finish().unwrap(), rows)
}

fn read_all(bytes: &[u8]) -> Result<Vec<(u32, Vec<u16>)>, DumpError> {
    let mut reader = DumpReader::new(Cursor::new(bytes), Path::new("test.dump"))?;
    let mut out = Vec::new();
    let mut samples = Vec::new();
    while let Some(row) = reader.next_row(&mut samples)? {
        out.push((row, std::mem::take(&mut samples)));
    }
    Ok(out)
}

fn efsm() -> ScanPlan {
    ScanPlan::paper_efsm(GroupCount::One)
}

#[test]
fn rows_round_trip_in_any_order() {
    let plan = efsm();
    let order = [3, 0, 4, 1, 2];
    let (bytes, rows) = dump_bytes(&plan, 9, 5, &order);
    assert_eq!(
        bytes.len(),
        HEADER_LEN + 5 * (8 + 2 * 9 * plan.sequence_len())
    );
    let read = read_all(&bytes).unwrap();
    assert_eq!(read.len(), 5);
    for ((row, samples), &expected_row) in read.iter().zip(&order) {
        assert_eq!(*row, expected_row);
        assert_eq!(samples, &rows[*row as usize]);
    }
    // The same through a file, with the up-front length check.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scan.dump");
    std::fs::write(&path, &bytes).unwrap();
    let reader = DumpReader::open(&path).unwrap();
    reader.check(plan, Some(12)).unwrap();
}

#[test]
fn a_flipped_sample_byte_is_a_crc_error_naming_the_row() {
    let plan = efsm();
    let (bytes, _) = dump_bytes(&plan, 9, 5, &[0, 1, 2, 3, 4]);
    let record_len = 8 + 2 * 9 * plan.sequence_len();
    for record in 0..5u32 {
        let mut bad = bytes.clone();
        bad[HEADER_LEN + record as usize * record_len + 100] ^= 0x10;
        let e = read_all(&bad).unwrap_err();
        match &e {
            DumpError::Record {
                record: r, source, ..
            } => {
                assert_eq!(*r, record);
                assert!(matches!(source.0, WireError::RecordCrc { row, .. } if row == record));
            }
            other => panic!("expected a record CRC error, got {other}"),
        }
        assert_eq!(e.row(), Some(record));
        let message = e.to_string();
        assert!(message.contains(&format!("row {record}")), "{message}");
        assert!(message.contains("test.dump"), "{message}");
    }
}

#[test]
fn a_flipped_header_byte_is_a_header_error() {
    let (bytes, _) = dump_bytes(&efsm(), 9, 5, &[0, 1, 2, 3, 4]);
    for at in [0, 9, 12, 20, 30, 61] {
        let mut bad = bytes.clone();
        bad[at] ^= 0x01;
        let e = read_all(&bad).unwrap_err();
        assert!(matches!(e, DumpError::Header { .. }), "byte {at}: {e}");
        assert!(e.to_string().contains("header"), "{e}");
    }
}

#[test]
fn truncation_names_the_record_and_its_row() {
    let plan = efsm();
    let order = [4, 2, 0, 1, 3];
    let (bytes, _) = dump_bytes(&plan, 9, 5, &order);
    let record_len = 8 + 2 * 9 * plan.sequence_len();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cut.dump");
    for (record, cut_into) in [
        (0usize, 2usize),
        (1, 4),
        (2, 500),
        (4, record_len - 1),
        (3, 0),
    ] {
        let len = HEADER_LEN + record * record_len + cut_into;
        // Streaming: the error arises at the cut record.
        let e = read_all(&bytes[..len]).unwrap_err();
        let expected_row = (cut_into >= 4).then_some(order[record]);
        match &e {
            DumpError::Truncated {
                record: r,
                row,
                got,
                ..
            } => {
                assert_eq!((*r as usize, *row, *got), (record, expected_row, cut_into));
            }
            other => panic!("expected truncation, got {other}"),
        }
        // From a file: refused up front with the same facts.
        std::fs::write(&path, &bytes[..len]).unwrap();
        let e = DumpReader::open(&path)
            .err()
            .expect("truncated file refused");
        match &e {
            DumpError::Truncated { record: r, row, .. } => {
                assert_eq!((*r as usize, *row), (record, expected_row));
            }
            other => panic!("expected truncation, got {other}"),
        }
        let message = e.to_string();
        assert!(message.contains(&format!("record {record}")), "{message}");
        if let Some(row) = expected_row {
            assert!(message.contains(&format!("row {row}")), "{message}");
        }
    }
    // A header cut short.
    let e = read_all(&bytes[..40]).unwrap_err();
    assert!(matches!(e, DumpError::Header { .. }), "{e}");
}

#[test]
fn padding_duplicates_and_foreign_plans_are_refused() {
    let plan = efsm();
    let (bytes, _) = dump_bytes(&plan, 9, 5, &[0, 1, 2, 3, 4]);
    let mut padded = bytes.clone();
    padded.push(0);
    assert!(matches!(
        read_all(&padded).unwrap_err(),
        DumpError::TrailingBytes { .. }
    ));

    // Row 2 twice (records 2 and 3), row 3 never: valid records, invalid dump.
    let header = RowDumpHeader::for_plan(&plan, 9, 5, 12);
    let samples = vec![7u16; header.samples_per_row()];
    let mut raw = header.encode().to_vec();
    let mut record = vec![0u8; header.record_len().unwrap()];
    for row in [0, 1, 2, 2, 4] {
        fsm_core::wire::row_dump::encode_record(&header, row, &samples, &mut record).unwrap();
        raw.extend_from_slice(&record);
    }
    match read_all(&raw).unwrap_err() {
        DumpError::DuplicateRow {
            row, first, second, ..
        } => assert_eq!((row, first, second), (2, 2, 3)),
        other => panic!("expected a duplicate row, got {other}"),
    }

    let reader = DumpReader::new(Cursor::new(&bytes), Path::new("a.dump")).unwrap();
    let other = ScanPlan::paper_efsm(GroupCount::Two);
    let e = reader.check(other, None).unwrap_err();
    assert!(matches!(e, DumpError::PatternMismatch { .. }));
    assert!(
        e.to_string()
            .contains(&format!("{:016x}", other.pattern_fingerprint())),
        "{e}"
    );
    // Other decoder settings, same patterns: accepted.
    let mut retuned = plan;
    retuned.decoding.noise_factor += 1.0;
    reader.check(retuned, Some(12)).unwrap();
    // A version-1 dump (the whole plan's fingerprint) decodes with its plan only.
    let v1 = RowDumpHeader {
        recorded_with: RecordedWith::Plan(plan.fingerprint()),
        ..*reader.header()
    };
    let mut old = bytes.clone();
    old[..HEADER_LEN].copy_from_slice(&v1.encode());
    let old_reader = DumpReader::new(Cursor::new(&old), Path::new("old.dump")).unwrap();
    old_reader.check(plan, Some(12)).unwrap();
    let e = old_reader.check(retuned, None).unwrap_err();
    assert!(matches!(e, DumpError::PlanMismatch { .. }), "{e}");
    assert!(e.to_string().contains("version-1"), "{e}");
    let e = reader.check(plan, Some(10)).unwrap_err();
    assert!(
        matches!(
            e,
            DumpError::BitDepth {
                found: 12,
                requested: 10,
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn a_corrupted_dump_fails_the_decode_and_leaves_nothing() {
    let plan = efsm();
    let (mut bytes, _) = dump_bytes(&plan, 9, 40, &(0..40).collect::<Vec<_>>());
    let record_len = 8 + 2 * 9 * plan.sequence_len();
    bytes[HEADER_LEN + 33 * record_len + 50] ^= 0xff;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scan.dump");
    std::fs::write(&path, &bytes).unwrap();
    let capture = Capture::open_dump(&path, plan, None, BadRows::Refuse).unwrap();
    let out = dir.path().join("decoded");
    let options = DecodeOptions {
        memory_budget_bytes: 1 << 20,
        threads: 2,
    };
    let e = decode::decode_to_dir(plan, &capture, &out, false, &options, &Progress::hidden())
        .unwrap_err();
    assert!(matches!(&e, Error::Dump(d) if d.row() == Some(33)), "{e}");
    assert_eq!(
        support::entries(dir.path()),
        vec![path],
        "no output or temporary left"
    );
}

/// A dump of a lit scene (pixel `x` of row `y` sees column `3x + y`), rows in `order`.
fn scene_dump(plan: &ScanPlan, width: u32, height: u32, order: &[u32]) -> Vec<u8> {
    let header = RowDumpHeader::for_plan(plan, width, height, 12);
    let w = width as usize;
    let mut writer = DumpWriter::new(Vec::new(), header).unwrap();
    for &y in order {
        let mut samples = vec![0u16; header.samples_per_row()];
        for (i, pattern) in plan.sequence().enumerate() {
            for x in 0..w {
                let light = plan.intensity(pattern, 3 * x as u32 + y);
                samples[i * w + x] = (50.0 + 3000.0 * light).round() as u16;
            }
        }
        writer.write_row(y, &samples).unwrap();
    }
    writer.finish().unwrap()
}

#[test]
fn rows_stored_out_of_order_decode_to_the_same_candidate_file() {
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let (width, height) = (16, 40);
    let dir = tempfile::tempdir().unwrap();
    let in_order: Vec<u32> = (0..height).collect();
    let reversed: Vec<u32> = (0..height).rev().collect();
    let mut files = Vec::new();
    for (name, order) in [("a", &in_order), ("b", &reversed)] {
        let path = dir.path().join(format!("{name}.dump"));
        std::fs::write(&path, scene_dump(&plan, width, height, order)).unwrap();
        let capture = Capture::open_dump(&path, plan, Some(12), BadRows::Refuse).unwrap();
        let out = dir.path().join(name);
        let options = DecodeOptions {
            memory_budget_bytes: 1 << 30,
            threads: 2,
        };
        let summary =
            decode::decode_to_dir(plan, &capture, &out, false, &options, &Progress::hidden())
                .unwrap();
        assert_eq!(summary.lit_pixels, (width * height) as u64);
        files.push(std::fs::read(out.join(fsm_io::candidate_file::CANDIDATE_FILE_NAME)).unwrap());
    }
    assert_eq!(files[0], files[1]);
}

#[test]
fn a_header_claiming_huge_records_is_refused_without_allocating_them() {
    // Valid header CRC, records of 2^52 bytes: the reader must fail on the data, not abort.
    let header = RowDumpHeader {
        bit_depth: 12,
        recorded_with: RecordedWith::Patterns(1),
        width: 1 << 31,
        height: 3,
        frames: 1 << 20,
    };
    let mut bytes = header.encode().to_vec();
    bytes.extend_from_slice(&[0u8; 100]);
    let e = read_all(&bytes).unwrap_err();
    assert!(
        matches!(
            e,
            DumpError::Truncated {
                record: 0,
                got: 100,
                ..
            }
        ),
        "{e}"
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("huge.dump");
    std::fs::write(&path, &bytes).unwrap();
    assert!(matches!(
        DumpReader::open(&path),
        Err(DumpError::Truncated { .. })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let _ = read_all(&bytes);
    }

    #[test]
    fn any_corruption_is_an_error_never_wrong_data(at in 0usize..2000, xor in 1u8..=255, cut in any::<bool>()) {
        let plan = ScanPlan::efsm(64, 16, GroupCount::One);
        let (bytes, rows) = dump_bytes(&plan, 3, 4, &[1, 3, 0, 2]);
        let at = at % bytes.len();
        let mut bad = bytes.clone();
        if cut {
            bad.truncate(at);
        } else {
            bad[at] ^= xor;
        }
        match read_all(&bad) {
            Ok(read) => {
                // Only reserved header bytes are unchecked by value, and they are CRC-covered:
                // whatever is read must be the original data.
                for (row, samples) in read {
                    prop_assert_eq!(&samples, &rows[row as usize]);
                }
                prop_assert!(false, "corruption at byte {} went unnoticed", at);
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }
}
