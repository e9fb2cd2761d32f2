//! Decodes one synthetic 256-pixel row of a preset plan `n` times: the workload behind
//! `core/scripts/instructions-per-pixel.sh`, which counts instructions with callgrind (exact and
//! repeatable on a busy machine, and comparable with the firmware's count on the Cortex-A9).
//!
//! `cargo run --release -p fsm-core --example decode_loop -- bfsm|efsm1|efsm2 [n]`
//!
//! Three pixels in four are lit by one column pair (1200 + 600 DN), one in four also by a second
//! column (500 DN) elsewhere: the interreflection case.

use fsm_core::{Decoder, GroupCount, PixelCandidates, Row, ScanPlan};

fn main() {
    let mut args = std::env::args().skip(1);
    let plan = match args.next().as_deref() {
        Some("efsm1") => ScanPlan::paper_efsm(GroupCount::One),
        Some("efsm2") => ScanPlan::paper_efsm(GroupCount::Two),
        Some("bfsm") | None => ScanPlan::paper_bfsm(),
        Some(other) => panic!("unknown plan {other}: use bfsm, efsm1 or efsm2"),
    };
    let repeats: usize = args.next().map_or(100, |n| n.parse().expect("a count"));
    let width = 256;
    let columns = plan.projector_columns as usize;
    let mut frames = vec![0u16; plan.sequence_len() * width];
    for x in 0..width {
        let direct = (10 + (x * 37) % (columns - 20)) as u32;
        let indirect = (10 + (x * 91) % (columns - 20)) as u32;
        for (i, p) in plan.sequence().enumerate() {
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
        decoder
            .decode_row(&row, &mut scratch, &mut out)
            .expect("row decodes");
    }
    let candidates: usize = out.iter().map(|p| p.candidates.len()).sum();
    println!("{candidates} candidates in the last row");
}
