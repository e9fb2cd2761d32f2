//! Candidate files: decoded rows round trip through the file; truncation, corruption, row
//! order and trailing bytes are errors naming the row; arbitrary bytes never panic the reader.

use std::io::Cursor;
use std::path::Path;

use fsm_core::wire::candidates::CandidateHeader;
use fsm_core::wire::HEADER_LEN;
use fsm_core::{Decoder, GroupCount, Row, ScanPlan};
use fsm_io::candidate_file::{
    CandidateFileError, CandidateReader, CandidateWriter, HostCandidates,
};
use fsm_io::decode::candidate_header;
use proptest::prelude::*;

/// Decoded rows of a small EFSM scene: pixel `x` lit by column `40 + 9x` (and, on odd pixels,
/// weakly by column `700 − 5x`, as by a reflection).
fn decoded_rows(height: u32, width: usize) -> (ScanPlan, Vec<Vec<HostCandidates>>) {
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let mut tables = vec![0.0; Decoder::tables_len(&plan)];
    let decoder = Decoder::new(&plan, &mut tables).unwrap();
    let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
    let mut rows = Vec::new();
    for y in 0..height {
        let mut frames = vec![0u16; plan.sequence_len() * width];
        for (i, pattern) in plan.sequence().enumerate() {
            for x in 0..width {
                let direct = plan.intensity(pattern, 40 + 9 * x as u32 + y);
                let indirect = if x % 2 == 1 {
                    plan.intensity(pattern, 700 - 5 * x as u32)
                } else {
                    0.0
                };
                frames[i * width + x] = (30.0 + 2000.0 * direct + 500.0 * indirect).round() as u16;
            }
        }
        let row = Row {
            frames: &frames,
            width,
            bit_depth: 12,
            column_limits: None,
        };
        let mut out = vec![HostCandidates::new(); width];
        decoder.decode_row(&row, &mut scratch, &mut out).unwrap();
        rows.push(out);
    }
    (plan, rows)
}

fn file_bytes(header: CandidateHeader, rows: &[Vec<HostCandidates>]) -> Vec<u8> {
    let mut writer = CandidateWriter::new(Vec::new(), header).unwrap();
    for (y, row) in rows.iter().enumerate() {
        writer.write_row(y as u32, row).unwrap();
    }
    writer.finish().unwrap()
}

fn read_all(bytes: &[u8], width: usize) -> Result<Vec<Vec<HostCandidates>>, CandidateFileError> {
    let mut reader = CandidateReader::new(Cursor::new(bytes), Path::new("c.fsmc"))?;
    let mut rows = Vec::new();
    let mut pixels = vec![HostCandidates::new(); width];
    while reader.next_row(&mut pixels)?.is_some() {
        rows.push(pixels.clone());
    }
    Ok(rows)
}

#[test]
fn decoded_rows_round_trip() {
    let (plan, rows) = decoded_rows(3, 12);
    assert!(
        rows.iter().flatten().any(|p| p.candidates.len() >= 2),
        "some pixels have two candidates"
    );
    let bytes = file_bytes(candidate_header(plan, 12, 3), &rows);
    assert_eq!(read_all(&bytes, 12).unwrap(), rows);
}

#[test]
fn damage_is_an_error_naming_the_row() {
    let (plan, rows) = decoded_rows(3, 12);
    let bytes = file_bytes(candidate_header(plan, 12, 3), &rows);
    let first_len = fsm_core::wire::candidates::record_len(&rows[0]);
    let second = HEADER_LEN + first_len;

    let mut flipped = bytes.clone();
    flipped[second + 20] ^= 0x04;
    let e = read_all(&flipped, 12).unwrap_err();
    assert!(
        matches!(e, CandidateFileError::Record { row: 1, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("row 1"), "{e}");

    let e = read_all(&bytes[..second + 30], 12).unwrap_err();
    assert!(
        matches!(e, CandidateFileError::Truncated { row: 1, .. }),
        "{e}"
    );

    let e = read_all(&bytes[..bytes.len() - first_len.min(10)], 12).unwrap_err();
    assert!(
        matches!(e, CandidateFileError::Truncated { row: 2, .. }),
        "{e}"
    );

    let mut padded = bytes.clone();
    padded.extend_from_slice(&[0; 3]);
    assert!(matches!(
        read_all(&padded, 12).unwrap_err(),
        CandidateFileError::TrailingBytes { .. }
    ));

    // Rows 1 and 0 swapped: valid records, wrong order.
    let header = candidate_header(plan, 12, 3);
    let mut swapped = header.encode().to_vec();
    for (y, row) in [(1u32, &rows[1]), (0, &rows[0]), (2, &rows[2])] {
        let mut record = Vec::new();
        fsm_io::candidate_file::encode_row(&header, y, row, &mut record).unwrap();
        swapped.extend_from_slice(&record);
    }
    let e = read_all(&swapped, 12).unwrap_err();
    assert!(
        matches!(
            e,
            CandidateFileError::RowOrder {
                expected: 0,
                found: 1,
                ..
            }
        ),
        "{e}"
    );

    let mut bad_header = bytes.clone();
    bad_header[25] ^= 1;
    assert!(matches!(
        read_all(&bad_header, 12).unwrap_err(),
        CandidateFileError::Header { .. }
    ));
}

#[test]
fn the_writer_refuses_rows_out_of_order_and_missing_rows() {
    let (plan, rows) = decoded_rows(2, 5);
    let header = candidate_header(plan, 5, 2);
    let mut writer = CandidateWriter::new(Vec::new(), header).unwrap();
    assert!(writer.write_row(1, &rows[1]).is_err());
    writer.write_row(0, &rows[0]).unwrap();
    assert!(writer.finish().is_err());
}

#[test]
fn a_record_claiming_a_huge_payload_is_refused_without_allocating_it() {
    let header = CandidateHeader {
        capacity: 255,
        plan_fingerprint: 7,
        width: 1 << 31,
        height: 1,
    };
    let mut bytes = header.encode().to_vec();
    bytes.extend_from_slice(&0u32.to_le_bytes());
    bytes.extend_from_slice(&u32::MAX.to_le_bytes());
    bytes.extend_from_slice(&[0u8; 50]);
    let mut reader = CandidateReader::new(Cursor::new(&bytes), Path::new("c.fsmc")).unwrap();
    let mut pixels: Vec<HostCandidates> = Vec::new();
    let e = reader.next_row(&mut pixels).unwrap_err();
    assert!(
        matches!(
            e,
            CandidateFileError::Truncated {
                row: 0,
                got: 58,
                ..
            }
        ),
        "{e}"
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400), width in 1usize..4) {
        let _ = read_all(&bytes, width);
    }

    #[test]
    fn arbitrary_records_after_a_valid_header_never_panic(tail in proptest::collection::vec(any::<u8>(), 0..400)) {
        let header = CandidateHeader { capacity: 16, plan_fingerprint: 7, width: 2, height: 3 };
        let mut bytes = header.encode().to_vec();
        bytes.extend_from_slice(&tail);
        let _ = read_all(&bytes, 2);
    }
}
