//! A point is right or absent (issue 13): on the mirror scenes and the V-grooves, BFSM and EFSM
//! (two groups) scanned through the library path of `fsm scan` — decode with the calibration's
//! column limits, triangulate every candidate, select, then drop what the projector cannot
//! light directly, what a plane mirror hides and the pixels that straddle a depth edge — and
//! every output point compared with the simulator's true surface point. The default quality
//! filter ([`fsm_scan::selection::DEFAULT_MIN_QUALITY`]) is on in every scan.
//!
//! - wrong: output points more than 1 mm from the true point of their pixel (or on a pixel
//!   that sees no surface at all);
//! - completeness: the share of the directly lit pixels (away from edges) that keep a point
//!   within 1 mm of the truth.
//!
//! The default run scans a band of rows of each scene (`sphere_mirror` whole); the whole images
//! are
//! `cargo test -p fsm-tests --release --test workspace wrong_points:: -- --ignored --nocapture`.

use crate::support;

use std::ops::Range;
use std::sync::Arc;

use fsm_core::{GroupCount, ScanPlan};
use fsm_io::plan_file::MethodPlan;
use fsm_scan::metrics::{point_errors, PointErrors};
use fsm_scan::{NoPointCounts, SelectionParams};
use fsm_sim::comparison::{self, Scanned};
use fsm_sim::{Capture, LightTransport, Sensor, System};
use support::transport;

/// Distance from the truth beyond which a point is wrong, mm.
const WRONG_MM: f64 = 1.0;

struct Figures {
    errors: PointErrors,
    no_point: NoPointCounts,
}

fn scan(
    transport: &Arc<LightTransport>,
    plan: &ScanPlan,
    system: &System,
    tests_on: bool,
) -> Figures {
    let sensor = Sensor::default();
    let capture = Capture::new(transport.clone(), plan, system, sensor, 7).expect("capture");
    // The plan states the simulated camera's sensor, as a user states theirs.
    let mut plan = *plan;
    plan.decoding.sensor = sensor.datasheet();
    let params = SelectionParams {
        drop_fictitious: tests_on,
        drop_edges: tests_on,
        ..SelectionParams::for_calibration(&system.calibration)
    };
    let Scanned { surface, truth, .. } =
        comparison::scan_capture(&capture, &MethodPlan::Fsm(plan), system, &params)
            .expect("the capture scans");
    let (truth_mm, lit) = comparison::truth_points(&truth);
    Figures {
        errors: point_errors(&surface.point_mm, &truth_mm, &lit, WRONG_MM),
        no_point: surface.no_point_counts(),
    }
}

/// The bounds a scan with the tests on must keep: on its band of rows, the share of wrong
/// points (the goal is 0.1%; where a scene is above it, this is what the tests reach so
/// far, with margin) and the completeness over the directly lit pixels; on any rows, the share
/// of the right points the tests may cost (the edge test drops mixed pixels the truth does not
/// count as edges: up to 0.5% on the mirror scenes).
const BOUNDS: [(&str, &str, f64, f64, f64); 8] = [
    ("sphere_mirror", "BFSM", 0.001, 0.99, 0.005),
    ("sphere_mirror", "EFSM x2", 0.001, 0.97, 0.005),
    ("plane_mirror", "BFSM", 0.001, 0.99, 0.005),
    ("plane_mirror", "EFSM x2", 0.001, 0.95, 0.005),
    ("vgroove", "BFSM", 0.001, 0.99, 0.001),
    ("vgroove", "EFSM x2", 0.001, 0.99, 0.001),
    // The tests take 0.15% of the band's 3,946 right points and 0.3% of the whole image's
    // 23,713 (none before the decoder's runs had feet, which added right points the edge test
    // now judges).
    ("vgroove_glossy", "BFSM", 0.001, 0.96, 0.004),
    // EFSM under a broad glossy lobe: the decoder misses the direct light where a facet's
    // reflection outshines it (issue 12), and a band of 40 rows gives the selection too little
    // to judge from: this band keeps 663 wrong points (27%) and is 42% complete, where the
    // whole image is at 0.087% wrong and 69% complete. Since a point must be confirmed by its
    // neighbourhood (`Surface::drop_unconfirmed`) the tests cost 15% of the whole image's right
    // points here (its facets' points are noisy), and take its wrong points from 4.22% to
    // 0.087%. Bounded so that it cannot get worse unnoticed.
    ("vgroove_glossy", "EFSM x2", 0.30, 0.38, 0.20),
];

/// The share of wrong points every scene keeps over its whole image (issue 13's goal).
const WHOLE_IMAGE_WRONG: f64 = 0.001;

