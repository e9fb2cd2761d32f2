//! The projector's gamma and its correction, on the simulator.
//!
//! A projector with `light = code^2.2` turns each fringe `PA + PB·cos(2π f_m c)` into a distorted
//! wave: `Σ_k a_k cos(2π k f_m c)`. Over the sequence, harmonic `k` of a pixel lit by column `c`
//! varies as `cos(2π (k c / L)(n1 + m))`, which the decoder reads as light from column `k·c`,
//! folded into the c-domain `[0, L/2]` (the magnitude spectrum of real samples repeats every
//! `L` columns and mirrors about `L/2`): ghost peaks at columns the plan predicts
//! ([`harmonic_column`]). This test renders BFSM on the `plane` scene with a gamma-2.2
//! projector and shows
//!
//! 1. without correction, most measurable pixels get ghost candidates, and they sit at the
//!    predicted harmonic columns;
//! 2. the response estimated from simulated grey-level captures recovers the gamma;
//! 3. patterns pre-corrected with it (8-bit codes, as `fsm patterns --gamma` writes them) bring
//!    the ghosts down to a small share and the direct column back to a linear projector's
//!    accuracy.
//!
//! A band of 8 rows of the 320 × 240 bench keeps it to a few seconds:
//! `cargo test -p fsm-tests --test workspace gamma:: -- --nocapture` prints the measured numbers.

use std::sync::Arc;

use fsm_core::{Decoder, PixelCandidates, Row, ScanPlan};
use fsm_io::patterns::pattern_row;
use fsm_io::projector_response::{estimate, grey_level_codes, ProjectorResponse};
use fsm_sim::capture::{DrivenCodes, UniformLevels};
use fsm_sim::{
    Capture, LightTransport, PatternSequence, PixelTruth, Scene, Sensor, SurfaceClass, System,
    TransportSettings,
};

/// Candidates kept per pixel.
const K: usize = 8;
/// The simulated projector's gamma.
const GAMMA: f64 = 2.2;
/// Rows of the bench camera rendered.
const ROWS: std::ops::Range<u32> = 112..120;
/// Grey levels of the response measurement (as `fsm calibrate response --levels 17`).
const LEVELS: usize = 17;
/// Projector code depth of the pre-corrected patterns (`fsm patterns`' default 8-bit).
const PROJECTOR_MAX_CODE: u16 = 255;
/// Harmonics whose ghost columns are predicted.
const HARMONICS: [u32; 3] = [2, 3, 4];

/// Where harmonic `k` of the fringes of a pixel lit by column `c` decodes: column `k·c`
/// folded into `[0, L/2]` (period `L` of the c-domain, mirrored about `L/2`).
fn harmonic_column(plan: &ScanPlan, k: u32, c: f64) -> f64 {
    let l = plan.band.period_columns as f64;
    let x = (k as f64 * c).rem_euclid(l);
    if x > l / 2.0 {
        l - x
    } else {
        x
    }
}

/// Pixels lit directly, away from depth and shadow edges.
fn measurable(t: &PixelTruth) -> bool {
    t.class == SurfaceClass::Diffuse && t.direct_column.is_finite() && t.direct > 0.0 && !t.edge
}

fn transport(system: &System) -> Arc<LightTransport> {
    let scene = Scene::preset("plane").expect("preset exists");
    Arc::new(
        LightTransport::compute_rows(&scene, system, &TransportSettings::default(), ROWS)
            .expect("transport computes"),
    )
}

/// Every row of `capture`, decoded: `(truth, candidates)` per pixel.
fn decode(capture: &Capture, plan: &ScanPlan) -> Vec<(PixelTruth, PixelCandidates<K>)> {
    let mut tables = vec![0.0; Decoder::tables_len(plan)];
    let decoder = Decoder::new(plan, &mut tables).expect("valid plan");
    let mut scratch = vec![0.0; Decoder::scratch_len(plan)];
    let width = capture.width() as usize;
    let mut frames = vec![0u16; capture.frame_count() * width];
    let mut out = vec![PixelCandidates::<K>::new(); width];
    let mut pixels = Vec::new();
    for y in capture.rows() {
        capture.render_row(y, &mut frames).expect("row renders");
        let row = Row {
            frames: &frames,
            width,
            bit_depth: capture.bit_depth(),
            column_limits: None,
        };
        decoder
            .decode_row(&row, &mut scratch, &mut out)
            .expect("row decodes");
        for (x, c) in out.iter().enumerate() {
            let truth = *capture.ground_truth().pixel(x as u32, y).expect("truth");
            pixels.push((truth, c.clone()));
        }
    }
    pixels
}

