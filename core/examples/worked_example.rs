//! Decodes the paper's §V worked example (SPEC §3) from simulated pixels and prints what each
//! method finds: a pixel lit only directly (Qd, column 694.9) and one lit directly and through a
//! mirror (Qid, columns 539.4 and 658.7), on the paper's 768-column projector.
//!
//! `cargo run --release -p fsm-core --example worked_example`

use fsm_core::{Decoder, Group, GroupCount, Method, PixelCandidates, Row, ScanPlan};

/// 12-bit samples of a pixel that sees defocused spots (centre, DN at full output), σ 0.6
/// column, over whole projector columns, 40 DN ambient light.
fn pixel(plan: &ScanPlan, spots: &[(f64, f64)]) -> Vec<u16> {
    plan.sequence()
        .map(|pattern| {
            let mut v = 40.0;
            for &(centre, dn) in spots {
                let (lo, hi) = ((centre - 4.0) as u32, (centre + 5.0) as u32);
                let weights: Vec<f64> = (lo..=hi)
                    .map(|j| (-0.5 * ((j as f64 - centre) / 0.6).powi(2)).exp())
                    .collect();
                let total: f64 = weights.iter().sum();
                for (j, w) in (lo..=hi).zip(weights) {
                    v += dn * w / total * plan.intensity(pattern, j) as f64;
                }
            }
            v.round() as u16
        })
        .collect()
}

fn main() {
    let mut efsm = ScanPlan::efsm(768, 32, GroupCount::Two);
    if let Method::Efsm(coding) = &mut efsm.method {
        coding.border_guard = 2.0; // the paper keeps group 2's c̃ = 2.8
    }
    for (name, plan) in [
        ("BFSM, 768 fringes", ScanPlan::paper_bfsm()),
        ("EFSM, cB = 32, two groups", efsm),
    ] {
        println!(
            "{name}: {} patterns + {} reference frames",
            plan.pattern_count(),
            plan.reference_count()
        );
        let mut tables = vec![0.0; Decoder::tables_len(&plan)];
        let decoder = Decoder::new(&plan, &mut tables).expect("valid plan");
        let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
        for (label, spots) in [
            ("Qd ", vec![(694.9, 1500.0)]),
            ("Qid", vec![(539.4, 1500.0), (658.7, 900.0)]),
        ] {
            let samples = pixel(&plan, &spots);
            let row = Row {
                frames: &samples,
                width: 1,
                bit_depth: 12,
                column_limits: None,
            };
            for group in plan.groups().filter(|_| plan.block_coding().is_some()) {
                let peaks = decoder
                    .peaks(&row, 0, group, &mut scratch)
                    .expect("row decodes");
                let local: Vec<String> = peaks
                    .peaks
                    .iter()
                    .map(|p| format!("{:.1}", p.column))
                    .collect();
                println!(
                    "  {label} group {}: c̃ = {{{}}}",
                    group.number(),
                    local.join(", ")
                );
            }
            let mut out = PixelCandidates::<8>::new();
            decoder
                .decode_pixel(&row, 0, &mut scratch, &mut out)
                .expect("row decodes");
            let columns: Vec<String> = out
                .candidates
                .iter()
                .map(|c| {
                    format!(
                        "{:.2} ({:.0} DN{})",
                        c.column,
                        c.amplitude,
                        if c.groups.0 == 3 { ", both groups" } else { "" }
                    )
                })
                .collect();
            println!("  {label} candidates: {}", columns.join(", "));
        }
        let _ = Group::One;
    }
}
