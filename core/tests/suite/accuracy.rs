//! Decoding accuracy on synthetic pixels: every projector column, blurred spots at fractional
//! positions, and pairs of lights more than 2Δc apart (§IV-C). 12-bit samples, 1 DN read noise.

use crate::support;

use fsm_core::{GroupCount, GroupSet, PixelFlags, ScanPlan};
use support::{decode_all, nearest_error, Harness, Noise, Pixel};

#[test]
fn bfsm_recovers_every_column_with_one_candidate() {
    let plan = ScanPlan::paper_bfsm();
    let pixels: Vec<Pixel> = (0..768).map(|c| Pixel::column(c, 1200.0)).collect();
    let out = decode_all::<8>(plan, &pixels, 1);
    // Column 0's fringes are constant (cos 0 = 1 at every frequency): mean removal leaves
    // nothing, so no decoder can see it. Every other column is found, alone.
    assert!(
        out[0].candidates.is_empty(),
        "column 0: {:?}",
        out[0].candidates
    );
    let mut worst: f64 = 0.0;
    for (c, p) in out.iter().enumerate().skip(1) {
        assert_eq!(p.candidates.len(), 1, "column {c}: {:?}", p.candidates);
        worst = worst.max(nearest_error(p, c as f64));
    }
    println!("BFSM every column: worst error {worst:.4} column");
    assert!(worst < 0.02, "worst {worst}");
}

#[test]
fn efsm_two_groups_recover_every_column_and_cover_each_others_borders() {
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let coding = plan.block_coding().unwrap();
    let pixels: Vec<Pixel> = (0..768).map(|c| Pixel::column(c, 1200.0)).collect();
    let out = decode_all::<8>(plan, &pixels, 2);
    let mut worst: f64 = 0.0;
    for (c, p) in out.iter().enumerate() {
        assert_eq!(p.candidates.len(), 1, "column {c}: {:?}", p.candidates);
        worst = worst.max(nearest_error(p, c as f64));
        // The groups that see the column: those where it lies inside the border guard (columns
        // exactly on the guard's edge may fall either way by a rounding error).
        let margin = |group| {
            let (_, local) = plan.block_of(c as u32, group);
            fsm_core::block::border_margin(local as f32, &coding) - coding.border_guard
        };
        let mut expected = GroupSet::default();
        for group in plan.groups() {
            if margin(group) > 0.0 {
                expected = expected.union(GroupSet::only(group));
            }
        }
        let found = p.candidates[0].groups;
        let on_edge = plan.groups().any(|g| margin(g) == 0.0);
        assert!(
            found == expected || on_edge,
            "column {c}: {found:?} vs {expected:?}"
        );
        // Where both groups see the column whole (its fit inside the block) their views are
        // averaged; otherwise the view is the group's that sees it further from a border.
        let whole = |g| margin(g) + coding.border_guard >= 3.5;
        let best = plan.groups().map(margin).fold(f32::MIN, f32::max);
        let averaged = plan.groups().all(whole);
        assert!(
            averaged || margin(p.candidates[0].group) == best,
            "column {c}"
        );
    }
    println!("EFSM two groups every column: worst error {worst:.4} column");
    assert!(worst < 0.02, "worst {worst}");
}

#[test]
fn efsm_one_group_loses_only_the_guarded_borders() {
    let plan = ScanPlan::paper_efsm(GroupCount::One);
    let coding = plan.block_coding().unwrap();
    let pixels: Vec<Pixel> = (0..768).map(|c| Pixel::column(c, 1200.0)).collect();
    let out = decode_all::<8>(plan, &pixels, 3);
    for (c, p) in out.iter().enumerate() {
        let local = (c % 64) as f32;
        let margin = fsm_core::block::border_margin(local, &coding) - coding.border_guard;
        if margin == 0.0 {
            continue; // on the guard's edge: either outcome is right
        }
        if margin > 0.0 {
            assert_eq!(p.candidates.len(), 1, "column {c}: {:?}", p.candidates);
            assert!(
                nearest_error(p, c as f64) < 0.02,
                "column {c}: {:?}",
                p.candidates
            );
        } else {
            assert!(
                p.candidates.is_empty(),
                "column {c} is in the border guard: {:?}",
                p.candidates
            );
        }
    }
}

