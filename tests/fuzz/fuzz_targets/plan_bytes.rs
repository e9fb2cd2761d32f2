//! Plan bytes of every method: decoding never panics, and whatever decodes re-encodes
//! canonically: a version-2 FSM plan to the same 80 bytes, a version-1 plan to version 2 with
//! the same fields and the fingerprint of its own 64 bytes as its legacy fingerprint, a
//! baseline's plan (`fsm_core::methods::wire`) to the same bytes; and `MethodPlan::from_bytes`
//! reads 80 bytes as `ScanPlan::from_bytes` does.
#![no_main]

use fsm_core::wire::plan::{PLAN_LEN, PLAN_V1_LEN};
use fsm_core::{
    CodeEnsemblePlan, LineScanPlan, MethodPlan, MicroPhaseShiftPlan, PhaseShiftPlan, ScanPlan,
};
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
    match MethodPlan::from_bytes(data) {
        Ok(MethodPlan::Fsm(plan)) => {
            assert!(data.len() == PLAN_LEN || data.len() == PLAN_V1_LEN);
            assert_eq!(ScanPlan::from_bytes(data), Ok(plan));
        }
        Ok(plan) => {
            assert!(plan.check().is_ok());
            assert_eq!(plan.wire_len(), data.len());
            assert_eq!(plan.to_bytes().as_slice(), data);
            assert_eq!(MethodPlan::from_bytes(&plan.to_bytes()), Ok(plan));
        }
        Err(e) => {
            let _ = e.to_string();
            if data.len() == PLAN_LEN {
                assert!(ScanPlan::from_bytes(data).is_err());
            }
        }
    }
    // Each baseline's own reader agrees with the dispatcher on its bytes.
    if let Ok(p) = PhaseShiftPlan::from_bytes(data) {
        assert_eq!(MethodPlan::from_bytes(data), Ok(MethodPlan::PhaseShift(p)));
    }
    if let Ok(p) = MicroPhaseShiftPlan::from_bytes(data) {
        assert_eq!(MethodPlan::from_bytes(data), Ok(MethodPlan::MicroPhaseShift(p)));
    }
    if let Ok(p) = LineScanPlan::from_bytes(data) {
        assert_eq!(MethodPlan::from_bytes(data), Ok(MethodPlan::LineScan(p)));
    }
    if let Ok(p) = CodeEnsemblePlan::from_bytes(data) {
        assert_eq!(MethodPlan::from_bytes(data), Ok(MethodPlan::CodeEnsemble(p)));
    }
});
