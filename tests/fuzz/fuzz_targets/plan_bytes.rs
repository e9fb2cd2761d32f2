//! Plan bytes: decoding never panics, and whatever decodes re-encodes canonically: a version-2
//! plan to the same 80 bytes, a version-1 plan to version 2 with the same fields and the
//! fingerprint of its own 64 bytes as its legacy fingerprint.
#![no_main]

use fsm_core::wire::plan::{PLAN_LEN, PLAN_V1_LEN};
use fsm_core::ScanPlan;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(plan) = ScanPlan::from_bytes(data) {
        assert!(plan.validate().is_ok());
        let bytes = plan.to_bytes();
        if data[60..62] == [1, 0] {
            assert_eq!(&bytes[..60], &data[..60]);
            assert_eq!(&bytes[62..PLAN_V1_LEN], &data[62..PLAN_V1_LEN]);
            let legacy = fsm_core::wire::crc64(&data[..PLAN_V1_LEN]);
            assert_eq!(plan.legacy_fingerprint(), Some(legacy));
        } else {
            assert_eq!(&bytes[..], &data[..PLAN_LEN]);
        }
    }
});
