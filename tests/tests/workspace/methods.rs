//! Every method of the paper's comparison through the same path (render, decode with the
//! calibration's column limits, triangulate, select), against the simulator's ground truth:
//! on a plane (each method within its expected precision; BFSM ahead of line scanning with as
//! many patterns, paper Fig. 13) and beside a mirror (line scanning keeps the direct light as
//! FSM does; phase shift and Micro Phase Shifting lose it, paper Figs. 9–10).
//!
//! The default run scans a band of rows; the figures print with `--nocapture`:
//! `cargo test -p fsm-tests --test workspace methods:: -- --nocapture`.

use crate::support;

use std::ops::Range;

use fsm_io::plan_file::MethodPlan;
use fsm_scan::SelectionParams;
use fsm_sim::comparison::{self, Scanned};
use fsm_sim::{PixelTruth, Sensor, System};
use support::transport;

/// `fsm demo`'s plans of the four methods compared here, in this order.
fn methods() -> [(&'static str, MethodPlan); 4] {
    let all = comparison::Plans::paper().methods();
    ["BFSM", "PS", "MPS", "LS"].map(|name| {
        *all.iter()
            .find(|(n, _)| *n == name)
            .expect("fsm demo compares it")
    })
}

/// Of the directly lit pixels (away from edges): the share with a point, the share of those
/// within 0.5 column of the truth, and the column RMS of the latter.
struct Columns {
    pixels: usize,
    completeness: f64,
    within_half: f64,
    rms: f64,
}

fn columns(s: &Scanned, select: impl Fn(&PixelTruth) -> bool) -> Columns {
    let (mut pixels, mut points, mut near, mut sum) = (0usize, 0usize, 0usize, 0.0f64);
    for (i, t) in s.truth.iter().enumerate() {
        if !t.is_lit_directly() || !select(t) {
            continue;
        }
        pixels += 1;
        if let Some(c) = s.surface.column[i] {
            points += 1;
            let e = c as f64 - t.direct_column;
            if e.abs() <= 0.5 {
                near += 1;
                sum += e * e;
            }
        }
    }
    Columns {
        pixels,
        completeness: points as f64 / pixels.max(1) as f64,
        within_half: near as f64 / points.max(1) as f64,
        rms: (sum / near.max(1) as f64).sqrt(),
    }
}

fn scan(scene: &str, rows: Range<u32>, method: MethodPlan, seed: u64) -> Scanned {
    let system = System::bench();
    let t = transport(scene, &system, rows);
    let capture =
        comparison::capture_of(&method, &t, &system, Sensor::default(), seed).expect("capture");
    let params = SelectionParams::for_calibration(&system.calibration);
    comparison::scan_capture(&capture, &method, &system, &params).expect("the capture scans")
}

#[test]
fn every_method_measures_a_plane() {
    let mut rms = Vec::new();
    for (name, method) in methods() {
        let c = columns(&scan("plane", 110..126, method, 7), |_| true);
        println!(
            "plane, {name:>4} ({} patterns): {} pixels, {:.2}% with a point, {:.2}% of them within 0.5 column, column RMS {:.4}",
            method.patterns().pattern_count(),
            c.pixels,
            100.0 * c.completeness,
            100.0 * c.within_half,
            c.rms
        );
        assert!(c.pixels > 3000, "{name}: {} pixels", c.pixels);
        assert!(c.completeness >= 0.99, "{name}: {}", c.completeness);
        assert!(c.within_half >= 0.999, "{name}: {}", c.within_half);
        rms.push(c.rms);
    }
    let [bfsm, ps, mps, ls] = rms[..] else {
        unreachable!()
    };
    // Every method is sub-column on a plane; their precision follows how much light codes each
    // column: BFSM's 768 patterns most, MPS's 17 least among the fringes.
    assert!(bfsm <= 0.01, "BFSM {bfsm}");
    assert!(ps <= 0.05 && mps <= 0.05, "PS {ps}, MPS {mps}");
    // Fig. 13: the same 768 patterns, about 10 times the precision for BFSM in the paper.
    println!(
        "LS / BFSM column RMS with 768 patterns each: {:.1}",
        ls / bfsm
    );
    assert!(ls >= 3.0 * bfsm, "LS {ls} vs BFSM {bfsm}");
}

#[test]
fn beside_a_mirror_line_scanning_keeps_the_direct_light_and_the_fringes_lose_it() {
    let mut share = Vec::new();
    for (name, method) in methods() {
        let s = scan("plane_mirror", 100..140, method, 8);
        // Pixels whose mirrored light is at least a fifth of their direct light.
        let c = columns(&s, |t| t.has_interreflection(0.2));
        println!(
            "plane_mirror, {name:>4}: {} interreflection pixels, {:.2}% with a point, {:.2}% of them within 0.5 column",
            c.pixels,
            100.0 * c.completeness,
            100.0 * c.within_half
        );
        assert!(c.pixels > 200, "{name}: the rows must cross the reflection");
        share.push(c.completeness * c.within_half);
    }
    let [bfsm, ps, mps, ls] = share[..] else {
        unreachable!()
    };
    assert!(bfsm >= 0.98 && ls >= 0.95, "BFSM {bfsm}, LS {ls}");
    assert!(ps <= 0.5 && mps <= 0.5, "PS {ps}, MPS {mps}");
}

#[test]
fn line_scanning_measures_pixels_that_see_six_columns() {
    // A 128 x 96 camera on the bench: each pixel sees about 6 projector columns, a flat-topped
    // footprint with 3-7% ripples. A 3-point fit at its highest sample was off by more than
    // half a column at 660 of these 5760 pixels; the centre of mass of the whole light is not.
    let system = System::bench_with_camera(128, 96);
    let t = transport("plane_mirror_covered", &system, 20..80);
    let [.., (_, method)] = methods();
    let capture = comparison::capture_of(&method, &t, &system, Sensor::default(), 1).unwrap();
    let params = SelectionParams::for_calibration(&system.calibration);
    let s = comparison::scan_capture(&capture, &method, &system, &params).unwrap();
    let c = columns(&s, |_| true);
    println!(
        "LS at 128 x 96: {} pixels, {:.2}% with a point, {:.2}% of them within 0.5 column, column RMS {:.4}",
        c.pixels,
        100.0 * c.completeness,
        100.0 * c.within_half,
        c.rms
    );
    assert!(c.pixels > 5000, "{}", c.pixels);
    assert!(c.completeness >= 0.99, "{}", c.completeness);
    assert!(c.within_half >= 0.999, "{}", c.within_half);
    assert!(c.rms <= 0.1, "{}", c.rms);
}