/// Ghost statistics of a decoded capture.
#[derive(Debug)]
struct Ghosts {
    /// Measurable pixels.
    pixels: usize,
    /// … with at least one candidate farther than `2Δc` from the true column.
    with_ghost: usize,
    /// Such candidates, …
    ghosts: usize,
    /// … of which within `HARMONIC_TOLERANCE` of a predicted harmonic column.
    at_harmonic: usize,
    /// … of which at the second harmonic.
    at_second: usize,
    /// … of which at a second harmonic mirrored about `L/2` (`2c > L/2`): the folding matters.
    at_second_mirrored: usize,
    /// Largest distance of a ghost from its nearest predicted harmonic column.
    worst_harmonic_distance: f64,
    /// RMS of the strongest candidate's error, columns.
    direct_rms: f64,
    /// Pixels whose strongest candidate is not within `2Δc` of the truth.
    direct_wrong: usize,
}

impl Ghosts {
    fn share(&self) -> f64 {
        self.with_ghost as f64 / self.pixels as f64
    }
}

/// A ghost lies within this many columns of a predicted harmonic column: a pixel's footprint
/// spans about 2 columns (×k at harmonic k), plus the projector blur.
const HARMONIC_TOLERANCE: f64 = 6.0;

fn ghosts(plan: &ScanPlan, decoded: &[(PixelTruth, PixelCandidates<K>)]) -> Ghosts {
    // Separable columns are more than 2Δc apart (SPEC §2): closer is the direct peak itself.
    let near = 2.0 * plan.column_resolution() as f64;
    let mut g = Ghosts {
        pixels: 0,
        with_ghost: 0,
        ghosts: 0,
        at_harmonic: 0,
        at_second: 0,
        at_second_mirrored: 0,
        worst_harmonic_distance: 0.0,
        direct_rms: 0.0,
        direct_wrong: 0,
    };
    let mut errors = Vec::new();
    for (truth, c) in decoded {
        if !measurable(truth) {
            continue;
        }
        g.pixels += 1;
        let t = truth.direct_column;
        match c.strongest() {
            Some(k) if (k.column as f64 - t).abs() <= near => {
                errors.push(k.column as f64 - t);
            }
            _ => g.direct_wrong += 1,
        }
        let mut any = false;
        for k in &c.candidates {
            let col = k.column as f64;
            if (col - t).abs() <= near {
                continue;
            }
            any = true;
            g.ghosts += 1;
            let distance = |h: u32| (col - harmonic_column(plan, h, t)).abs();
            let nearest = HARMONICS
                .iter()
                .map(|&h| distance(h))
                .fold(f64::INFINITY, f64::min);
            g.worst_harmonic_distance = g.worst_harmonic_distance.max(nearest);
            if HARMONICS.iter().any(|&h| distance(h) <= HARMONIC_TOLERANCE) {
                g.at_harmonic += 1;
            }
            if distance(2) <= HARMONIC_TOLERANCE {
                g.at_second += 1;
                if 2.0 * t > plan.band.period_columns as f64 / 2.0 {
                    g.at_second_mirrored += 1;
                }
            }
        }
        g.with_ghost += any as usize;
    }
    g.direct_rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64).sqrt();
    g
}

/// Simulated grey-level captures through the scene (one frame per level, every rendered row),
/// as images of the band: `images[level][pixel]`.
fn grey_captures(
    transport: &Arc<LightTransport>,
    system: &System,
    sensor: Sensor,
    fractions: &[f64],
) -> Vec<Vec<u16>> {
    let levels = UniformLevels::new(
        system.projector_columns() as u16,
        fractions.iter().map(|&f| f as f32).collect(),
    );
    let capture = Capture::new(transport.clone(), &levels, system, sensor, 99).expect("capture");
    let w = capture.width() as usize;
    let mut images = vec![Vec::new(); fractions.len()];
    for y in capture.rows() {
        let row = capture.row(y).expect("row renders");
        for (i, image) in images.iter_mut().enumerate() {
            image.extend_from_slice(&row[i * w..(i + 1) * w]);
        }
    }
    images
}

/// The projector code `fsm patterns` writes for light `value` with `response` (8-bit).
fn precorrected(response: &ProjectorResponse, value: f32) -> f32 {
    let max = PROJECTOR_MAX_CODE as f64;
    ((response.code_for(value as f64) * max)
        .round()
        .clamp(0.0, max)
        / max) as f32
}

#[test]
fn harmonic_columns_fold_into_the_c_domain() {
    let plan = ScanPlan::paper_bfsm(); // L = 1536: the c-domain is [0, 768]
    assert_eq!(harmonic_column(&plan, 2, 100.0), 200.0);
    assert_eq!(harmonic_column(&plan, 2, 500.0), 536.0); // 1000 mirrored about 768
    assert_eq!(harmonic_column(&plan, 3, 600.0), 264.0); // 1800 − 1536
    assert_eq!(harmonic_column(&plan, 2, 512.0), 512.0); // coincides with the direct column
}

