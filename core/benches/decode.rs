//! Decode throughput of the line decoder on one core: ns per pixel for the paper's BFSM plan
//! (M = 768, N = 1024) and EFSM plans (cB = 64, one and two groups).
//!
//! Each row holds 256 pixels: 3/4 lit by one blurred spot, 1/4 by a spot plus a mirror's
//! indirect spot at 40% (the interreflection case), 12-bit samples with 2 DN read noise.
//! Run: `cargo bench -p fsm-core --bench decode`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use fsm_core::{Decoder, GroupCount, PixelCandidates, Row, ScanPlan};

const WIDTH: usize = 256;

/// Sample-major row of `WIDTH` pixels (deterministic pseudo-random content).
fn row(plan: &ScanPlan) -> Vec<u16> {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let frames = plan.sequence_len();
    let mut out = vec![0u16; frames * WIDTH];
    let columns = plan.projector_columns as f64;
    for x in 0..WIDTH {
        let direct = 8.0 + uniform() * (columns - 16.0);
        let indirect = (x % 4 == 0).then(|| 8.0 + uniform() * (columns - 16.0));
        let spot = |centre: f64, j: u32| {
            let d = (j as f64 - centre) / 0.7;
            (-0.5 * d * d).exp() / (0.7 * std::f64::consts::TAU.sqrt())
        };
        for (i, pattern) in plan.sequence().enumerate() {
            let mut v = 100.0;
            let lo = (direct - 4.0).max(0.0) as u32;
            for j in lo..lo + 9 {
                v += 2400.0 * spot(direct, j) * plan.intensity(pattern, j) as f64;
            }
            if let Some(c) = indirect {
                let lo = (c - 4.0).max(0.0) as u32;
                for j in lo..lo + 9 {
                    v += 960.0 * spot(c, j) * plan.intensity(pattern, j) as f64;
                }
            }
            // Read noise ~2 DN (sum of uniforms), 12-bit.
            let n = (uniform() + uniform() + uniform() + uniform() - 2.0) * 3.46;
            out[i * WIDTH + x] = (v + n).round().clamp(0.0, 4095.0) as u16;
        }
    }
    out
}

fn bench(c: &mut Criterion) {
    let plans = [
        ("bfsm_m768_n1024", ScanPlan::paper_bfsm()),
        ("efsm_cb64_one_group", ScanPlan::paper_efsm(GroupCount::One)),
        (
            "efsm_cb64_two_groups",
            ScanPlan::paper_efsm(GroupCount::Two),
        ),
    ];
    let mut group = c.benchmark_group("decode_row");
    group.throughput(Throughput::Elements(WIDTH as u64));
    for (name, plan) in plans {
        let mut tables = vec![0.0; Decoder::tables_len(&plan)];
        let decoder = Decoder::new(&plan, &mut tables).expect("preset is valid");
        let frames = row(&plan);
        let row = Row {
            frames: &frames,
            width: WIDTH,
            bit_depth: 12,
            column_limits: None,
        };
        let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
        let mut out = vec![PixelCandidates::<16>::new(); WIDTH];
        group.bench_with_input(BenchmarkId::from_parameter(name), &row, |b, row| {
            b.iter(|| {
                decoder
                    .decode_row(row, &mut scratch, &mut out)
                    .expect("row decodes")
            })
        });
        let per_pixel: Vec<usize> = out.iter().map(|p| p.candidates.len()).collect();
        println!(
            "{name}: {} frames, mean {:.2} candidates per pixel",
            plan.sequence_len(),
            per_pixel.iter().sum::<usize>() as f64 / WIDTH as f64
        );
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20).measurement_time(std::time::Duration::from_secs(4));
    targets = bench
}
criterion_main!(benches);
