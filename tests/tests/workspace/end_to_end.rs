//! First end-to-end checks: simulated captures decoded by `fsm_core::Decoder`, against the
//! simulator's ground truth. A band of rows of the default bench (320 × 240 camera) keeps the
//! default run in seconds; the full-image runs are `#[ignore]`d:
//! `cargo test -p fsm-tests --release --test workspace end_to_end:: -- --ignored --nocapture`.

use crate::support;

use std::time::Instant;

use fsm_core::{GroupCount, ScanPlan};
use fsm_sim::{Sensor, SurfaceClass, System};
use support::{nearest_error, rms, simulate_and_decode, transport};

/// Pixels lit directly, away from depth and shadow edges: where a direct column is defined
/// and measurable.
fn measurable(t: &fsm_sim::PixelTruth) -> bool {
    t.class == SurfaceClass::Diffuse && t.direct_column.is_finite() && t.direct > 0.0 && !t.edge
}

fn plane_direct_column_rms(plan: ScanPlan, name: &str, rows: std::ops::Range<u32>) -> f64 {
    let system = System::bench();
    let t0 = Instant::now();
    let lt = transport("plane", &system, rows.clone());
    let transport_time = t0.elapsed();
    let d = simulate_and_decode(lt, &plan, &system, Sensor::default(), 11);
    let mut errors = Vec::new();
    let mut missing = 0;
    for (_, _, truth, c) in &d.pixels {
        if !measurable(truth) {
            continue;
        }
        match c.strongest() {
            Some(k) => errors.push(k.column as f64 - truth.direct_column),
            None => missing += 1,
        }
    }
    let r = rms(&errors);
    let worst = errors.iter().fold(0.0f64, |a, e| a.max(e.abs()));
    let mean = errors.iter().sum::<f64>() / errors.len() as f64;
    println!(
        "{name} on plane, rows {rows:?}: {} pixels, RMS {r:.4} column, bias {mean:+.4}, worst {worst:.3}, {missing} without candidate; transport {:.2?}, render {:.2?}, decode {:.2?}",
        errors.len(),
        transport_time,
        d.render_time,
        d.decode_time
    );
    assert_eq!(missing, 0);
    assert!(errors.len() > 1000, "{} pixels", errors.len());
    r
}

#[test]
fn bfsm_decodes_the_plane_within_0_05_column_rms() {
    let r = plane_direct_column_rms(ScanPlan::paper_bfsm(), "BFSM", 112..118);
    assert!(r <= 0.05, "RMS {r}");
}

#[test]
fn efsm_two_groups_decode_the_plane_within_0_05_column_rms() {
    let r = plane_direct_column_rms(
        ScanPlan::paper_efsm(GroupCount::Two),
        "EFSM cB 64 x2",
        112..118,
    );
    assert!(r <= 0.05, "RMS {r}");
}