#[test]
fn gamma_ghosts_appear_without_correction_and_vanish_with_the_measured_response() {
    let plan = ScanPlan::paper_bfsm();
    let sensor = Sensor::default();
    let linear = System::bench();
    let system = System {
        gamma: GAMMA,
        black_level: 0.002,
        ..System::bench()
    };
    let lt = transport(&system);

    // A linear projector: the reference accuracy.
    let reference = ghosts(
        &plan,
        &decode(
            &Capture::new(lt.clone(), &plan, &linear, sensor, 3).unwrap(),
            &plan,
        ),
    );
    println!("linear projector: {reference:?}");

    // 1. Gamma 2.2, patterns as they are.
    let raw = ghosts(
        &plan,
        &decode(
            &Capture::new(lt.clone(), &plan, &system, sensor, 3).unwrap(),
            &plan,
        ),
    );
    println!("gamma {GAMMA}, no correction: {raw:?}");
    println!(
        "  {:.1}% of {} measurable pixels have ghost candidates; {:.1}% of the {} ghosts lie within {HARMONIC_TOLERANCE} columns of a predicted harmonic column ({:.1}% at the 2nd)",
        100.0 * raw.share(),
        raw.pixels,
        100.0 * raw.at_harmonic as f64 / raw.ghosts as f64,
        raw.ghosts,
        100.0 * raw.at_second as f64 / raw.ghosts as f64,
    );
    assert!(raw.pixels > 1500, "{raw:?}");
    assert!(
        reference.share() <= 0.01,
        "a linear projector shows no ghosts: {reference:?}"
    );
    assert!(raw.share() >= 0.5, "ghosts expected: {raw:?}");
    assert!(
        raw.at_harmonic as f64 >= 0.95 * raw.ghosts as f64,
        "ghosts away from the predicted harmonics: {raw:?}"
    );
    // Both sides of the fold are seen: 2c below and above L/2.
    assert!(raw.at_second_mirrored >= raw.ghosts / 10, "{raw:?}");
    assert!(
        raw.at_second - raw.at_second_mirrored >= raw.ghosts / 10,
        "{raw:?}"
    );

    // 2. The response from grey-level captures of the same scene.
    let codes = grey_level_codes(LEVELS, PROJECTOR_MAX_CODE).unwrap();
    let fractions: Vec<f64> = codes
        .iter()
        .map(|&c| c as f64 / PROJECTOR_MAX_CODE as f64)
        .collect();
    let images = grey_captures(&lt, &system, sensor, &fractions);
    let refs: Vec<&[u16]> = images.iter().map(|v| v.as_slice()).collect();
    let estimate = estimate(
        &fractions,
        system.width() as usize,
        &refs,
        sensor.max_code(),
    )
    .expect("response estimates");
    println!(
        "estimated gamma {:.4} (true {GAMMA}), fit RMS {:.2e}, {} of {} pixels used ({} saturated, {} dim)",
        estimate.gamma,
        estimate.fit_rms,
        estimate.pixels_used,
        estimate.pixels,
        estimate.pixels_saturated,
        estimate.pixels_dim
    );
    assert!((estimate.gamma - GAMMA).abs() <= 0.05, "{estimate:?}");
    assert!(estimate.fit_rms <= 0.005, "{estimate:?}");

    // 3. Pre-corrected patterns, re-rendered: with the fitted gamma and with the table.
    for (name, response) in [
        ("fitted gamma", estimate.gamma_response()),
        ("measured table", estimate.table_response()),
    ] {
        let code = |v: f32| precorrected(&response, v);
        // The codes are the ones `fsm patterns` writes.
        for index in [2, 100, 400, 769] {
            let pattern = plan.pattern(index).unwrap();
            let row = pattern_row(&plan, pattern, 768, PROJECTOR_MAX_CODE, Some(&response));
            for x in [0usize, 17, 300, 767] {
                let value = plan.frame_intensity(index, x as u32);
                assert_eq!(code(value), (row[x] as f64 / 255.0) as f32);
            }
        }
        let driven = DrivenCodes::new(&plan, code);
        let corrected = ghosts(
            &plan,
            &decode(
                &Capture::new(lt.clone(), &driven, &system, sensor, 3).unwrap(),
                &plan,
            ),
        );
        println!(
            "gamma {GAMMA}, pre-corrected with the {name}: {corrected:?}\n  {:.2}% of pixels with ghosts (were {:.1}%), direct RMS {:.4} column (linear projector {:.4})",
            100.0 * corrected.share(),
            100.0 * raw.share(),
            corrected.direct_rms,
            reference.direct_rms
        );
        assert!(corrected.share() <= 0.01, "{name}: {corrected:?}");
        assert_eq!(corrected.direct_wrong, 0, "{name}: {corrected:?}");
        assert!(corrected.direct_rms <= 0.05, "{name}: {corrected:?}");
        assert!(
            corrected.direct_rms <= 1.5 * reference.direct_rms + 0.005,
            "{name}: {corrected:?} vs linear {reference:?}"
        );
    }
}
