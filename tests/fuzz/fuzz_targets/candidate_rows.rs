//! Candidate rows: raw bytes, and records whose CRC is made valid so the fuzzer reaches the
//! per-pixel structure checks. Nothing panics; a record that decodes re-encodes to its bytes.
#![no_main]

use fsm_core::wire::candidates::{self, CandidateHeader};
use fsm_core::wire::{crc32, HEADER_LEN};
use fsm_core::PixelCandidates;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(header) = CandidateHeader::decode(data) {
        assert_eq!(&header.encode()[..], &data[..HEADER_LEN]);
        let _ = candidates::decode_record(&header, &data[HEADER_LEN..]);
    }
    if data.len() < 2 {
        return;
    }
    let header = CandidateHeader {
        capacity: 1 + data[0] as u16 % 8,
        plan_fingerprint: 9,
        width: 1 + data[1] as u32 % 4,
        height: 4,
    };
    let payload = &data[2..];
    let mut record = 1u32.to_le_bytes().to_vec();
    record.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    record.extend_from_slice(payload);
    let crc = crc32(&record);
    record.extend_from_slice(&crc.to_le_bytes());
    if let Ok(r) = candidates::decode_record(&header, &record) {
        let mut pixels = vec![PixelCandidates::<8>::new(); header.width as usize];
        r.read_into(&header, &mut pixels).unwrap();
        let mut again = vec![0u8; record.len()];
        let n = candidates::encode_record(&header, 1, &pixels, &mut again).unwrap();
        assert_eq!(&again[..n], &record[..]);
    }
});
