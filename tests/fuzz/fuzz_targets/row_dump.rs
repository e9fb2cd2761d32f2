//! Row dumps: raw bytes, and records whose CRC is made valid so the fuzzer reaches the checks
//! behind it. Nothing panics; a record that decodes round-trips.
#![no_main]

use fsm_core::wire::row_dump::{self, RecordedWith, RowDumpHeader};
use fsm_core::wire::{crc32, HEADER_LEN};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(header) = RowDumpHeader::decode(data) {
        assert_eq!(&header.encode()[..], &data[..HEADER_LEN]);
        if let Ok(record) = row_dump::decode_record(&header, &data[HEADER_LEN..]) {
            let mut samples = vec![0u16; record.len()];
            record.copy_to(&mut samples).unwrap();
        }
    }
    // A small header built from the first bytes, then a record with a valid CRC.
    if data.len() < 4 {
        return;
    }
    let header = RowDumpHeader {
        bit_depth: 1 + data[0] % 16,
        // Either version: bit 7 of the first byte (bit depth reads the low 4).
        recorded_with: if data[0] & 0x80 == 0 {
            RecordedWith::Patterns(7)
        } else {
            RecordedWith::Plan(7)
        },
        width: 1 + data[1] as u32 % 8,
        height: 1 + data[2] as u32 % 8,
        frames: 1 + data[3] as u32 % 8,
    };
    let mut record = data[4..].to_vec();
    if let Some(len) = header.record_len() {
        if record.len() >= len && len >= 4 {
            let crc = crc32(&record[..len - 4]);
            record[len - 4..len].copy_from_slice(&crc.to_le_bytes());
        }
    }
    if let Ok(r) = row_dump::decode_record(&header, &record) {
        let mut samples = vec![0u16; r.len()];
        r.copy_to(&mut samples).unwrap();
        let mut again = vec![0u8; header.record_len().unwrap()];
        row_dump::encode_record(&header, r.row, &samples, &mut again).unwrap();
        assert_eq!(&again[..], &record[..again.len()]);
    }
});
