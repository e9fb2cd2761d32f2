//! Plan bytes: decoding never panics, and whatever decodes re-encodes to the same 64 bytes.
#![no_main]

use fsm_core::wire::plan::PLAN_LEN;
use fsm_core::ScanPlan;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(plan) = ScanPlan::from_bytes(data) {
        assert_eq!(&plan.to_bytes()[..], &data[..PLAN_LEN]);
        assert!(plan.validate().is_ok());
    }
});