#[test]
fn blurred_spots_at_fractional_columns() {
    for plan in [
        ScanPlan::paper_bfsm(),
        ScanPlan::paper_efsm(GroupCount::Two),
    ] {
        for sigma in [0.4, 0.7, 1.0] {
            let centres: Vec<f64> = (0..320).map(|i| 3.3 + i as f64 * 2.37).collect();
            let pixels: Vec<Pixel> = centres
                .iter()
                .map(|&c| Pixel::spot(c, sigma, 1500.0))
                .collect();
            let out = decode_all::<8>(plan, &pixels, 4);
            let (mut worst, mut sum_sq): (f64, f64) = (0.0, 0.0);
            for ((p, px), &c) in out.iter().zip(&pixels).zip(&centres) {
                let e = nearest_error(p, px.centroid_near(c));
                assert_eq!(
                    p.candidates.len(),
                    1,
                    "centre {c} σ {sigma}: {:?}",
                    p.candidates
                );
                worst = worst.max(e);
                sum_sq += e * e;
            }
            let rms = (sum_sq / centres.len() as f64).sqrt();
            println!(
                "{:?} spot σ {sigma}: RMS {rms:.4}, worst {worst:.4} column",
                plan.method
            );
            assert!(
                worst < 0.05 && rms < 0.01,
                "σ {sigma}: RMS {rms}, worst {worst}"
            );
        }
    }
}

#[test]
fn two_lights_more_than_two_resolution_steps_apart_are_both_found() {
    for plan in [
        ScanPlan::paper_bfsm(),
        ScanPlan::efsm(768, 64, GroupCount::One),
    ] {
        let two_dc = 2.0 * plan.column_resolution() as f64;
        let span = plan.span_columns() as f64;
        for separation in [two_dc + 0.2, two_dc + 1.0, 7.5, 12.0, 0.4 * span] {
            for ratio in [1.0, 0.5, 0.25] {
                let (mut worst, mut worst_amplitude): (f64, f64) = (0.0, 0.0);
                let mut h = Harness::new(plan);
                let mut noise = Noise::new(7);
                for i in 0..12 {
                    let a = 6.0 + i as f64 * 0.37;
                    let b = a + separation;
                    let (pa, pb) = (
                        Pixel::spot(a, 0.6, 1500.0),
                        Pixel::spot(b, 0.6, 1500.0 * ratio),
                    );
                    // Each light's own centroid and fringe modulation (PB = 1/2 of its DN).
                    let truths = [
                        (pa.centroid_near(a), 750.0),
                        (pb.centroid_near(b), 750.0 * ratio),
                    ];
                    let s = pa.plus(pb).samples(&plan, 1.0, 12, &mut noise);
                    let peaks = h.peaks(&s, fsm_core::Group::One, 12).peaks;
                    assert_eq!(
                        peaks.len(),
                        2,
                        "separation {separation} ratio {ratio} at {a}: {peaks:?}"
                    );
                    for (column, amplitude) in truths {
                        let distance = |p: &fsm_core::Peak| (p.column as f64 - column).abs();
                        let nearest = peaks
                            .iter()
                            .min_by(|p, q| distance(p).total_cmp(&distance(q)))
                            .unwrap();
                        worst = worst.max(distance(nearest));
                        worst_amplitude =
                            worst_amplitude.max((nearest.amplitude as f64 / amplitude - 1.0).abs());
                    }
                }
                println!(
                    "{:?} separation {separation:.1} ratio {ratio}: worst column error {worst:.4}, amplitude {:.2}%",
                    plan.method,
                    100.0 * worst_amplitude
                );
                let tolerance = if separation < 8.0 { 0.1 } else { 0.05 };
                assert!(
                    worst < tolerance,
                    "separation {separation} ratio {ratio}: worst {worst}"
                );
                assert!(
                    worst_amplitude < 0.02,
                    "separation {separation} ratio {ratio}: amplitude off by {worst_amplitude}"
                );
            }
        }
    }
}