#[test]
fn bfsm_on_plane_mirror_finds_the_direct_column_among_the_candidates() {
    let system = System::bench();
    let rows = 104..116;
    let t0 = Instant::now();
    let lt = transport("plane_mirror", &system, rows.clone());
    let transport_time = t0.elapsed();
    let d = simulate_and_decode(lt, &ScanPlan::paper_bfsm(), &system, Sensor::default(), 5);
    let (mut inter, mut inter_ok, mut inter_errors) = (0, 0, Vec::new());
    let (mut direct_only, mut direct_only_single) = (0, 0);
    let mut counts = [0usize; 4];
    for (x, y, truth, c) in &d.pixels {
        if !measurable(truth) {
            continue;
        }
        if truth.is_interreflection() {
            inter += 1;
            let e = nearest_error(c, truth.direct_column);
            if e <= 0.5 {
                inter_ok += 1;
                inter_errors.push(e);
            } else {
                println!(
                    "miss at ({x}, {y}): truth {:.2}, {:?}",
                    truth.direct_column,
                    c.candidates
                        .iter()
                        .map(|k| (k.column, k.amplitude))
                        .collect::<Vec<_>>()
                );
            }
            counts[c.candidates.len().min(3)] += 1;
        }
        if truth.is_direct_only() {
            direct_only += 1;
            if c.candidates.len() == 1 {
                direct_only_single += 1;
            } else {
                println!(
                    "direct-only pixel ({x}, {y}) with {} candidates: truth {:.2}, {:?}",
                    c.candidates.len(),
                    truth.direct_column,
                    c.candidates
                        .iter()
                        .map(|k| (k.column, k.amplitude))
                        .collect::<Vec<_>>()
                );
            }
        }
    }
    let share = inter_ok as f64 / inter as f64;
    println!(
        "BFSM on plane_mirror, rows {rows:?}: {inter} interreflection pixels, {:.2}% with a candidate within 0.5 column (RMS {:.4} column), candidate counts 0/1/2/3+ = {counts:?}; {direct_only} direct-only pixels, {direct_only_single} with exactly one candidate; transport {:.2?}, render {:.2?}, decode {:.2?}",
        100.0 * share,
        rms(&inter_errors),
        transport_time,
        d.render_time,
        d.decode_time
    );
    assert!(inter > 500, "{inter} interreflection pixels");
    assert!(direct_only > 500, "{direct_only} direct-only pixels");
    assert!(share >= 0.99, "{share}");
    assert_eq!(direct_only_single, direct_only);
}

/// Statistics of one decoded capture against its truth.
struct Figures {
    measurable: usize,
    direct_rms: f64,
    missing: usize,
    interreflection: usize,
    interreflection_within_half: usize,
    interreflection_rms: f64,
    direct_only: usize,
    direct_only_single: usize,
    /// Interreflection pixels without a candidate within 0.5 column whose mirrored column lies
    /// within 3 columns of the direct one modulo 64 (EFSM cB 64 cannot separate those, §IV-C).
    misses_aliased_mod_64: usize,
}

fn figures(d: &support::Decoded) -> Figures {
    let mut f = Figures {
        measurable: 0,
        direct_rms: 0.0,
        missing: 0,
        interreflection: 0,
        interreflection_within_half: 0,
        interreflection_rms: 0.0,
        direct_only: 0,
        direct_only_single: 0,
        misses_aliased_mod_64: 0,
    };
    let (mut direct, mut inter) = (Vec::new(), Vec::new());
    for (px, py, truth, c) in &d.pixels {
        let pixel = (*px, *py);
        if !measurable(truth) {
            continue;
        }
        f.measurable += 1;
        let e = nearest_error(c, truth.direct_column);
        if truth.is_interreflection() {
            f.interreflection += 1;
            if e <= 0.5 {
                f.interreflection_within_half += 1;
                inter.push(e);
            } else {
                let (x, y) = (pixel.0, pixel.1);
                let aliased = d
                    .capture
                    .transport()
                    .spans(x, y)
                    .filter(|s| s.kind == fsm_sim::PathKind::Specular)
                    .any(|s| {
                        let delta = (s.centroid() - truth.direct_column).rem_euclid(64.0);
                        delta.min(64.0 - delta) < 3.0
                    });
                f.misses_aliased_mod_64 += aliased as usize;
            }
        }
        // Lit only directly: the strongest candidate is the decoder's answer (with indirect
        // light, choosing among the candidates is the later selection's job).
        if truth.is_direct_only() {
            f.direct_only += 1;
            f.direct_only_single += (c.candidates.len() == 1) as usize;
            match c.strongest() {
                Some(k) => direct.push(k.column as f64 - truth.direct_column),
                None => f.missing += 1,
            }
        }
    }
    f.direct_rms = rms(&direct);
    f.interreflection_rms = rms(&inter);
    f
}

