//! The line decoder on arbitrary samples, plans and bit depths: it never panics and every
//! candidate it reports is finite, positive and inside the projector.
#![no_main]

use fsm_core::{Decoder, GroupCount, PixelCandidates, Row, ScanPlan, Window};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if data.len() < 3 {
        return;
    }
    let mut plan = match data[0] % 4 {
        0 => ScanPlan::efsm(128, 16, GroupCount::Two),
        1 => ScanPlan::efsm(96, 32, GroupCount::One),
        2 => {
            let mut p = ScanPlan::efsm(256, 64, GroupCount::Two);
            p.decoding.window = Window::Hann;
            p
        }
        _ => ScanPlan::paper_efsm(GroupCount::One),
    };
    plan.decoding.max_peaks = 1 + data[1] % 8;
    let bits = 1 + data[2] % 16;
    let width = 2;
    let samples: Vec<u16> = data[3..]
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .cycle()
        .take(plan.sequence_len() * width)
        .collect();
    if samples.len() != plan.sequence_len() * width {
        return;
    }
    let mut tables = vec![0.0; Decoder::tables_len(&plan)];
    let decoder = Decoder::new(&plan, &mut tables).unwrap();
    let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
    let mut out = vec![PixelCandidates::<16>::new(); width];
    let row = Row {
        frames: &samples,
        width,
        bit_depth: bits,
        column_limits: None,
    };
    decoder.decode_row(&row, &mut scratch, &mut out).unwrap();
    for p in &out {
        assert!(p.noise_dn.is_finite());
        for c in &p.candidates {
            assert!(c.column.is_finite() && c.amplitude.is_finite() && c.amplitude > 0.0);
            assert!(c.column >= -0.5 && c.column <= plan.projector_columns as f32 - 0.5);
        }
    }
});