/// EFSM cannot tell two lights apart whose local columns fall within one footprint of each
/// other modulo `cB` (paper §IV-C, with the cosine search's profile): both groups see one
/// mixed light; and where the two lights lie in different lit blocks within `2Δc`, each one
/// in the other's block is a candidate the selection cannot tell from the true one. Swept over
/// the local offset of a mirrored light (0.1-column steps, both sides): a pixel is flagged
/// aliased, or every candidate is a true light's local column in some block; beyond `2Δc`
/// none is flagged.
#[test]
fn efsm_flags_every_pixel_whose_lights_mix_modulo_the_block_width() {
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let cb = 64.0;
    let direct = 308.7;
    let offsets: Vec<f64> = (-80..=80).map(|i| i as f64 * 0.1).collect();
    let pixels: Vec<Pixel> = offsets
        .iter()
        .map(|&o| {
            Pixel::spot(direct, 0.7, 1500.0).plus(Pixel::spot(direct - 2.0 * cb + o, 0.7, 900.0))
        })
        .collect();
    let decoded = decode_all::<8>(plan, &pixels, 11);
    let (mut flagged, mut worst): (Vec<f64>, f64) = (Vec::new(), 0.0);
    for (p, &offset) in decoded.iter().zip(&offsets) {
        if p.flags.contains(PixelFlags::ALIASED) {
            flagged.push(offset);
            continue;
        }
        let truths = [direct, direct - 2.0 * cb + offset];
        for c in &p.candidates {
            let local = |t: f64| {
                let d = (c.column as f64 - t).rem_euclid(cb);
                d.min(cb - d)
            };
            worst = worst.max(
                truths
                    .iter()
                    .map(|&t| local(t))
                    .fold(f64::INFINITY, f64::min),
            );
        }
        assert!(p.candidates.len() >= 2, "offset {offset}: {p:?}");
    }
    let widest = flagged.iter().fold(0.0f64, |m, o| m.max(o.abs()));
    println!(
        "EFSM 2 groups, cosine: {} of {} offsets flagged (|offset| <= {widest:.1}); \
         unflagged worst local-column error {worst:.3}",
        flagged.len(),
        offsets.len()
    );
    assert!(
        widest <= 2.0 * plan.column_resolution() as f64,
        "flagged up to {widest}"
    );
    assert!(worst < 0.2, "an unflagged pixel's candidate is {worst} off");
}

/// The DFT searches cannot tell two lights apart whose local columns fall within `2Δc` of each
/// other modulo `cB` (paper §IV-C): both groups see one blended peak, or two peaks pulled
/// towards each other. The decoder flags such pixels aliased; lights further apart modulo
/// `cB`, and light spread over many blocks (diffuse interreflection), are decoded exactly and
/// not flagged; BFSM never flags.
#[test]
fn efsm_clean_flags_lights_unresolved_modulo_the_block_width() {
    let plan = ScanPlan::paper_efsm(GroupCount::Two).with_clean();
    let cb = 64.0;
    let two_dc = 2.0 * plan.column_resolution() as f64;
    let direct = 308.7;
    // A mirrored light in another block, at `offset` local columns from the direct one.
    let pixel = |offset: f64| {
        Pixel::spot(direct, 0.7, 1500.0).plus(Pixel::spot(direct - 2.0 * cb + offset, 0.7, 900.0))
    };
    let unresolved = [0.0, 0.8, 1.6, 2.5, 3.2, -1.6, -3.2];
    let resolved = [two_dc + 1.0, 9.5, 20.0, -20.0, -(two_dc + 1.0)];
    let pixels: Vec<Pixel> = unresolved
        .iter()
        .chain(&resolved)
        .map(|&o| pixel(o))
        .chain([Pixel::spot(direct, 0.7, 1500.0)])
        // Diffuse interreflection: light spread over 500 columns lights many masks, no peak.
        .chain([Pixel::spot(direct, 0.7, 1500.0).plus(Pixel {
            lights: (100..600).map(|j| (j, 1.5)).collect(),
            ambient: 0.0,
        })])
        .collect();
    let decoded = decode_all::<8>(plan, &pixels, 11);
    for (p, offset) in decoded.iter().zip(&unresolved) {
        assert!(
            p.flags.contains(PixelFlags::ALIASED),
            "offset {offset}: not flagged, {p:?}"
        );
    }
    for (p, offset) in decoded[unresolved.len()..].iter().zip(&resolved) {
        assert!(
            !p.flags.contains(PixelFlags::ALIASED),
            "offset {offset}: flagged, {p:?}"
        );
        let truth = pixels[0].centroid_near(direct);
        assert!(nearest_error(p, truth) < 0.05, "offset {offset}: {p:?}");
    }
    let truth = pixels[0].centroid_near(direct);
    for p in &decoded[unresolved.len() + resolved.len()..] {
        assert!(!p.flags.contains(PixelFlags::ALIASED), "{p:?}");
        assert!(nearest_error(p, truth) < 0.05, "{p:?}");
    }

    let bfsm = decode_all::<8>(ScanPlan::paper_bfsm().with_clean(), &pixels, 12);
    assert!(bfsm.iter().all(|p| !p.flags.contains(PixelFlags::ALIASED)));
}