/// The rows of a scene the default run scans: rows 100..140, except on `sphere_mirror`, which
/// is scanned whole. Its mirror is found from the pixels that see, through it, wall the
/// projector lights directly (`fsm_scan::mirror`); in rows 100..140 the mirror shows only the
/// sphere's shadow, and a band holds too few such pixels for EFSM.
fn band(scene: &str) -> Range<u32> {
    if scene == "sphere_mirror" {
        0..240
    } else {
        100..140
    }
}

/// Scans every scene with both plans, with the tests off and on, and prints the figures: the
/// band of each scene, or whole images. The tests never add a wrong point and keep [`BOUNDS`];
/// on whole images every scene keeps the goal, at most 0.1% of the points wrong.
fn right_or_absent(whole: bool) {
    let system = System::bench();
    let plans = [
        ("BFSM", ScanPlan::paper_bfsm()),
        ("EFSM x2", ScanPlan::paper_efsm(GroupCount::Two)),
    ];
    let mut failures = Vec::new();
    for scene in ["sphere_mirror", "plane_mirror", "vgroove", "vgroove_glossy"] {
        let rows = if whole { 0..240 } else { band(scene) };
        let t = transport(scene, &system, rows.clone());
        for (name, plan) in &plans {
            let [off, on] = [false, true].map(|tests_on| {
                let f = scan(&t, plan, &system, tests_on);
                let e = f.errors;
                let (wrong, complete) = (e.wrong_share(), e.completeness());
                println!(
                    "{scene:>14} {name:<7} rows {rows:?} tests {:<3}: {} points, {} wrong ({:.3}%), \
                     directly lit pixels with a right point {:.2}% of {}; no point: {:?}",
                    if tests_on { "on" } else { "off" },
                    e.points,
                    e.wrong,
                    100.0 * wrong,
                    100.0 * complete,
                    e.lit,
                    f.no_point,
                );
                (e, wrong, complete)
            });
            let bound = BOUNDS
                .iter()
                .find(|b| b.0 == scene && b.1 == *name)
                .expect("a bound for every scan");
            let lost = off.0.lit_right.saturating_sub(on.0.lit_right) as f64;
            if lost > bound.4 * off.0.lit_right as f64 || on.0.wrong > off.0.wrong {
                failures.push(format!(
                    "{scene} {name}: right points {} -> {}, wrong {} -> {}",
                    off.0.lit_right, on.0.lit_right, off.0.wrong, on.0.wrong
                ));
            }
            if whole && on.1 > WHOLE_IMAGE_WRONG {
                failures.push(format!(
                    "{scene} {name}: {:.3}% wrong on the whole image (goal {:.1}%)",
                    100.0 * on.1,
                    100.0 * WHOLE_IMAGE_WRONG
                ));
            }
            if !whole && (on.1 > bound.2 || on.2 < bound.3) {
                failures.push(format!(
                    "{scene} {name}: {:.3}% wrong (bound {:.1}%), {:.2}% complete (bound {:.0}%)",
                    100.0 * on.1,
                    100.0 * bound.2,
                    100.0 * on.2,
                    100.0 * bound.3
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn every_point_is_right_or_absent_on_a_band_of_each_scene() {
    right_or_absent(false);
}

#[test]
#[ignore = "whole images: cargo test -p fsm-tests --release --test workspace wrong_points:: -- --ignored --nocapture"]
fn every_point_is_right_or_absent_on_the_whole_images() {
    right_or_absent(true);
}

/// The mirror is found at a camera size other than the bench's 320 × 240. At 640 × 480 the
/// mirror search's tolerances once shrank with the pixel's footprint while its voting grid
/// stayed 320 × 240: no mirror was found and 4.3% of EFSM's points were virtual images behind it
/// (seed 3; 0.07% since the tolerances scale with the grid).
#[test]
fn the_mirror_is_found_and_what_it_hides_removed_at_640_by_480() {
    let system = System::bench_with_camera(640, 480);
    let t = transport("sphere_mirror", &system, 0..480);
    let f = scan(&t, &ScanPlan::paper_efsm(GroupCount::Two), &system, true);
    let e = f.errors;
    println!(
        "sphere_mirror EFSM x2 640x480: {} points, {} wrong ({:.3}%), {:.2}% complete; {:?}",
        e.points,
        e.wrong,
        100.0 * e.wrong_share(),
        100.0 * e.completeness(),
        f.no_point
    );
    assert!(
        f.no_point.behind_mirror > 0,
        "no mirror found: {:?}",
        f.no_point
    );
    assert!(
        e.wrong_share() <= 0.0015,
        "{:.3}% wrong",
        100.0 * e.wrong_share()
    );
    assert!(
        e.completeness() >= 0.97,
        "{:.2}% complete",
        100.0 * e.completeness()
    );
}
