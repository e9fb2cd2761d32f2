//! Shared helpers of the workspace-level tests: simulate a band of rows, decode it with the
//! core's line decoder, compare with the ground truth.
#![allow(dead_code)]

use std::sync::Arc;
use std::time::{Duration, Instant};

use fsm_core::{Decoder, PixelCandidates, Row, ScanPlan};
use fsm_sim::{Capture, LightTransport, PixelTruth, Scene, Sensor, System, TransportSettings};

/// Candidates kept per pixel in the tests.
pub const K: usize = 16;

/// A band of rows simulated and decoded, with timings.
pub struct Decoded {
    pub capture: Capture,
    /// `(x, y, truth, candidates)` of every pixel of the band.
    pub pixels: Vec<(u32, u32, PixelTruth, PixelCandidates<K>)>,
    pub transport_time: Duration,
    pub render_time: Duration,
    pub decode_time: Duration,
}

/// The light transport of `rows` of a preset scene on `system`.
pub fn transport(scene: &str, system: &System, rows: std::ops::Range<u32>) -> Arc<LightTransport> {
    let scene = Scene::preset(scene).expect("preset exists");
    Arc::new(
        LightTransport::compute_rows(&scene, system, &TransportSettings::default(), rows)
            .expect("transport computes"),
    )
}

/// Renders every row of `transport` with `plan` and decodes it, the plan stating `sensor`'s
/// noise ([`Sensor::datasheet`]).
pub fn simulate_and_decode(
    transport: Arc<LightTransport>,
    plan: &ScanPlan,
    system: &System,
    sensor: Sensor,
    seed: u64,
) -> Decoded {
    let capture = Capture::new(transport, plan, system, sensor, seed).expect("capture");
    // The plan states the simulated camera's sensor, as a user states theirs.
    let mut plan = *plan;
    plan.decoding.sensor = sensor.datasheet();
    let plan = &plan;
    let mut tables = vec![0.0; Decoder::tables_len(plan)];
    let decoder = Decoder::new(plan, &mut tables).expect("valid plan");
    let mut scratch = vec![0.0; Decoder::scratch_len(plan)];
    let width = capture.width() as usize;
    let mut pixels = Vec::new();
    let mut render_time = Duration::ZERO;
    let mut decode_time = Duration::ZERO;
    let mut frames = vec![0u16; capture.frame_count() * width];
    let mut out = vec![PixelCandidates::<K>::new(); width];
    for y in capture.rows() {
        let t = Instant::now();
        capture.render_row(y, &mut frames).expect("row renders");
        render_time += t.elapsed();
        let t = Instant::now();
        let row = Row {
            frames: &frames,
            width,
            bit_depth: capture.bit_depth(),
            column_limits: None,
        };
        decoder
            .decode_row(&row, &mut scratch, &mut out)
            .expect("row decodes");
        decode_time += t.elapsed();
        for (x, c) in out.iter().enumerate() {
            let truth = *capture
                .ground_truth()
                .pixel(x as u32, y)
                .expect("truth of the row");
            pixels.push((x as u32, y, truth, c.clone()));
        }
    }
    Decoded {
        capture,
        pixels,
        transport_time: Duration::ZERO,
        render_time,
        decode_time,
    }
}

/// Error of the candidate nearest to `truth` (infinity without candidates).
pub fn nearest_error(c: &PixelCandidates<K>, truth: f64) -> f64 {
    c.candidates
        .iter()
        .map(|k| (k.column as f64 - truth).abs())
        .fold(f64::INFINITY, f64::min)
}

/// RMS of a list of errors.
pub fn rms(errors: &[f64]) -> f64 {
    (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt()
}
