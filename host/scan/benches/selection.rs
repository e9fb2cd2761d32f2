//! Selection throughput: `cargo bench -p fsm-scan --bench selection`. The demo scene's size
//! (320 × 240) and a larger camera, 4 candidates per pixel: one on a plane, three fictitious.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use fsm_scan::{select, CandidateField, Label, Paths, SelectionParams};

fn field(width: usize, height: usize) -> CandidateField {
    CandidateField::from_fn(width, height, |x, y| {
        let p = [x as f32 * 0.5, y as f32 * 0.5, 500.0 + 0.1 * x as f32];
        (0..4).map(move |k| Label {
            point_mm: [p[0] * (1.0 + 0.05 * k as f32), p[1], p[2] + 35.0 * k as f32],
            amplitude: 100.0 - 10.0 * k as f32,
            column: 0.0,
        })
    })
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("select_4_candidates");
    for (w, h) in [(320, 240), (640, 480)] {
        let f = field(w, h);
        group.throughput(Throughput::Elements((w * h) as u64));
        for paths in [Paths::Eight, Paths::Sixteen] {
            let params = SelectionParams {
                paths,
                ..SelectionParams::for_footprint(0.5)
            };
            group.bench_with_input(
                BenchmarkId::new(format!("{paths:?}"), format!("{w}x{h}")),
                &f,
                |b, f| b.iter(|| select(f, &params)),
            );
        }
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
