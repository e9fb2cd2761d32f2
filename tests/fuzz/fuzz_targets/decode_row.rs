//! The line decoder on arbitrary samples, plans and bit depths: it never panics, every
//! candidate it reports is finite, positive and inside the projector, and the row decoded the
//! way this CPU decodes it fastest (`decode_row`) equals the row decoded one lane at a time,
//! as the camera does. Plans: small BFSM and EFSM ones, CLEAN and the cosine search, and the
//! paper's BFSM and two-group EFSM; rows of up to 2025 pixels.
#![no_main]

use fsm_core::{Decoder, GroupCount, PixelCandidates, Row, ScanPlan, Window};
use libfuzzer_sys::fuzz_target;

fn bfsm(columns: u16) -> ScanPlan {
    let mut plan = ScanPlan::paper_bfsm();
    plan.projector_columns = columns;
    plan.band.period_columns = 2 * columns as u32;
    plan.band.count = columns;
    plan.transform_size = (columns as u32).next_power_of_two().max(64) as u16;
    plan
}

fuzz_target!(|data: &[u8]| {
    if data.len() < 4 {
        return;
    }
    let mut plan = match data[0] % 9 {
        0 => ScanPlan::efsm(128, 16, GroupCount::Two),
        1 => ScanPlan::efsm(96, 32, GroupCount::One),
        2 => {
            let mut p = ScanPlan::efsm(256, 64, GroupCount::Two).with_clean();
            p.decoding.window = Window::Hann;
            p
        }
        3 => ScanPlan::paper_efsm(GroupCount::One),
        4 => bfsm(128),
        5 => bfsm(97),
        6 => bfsm(128).with_clean(),
        // The paper's own plans: 768 columns (a 1536-point transform: radix 3 over 512).
        7 => ScanPlan::paper_bfsm(),
        _ => ScanPlan::paper_efsm(GroupCount::Two),
    };
    plan.decoding.max_peaks = 1 + data[1] % 8;
    let bits = 1 + data[2] % 16;
    // Mostly 1 to 19 pixels: every lane count ends with a partial chunk somewhere; one input
    // in eight a camera's row (320 to 2025 pixels; the firmware takes 2048), the samples repeated.
    let width = if data[3] >= 224 {
        320 + (data[3] as usize - 224) * 55
    } else {
        1 + (data[3] % 19) as usize
    };
    let samples: Vec<u16> = data[4..]
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
    let mut one = vec![PixelCandidates::<16>::new(); width];
    decoder
        .decode_row_lanes::<1, 16>(&row, &mut scratch, &mut one)
        .unwrap();
    assert!(out == one, "{:?} lanes differ from one lane", decoder.isa());
    for p in &out {
        assert!(p.noise_dn.is_finite());
        for c in &p.candidates {
            assert!(c.column.is_finite() && c.amplitude.is_finite() && c.amplitude > 0.0);
            assert!(c.column >= -0.5 && c.column <= plan.projector_columns as f32 - 0.5);
        }
    }
});
