//! Render throughput of the simulator on the default scene (`plane_mirror`, bench system,
//! 320 × 240 camera): samples (frames × pixels) per second of one camera row through the sensor,
//! for the paper's BFSM and two-group EFSM plans, and the time to compute the scene's light
//! transport (all rows; rayon uses every core).
//! Run: `cargo bench -p fsm-sim --bench render`.

use std::sync::Arc;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use fsm_core::{GroupCount, ScanPlan};
use fsm_sim::{Capture, LightTransport, Scene, Sensor, System, TransportSettings};

fn bench(c: &mut Criterion) {
    let system = System::bench();
    let scene = Scene::preset("plane_mirror").expect("preset");
    let settings = TransportSettings::default();

    let mut group = c.benchmark_group("light_transport");
    group.sample_size(10);
    group.throughput(Throughput::Elements(
        (system.width() * system.height()) as u64,
    ));
    group.bench_function("plane_mirror_320x240", |b| {
        b.iter(|| LightTransport::compute(&scene, &system, &settings).expect("computes"))
    });
    group.finish();

    let transport =
        Arc::new(LightTransport::compute(&scene, &system, &settings).expect("computes"));
    let plans = [
        ("bfsm_m768", ScanPlan::paper_bfsm()),
        (
            "efsm_cb64_two_groups",
            ScanPlan::paper_efsm(GroupCount::Two),
        ),
    ];
    let mut group = c.benchmark_group("render_row");
    for (name, plan) in plans {
        let capture =
            Capture::new(transport.clone(), &plan, &system, Sensor::default(), 1).expect("capture");
        let mut out = vec![0u16; capture.frame_count() * capture.width() as usize];
        group.throughput(Throughput::Elements(out.len() as u64));
        group.bench_with_input(BenchmarkId::from_parameter(name), &120u32, |b, &y| {
            b.iter(|| capture.render_row(y, &mut out).expect("renders"))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
