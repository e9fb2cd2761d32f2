//! The host's candidate-file reader (`CandidateReader`: row order, truncation, record lengths
//! and trailing bytes over the core's record format, which the candidate_rows target covers on its own): raw
//! bytes, and a small header built from the first bytes followed by records whose CRCs are
//! made valid. Errors name the source; a file that reads has rows 0.. in order and writes back
//! to bytes that read to the same candidates.
#![no_main]

use std::path::Path;

use fsm_core::wire::candidates::{CandidateHeader, RECORD_OVERHEAD};
use fsm_core::wire::crc32;
use fsm_io::candidate_file::{
    CandidateFileError, CandidateReader, CandidateWriter, HostCandidates,
};
use libfuzzer_sys::fuzz_target;

/// Widths above this are not read (the caller allocates a row of candidates per the header).
const MAX_WIDTH: u32 = 1 << 12;

fn read_all(
    bytes: &[u8],
) -> Result<Option<(CandidateHeader, Vec<Vec<HostCandidates>>)>, CandidateFileError> {
    let mut reader = CandidateReader::new(bytes, Path::new("fuzz.fsmc"))?;
    let header = *reader.header();
    if header.width > MAX_WIDTH {
        return Ok(None);
    }
    let mut rows = Vec::new();
    loop {
        let mut out = vec![HostCandidates::default(); header.width as usize];
        match reader.next_row(&mut out)? {
            Some(row) => {
                assert_eq!(row as usize, rows.len(), "rows out of order");
                rows.push(out);
            }
            None => return Ok(Some((header, rows))),
        }
    }
}

fn write_all(header: CandidateHeader, rows: &[Vec<HostCandidates>]) -> Vec<u8> {
    let mut writer = CandidateWriter::new(Vec::new(), header).expect("header writes");
    for (row, pixels) in rows.iter().enumerate() {
        writer
            .write_row(row as u32, pixels)
            .expect("a row read writes");
    }
    writer.finish().expect("every row written")
}

fn check(bytes: &[u8]) {
    let (header, rows) = match read_all(bytes) {
        Ok(Some(file)) => file,
        Ok(None) => return,
        Err(e) => {
            let message = e.to_string();
            assert!(
                message.starts_with("fuzz.fsmc: "),
                "error without the source: {message}"
            );
            assert!(message.len() > "fuzz.fsmc: ".len(), "empty error");
            return;
        }
    };
    assert_eq!(rows.len(), header.height as usize);
    // Written again, the bytes read to the same candidates: the same bytes once more.
    let written = write_all(header, &rows);
    let (_, again) = read_all(&written)
        .expect("written file reads")
        .expect("small width");
    assert!(
        write_all(header, &again) == written,
        "candidates changed when written again"
    );
}

fuzz_target!(|data: &[u8]| {
    check(data);
    if data.len() < 3 {
        return;
    }
    let header = CandidateHeader {
        capacity: 1 + data[0] as u16 % 4,
        plan_fingerprint: 9,
        width: 1 + data[1] as u32 % 3,
        height: 1 + data[2] as u32 % 4,
    };
    // Records: row (the next one, mostly), payload length from the input, payload, valid CRC.
    let mut bytes = header.encode().to_vec();
    let mut rest = &data[3..];
    let mut row = 0u32;
    while rest.len() >= 2 {
        let (skip, payload_len) = (rest[0], rest[1] as usize);
        rest = &rest[2..];
        let payload = &rest[..payload_len.min(rest.len())];
        rest = &rest[payload.len()..];
        let r = if skip % 8 == 0 { row + 1 } else { row };
        let mut record = r.to_le_bytes().to_vec();
        record.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        record.extend_from_slice(payload);
        let crc = crc32(&record);
        record.extend_from_slice(&crc.to_le_bytes());
        debug_assert_eq!(record.len(), payload.len() + RECORD_OVERHEAD);
        bytes.extend_from_slice(&record);
        row += 1;
    }
    check(&bytes);
});
