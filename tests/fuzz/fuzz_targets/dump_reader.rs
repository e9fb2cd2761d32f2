//! The host's row-dump reader (`DumpReader`: record order, duplicate rows, truncation and
//! trailing bytes over the core's record format, which the row_dump target covers on its own): raw
//! bytes, and a small header built from the first bytes followed by records whose CRCs are
//! made valid, so the fuzzer reaches the checks behind them. Errors name the source; a dump
//! that reads has every row once and writes back to the same bytes.
#![no_main]

use std::collections::HashSet;
use std::path::Path;

use fsm_core::wire::crc32;
use fsm_core::wire::row_dump::{RecordedWith, RowDumpHeader};
use fsm_io::dump::{DumpError, DumpReader, DumpWriter};
use libfuzzer_sys::fuzz_target;

type Rows = Vec<(u32, Vec<u16>)>;

fn read_all(bytes: &[u8]) -> Result<(RowDumpHeader, Rows), DumpError> {
    let mut reader = DumpReader::new(bytes, Path::new("fuzz.dump"))?;
    let mut rows = Vec::new();
    loop {
        let mut samples = Vec::new();
        match reader.next_row(&mut samples)? {
            Some(row) => rows.push((row, samples)),
            None => return Ok((*reader.header(), rows)),
        }
    }
}

/// Reading on past the records that spoil only themselves (`--skip-bad-rows`) ends after at
/// most one call per record, and delivers each row at most once.
fn read_skipping(bytes: &[u8]) {
    let Ok(mut reader) = DumpReader::new(bytes, Path::new("fuzz.dump")) else {
        return;
    };
    let mut seen = HashSet::new();
    for _ in 0..=reader.header().height {
        let mut samples = Vec::new();
        match reader.next_row(&mut samples) {
            Ok(Some(row)) => {
                assert!(seen.insert(row), "row {row} delivered twice");
                assert_eq!(samples.len(), reader.header().samples_per_row());
            }
            Err(e) if e.spoils_one_record() => assert!(samples.is_empty()),
            Ok(None) | Err(_) => return,
        }
    }
    panic!("more calls than the header's records");
}

fn check(bytes: &[u8]) {
    read_skipping(bytes);
    let (header, rows) = match read_all(bytes) {
        Ok(dump) => dump,
        Err(e) => {
            let message = e.to_string();
            assert!(
                message.starts_with("fuzz.dump: "),
                "error without the source: {message}"
            );
            assert!(message.len() > "fuzz.dump: ".len(), "empty error");
            return;
        }
    };
    assert_eq!(rows.len(), header.height as usize);
    let mut seen = HashSet::new();
    for (row, samples) in &rows {
        assert!(
            *row < header.height && seen.insert(*row),
            "row {row} again or out of range"
        );
        assert_eq!(samples.len(), header.samples_per_row());
    }
    let mut writer = DumpWriter::new(Vec::new(), header).expect("header writes");
    for (row, samples) in &rows {
        writer.write_row(*row, samples).expect("a row read writes");
    }
    let written = writer.finish().expect("every row written");
    assert!(written == bytes, "a dump read and written again changed");
    // Seeking a row reads the same samples.
    let (row, samples) = rows.last().expect("at least one row");
    let mut reader = DumpReader::new(bytes, Path::new("fuzz.dump")).expect("reads again");
    let mut found = Vec::new();
    reader.find_row(*row, &mut found).expect("row is there");
    assert!(found == *samples);
}

fuzz_target!(|data: &[u8]| {
    check(data);
    if data.len() < 4 {
        return;
    }
    let header = RowDumpHeader {
        bit_depth: 1 + data[0] % 16,
        recorded_with: RecordedWith::Patterns(7),
        width: 1 + data[1] as u32 % 4,
        height: 1 + data[2] as u32 % 6,
        frames: 1 + data[3] as u32 % 4,
    };
    let len = header.record_len().expect("small record");
    let mut bytes = header.encode().to_vec();
    for chunk in data[4..].chunks(len) {
        let mut record = chunk.to_vec();
        if record.len() == len {
            // Rows 0..=height: the last is out of range, and rows may repeat.
            let row = record[0] as u32 % (header.height + 1);
            record[..4].copy_from_slice(&row.to_le_bytes());
            let crc = crc32(&record[..len - 4]);
            record[len - 4..].copy_from_slice(&crc.to_le_bytes());
        }
        bytes.extend_from_slice(&record);
    }
    check(&bytes);
});