/// Full 320 × 240 images of `plane` and `plane_mirror`, BFSM and EFSM (two groups, cB 64):
/// `cargo test -p fsm-tests --release --test workspace end_to_end::full_image -- --ignored --nocapture`.
#[test]
#[ignore = "full-size run (about a minute): cargo test -p fsm-tests --release --test workspace end_to_end::full_image -- --ignored --nocapture"]
fn full_image_accuracy_of_bfsm_and_efsm() {
    let system = System::bench();
    for scene in ["plane", "plane_mirror"] {
        let t0 = Instant::now();
        let lt = transport(scene, &system, 0..system.height());
        let transport_time = t0.elapsed();
        for (name, plan) in [
            ("BFSM", ScanPlan::paper_bfsm()),
            ("EFSM cB 64 x2", ScanPlan::paper_efsm(GroupCount::Two)),
        ] {
            let d = simulate_and_decode(lt.clone(), &plan, &system, Sensor::default(), 21);
            let f = figures(&d);
            println!(
                "{scene} / {name} ({} patterns): {} measurable pixels, direct-only pixels' strongest candidate RMS {:.4} column, {} without candidate; interreflection pixels {}: {:.2}% within 0.5 column (RMS {:.4}), {} of the misses with the mirrored column within 3 columns of the direct one modulo 64; direct-only pixels {}: {:.2}% with one candidate; transport {:.2?} (all rows), render {:.2?}, decode {:.2?}",
                plan.pattern_count(),
                f.measurable,
                f.direct_rms,
                f.missing,
                f.interreflection,
                100.0 * f.interreflection_within_half as f64 / f.interreflection.max(1) as f64,
                f.interreflection_rms,
                f.misses_aliased_mod_64,
                f.direct_only,
                100.0 * f.direct_only_single as f64 / f.direct_only.max(1) as f64,
                transport_time,
                d.render_time,
                d.decode_time,
            );
            assert!(f.direct_rms <= 0.05, "{}", f.direct_rms);
            assert_eq!(f.missing, 0);
            if scene == "plane_mirror" && name == "BFSM" {
                assert!(f.interreflection_within_half as f64 >= 0.99 * f.interreflection as f64);
                assert_eq!(f.direct_only_single, f.direct_only);
            }
        }
    }
}

/// SPEC §7: with a sharp projector and a camera that out-resolves it (1280 × 960: 0.46 column
/// per pixel), every decoder is off the geometric truth by up to ±0.5 column; the default blur
/// removes the error.
/// `cargo test -p fsm-tests --release --test workspace end_to_end::sharp_projector -- --ignored --nocapture`.
#[test]
#[ignore = "1280 x 960 band: cargo test -p fsm-tests --release --test workspace end_to_end::sharp_projector -- --ignored --nocapture"]
fn sharp_projector_puts_every_decoder_off_by_up_to_half_a_column() {
    let mut worst = Vec::new();
    for sigma in [0.0, 0.7] {
        let mut system = System::bench_with_camera(1280, 960);
        system.blur_sigma_columns = sigma;
        let lt = transport("plane", &system, 478..482);
        let d = simulate_and_decode(lt, &ScanPlan::paper_bfsm(), &system, Sensor::default(), 4);
        let errors: Vec<f64> = d
            .pixels
            .iter()
            .filter(|(_, _, t, _)| measurable(t))
            .filter_map(|(_, _, t, c)| c.strongest().map(|k| k.column as f64 - t.direct_column))
            .collect();
        let w = errors.iter().fold(0.0f64, |a, e| a.max(e.abs()));
        println!(
            "plane, 1280 x 960, blur sigma {sigma} column: BFSM RMS {:.4} column, worst {w:.3} ({} pixels)",
            rms(&errors),
            errors.len()
        );
        worst.push((rms(&errors), w));
    }
    assert!(worst[0].0 > 3.0 * worst[1].0, "{worst:?}");
    assert!(worst[0].1 > 0.2 && worst[0].1 < 0.6, "{worst:?}");
    assert!(worst[1].0 <= 0.05, "{worst:?}");
}
