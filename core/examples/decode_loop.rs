//! Decodes one synthetic 256-pixel row of a preset plan `n` times: the workload behind
//! `core/scripts/instructions-per-pixel.sh`, which counts instructions with callgrind (exact and
//! repeatable on a busy machine, and comparable with the firmware's count on the Cortex-A9).
//!
//! `cargo run --release -p fsm-core --example decode_loop -- bfsm|efsm1|efsm2[-fast][-shadow] [n]`
//!
//! `-fast`: the paper's local-maximum search without zero padding ([`ScanPlan::with_local_maxima`]).
//! `-scalar` (last, e.g. `efsm1-scalar`): one lane at a time; `-lanes4`: four lanes of the
//! build's 4-lane vector (SSE2 here), as the camera decodes with NEON; the default is what
//! `Decoder::decode_row` picks for this CPU.
//!
//! Three pixels in four are lit by one column pair (1200 + 600 DN), one in four also by a second
//! column (500 DN) elsewhere: the interreflection case. With `-shadow` (e.g. `efsm1-shadow`)
//! every pixel is in shadow instead: ambient light and the same small noise, no fringes.

use fsm_core::{Decoder, GroupCount, PixelCandidates, Row, ScanPlan};

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next();
    let (name, shadow) = match name.as_deref().map(|n| n.strip_suffix("-shadow")) {
        Some(Some(base)) => (Some(base), true),
        _ => (name.as_deref(), false),
    };
    let (name, lanes) = match name {
        Some(n) if n.ends_with("-scalar") => (n.strip_suffix("-scalar"), 1),
        Some(n) if n.ends_with("-lanes4") => (n.strip_suffix("-lanes4"), 4),
        _ => (name, 0),
    };
    let (name, fast) = match name.map(|n| n.strip_suffix("-fast")) {
        Some(Some(base)) => (Some(base), true),
        _ => (name, false),
    };
    let mut plan = match name {
        Some("efsm1") => ScanPlan::paper_efsm(GroupCount::One),
        Some("efsm2") => ScanPlan::paper_efsm(GroupCount::Two),
        Some("bfsm") | None => ScanPlan::paper_bfsm(),
        Some(other) => panic!("unknown plan {other}: use bfsm, efsm1 or efsm2"),
    };
    if fast {
        plan = plan.with_local_maxima();
    }
    let repeats: usize = args.next().map_or(100, |n| n.parse().expect("a count"));
    let width = 256;
    let columns = plan.projector_columns as usize;
    let mut frames = vec![0u16; plan.sequence_len() * width];
    for x in 0..width {
        let direct = (10 + (x * 37) % (columns - 20)) as u32;
        let indirect = (10 + (x * 91) % (columns - 20)) as u32;
        for (i, p) in plan.sequence().enumerate() {
            if shadow {
                frames[i * width + x] = (100.0 + 4.0 * uniform(i, x)) as u16;
                continue;
            }
            let mut v = 100.0
                + 1200.0 * plan.intensity(p, direct)
                + 600.0 * plan.intensity(p, direct + 1)
                + ((i * 7919 + x * 31) % 5) as f32;
            if x % 4 == 0 {
                v += 500.0 * plan.intensity(p, indirect);
            }
            frames[i * width + x] = v as u16;
        }
    }
    let mut tables = vec![0.0; Decoder::tables_len(&plan)];
    let decoder = Decoder::new(&plan, &mut tables).expect("preset is valid");
    let row = Row {
        frames: &frames,
        width,
        bit_depth: 12,
        column_limits: None,
    };
    let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
    let mut out = vec![PixelCandidates::<16>::new(); width];
    for _ in 0..repeats {
        match lanes {
            1 => decoder.decode_row_lanes::<1, 16>(&row, &mut scratch, &mut out),
            4 => decoder.decode_row_lanes::<4, 16>(&row, &mut scratch, &mut out),
            _ => decoder.decode_row(&row, &mut scratch, &mut out),
        }
        .expect("row decodes");
    }
    let candidates: usize = out.iter().map(|p| p.candidates.len()).sum();
    println!("{candidates} candidates in the last row");
}

/// Uniform in `[0, 1)`, a fixed function of frame and pixel (SplitMix64): noise without a tone.
fn uniform(frame: usize, x: usize) -> f32 {
    let mut z = (frame as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (x as u64) << 32;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 24) as f32
}
