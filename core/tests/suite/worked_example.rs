//! Paper §V, as restated in SPEC §3: a pixel lit only directly (Qd, column 694.9) and a pixel
//! lit directly and via a mirror (Qid, columns 539.4 and 658.7), decoded with BFSM (cmax 768)
//! and with EFSM (cB = 32, both groups).
//!
//! The pixels are synthetic: light from a defocused projector (Gaussian spread of 0.6 column
//! over whole projector columns) centred on the paper's columns, 12-bit samples, 1 DN noise.

use crate::support;

use fsm_core::{Group, GroupCount, PixelCandidates, ScanPlan};
use support::{Harness, Noise, Pixel};

const TOLERANCE: f32 = 0.05;

fn qd() -> Pixel {
    Pixel::spot(694.9, 0.6, 1500.0)
}

fn qid() -> Pixel {
    Pixel::spot(539.4, 0.6, 1500.0).plus(Pixel::spot(658.7, 0.6, 900.0))
}

fn columns<const K: usize>(p: &PixelCandidates<K>) -> Vec<f32> {
    let mut c: Vec<f32> = p.candidates.iter().map(|c| c.column).collect();
    c.sort_by(f32::total_cmp);
    c
}

fn assert_near(got: &[f32], expected: &[f32], what: &str) {
    assert_eq!(
        got.len(),
        expected.len(),
        "{what}: got {got:?}, expected {expected:?}"
    );
    for (g, e) in got.iter().zip(expected) {
        assert!(
            (g - e).abs() < TOLERANCE,
            "{what}: got {got:?}, expected {expected:?}"
        );
    }
}

#[test]
fn bfsm_peaks_of_the_worked_example() {
    let plan = ScanPlan::paper_bfsm();
    let mut h = Harness::new(plan);
    let mut noise = Noise::new(5);
    let out = h.decode::<8>(
        &[
            qd().samples(&plan, 1.0, 12, &mut noise),
            qid().samples(&plan, 1.0, 12, &mut noise),
        ],
        12,
    );
    assert_near(&columns(&out[0]), &[694.9], "Qd, BFSM");
    assert_near(&columns(&out[1]), &[539.4, 658.7], "Qid, BFSM");
    // The direct light is the stronger one here; amplitudes are fringe modulations in DN.
    assert!((out[1].candidates[0].column - 539.4).abs() < TOLERANCE);
    assert!(
        (out[1].candidates[0].amplitude - 750.0).abs() < 10.0,
        "{:?}",
        out[1].candidates[0]
    );
}

#[test]
fn efsm_local_peaks_blocks_and_candidates_of_the_worked_example() {
    let mut plan = ScanPlan::efsm(768, 32, GroupCount::Two);
    // The paper lists group 2's candidates from c̃ = 2.8, so its border guard was below that.
    if let fsm_core::Method::Efsm(coding) = &mut plan.method {
        coding.border_guard = 2.0;
    }
    plan.validate().unwrap();
    let mut h = Harness::new(plan);
    let mut noise = Noise::new(6);
    let qd_samples = qd().samples(&plan, 1.0, 12, &mut noise);
    let qid_samples = qid().samples(&plan, 1.0, 12, &mut noise);

    // c̃-domain peaks (paper Figs. 8k–l).
    let local = |h: &mut Harness, s: &[u16], g: Group| {
        let mut c: Vec<f32> = h.peaks(s, g, 12).peaks.iter().map(|p| p.column).collect();
        c.sort_by(f32::total_cmp);
        c
    };
    assert_near(&local(&mut h, &qd_samples, Group::One), &[22.9], "Qd, Ṽ1");
    assert_near(&local(&mut h, &qd_samples, Group::Two), &[6.9], "Qd, Ṽ2");
    assert_near(
        &local(&mut h, &qid_samples, Group::One),
        &[18.7, 27.4],
        "Qid, Ṽ1",
    );
    // The paper prints 2.8 for the measured pixel; this synthetic one is lit at exactly 658.7.
    assert_near(
        &local(&mut h, &qid_samples, Group::Two),
        &[2.7, 11.4],
        "Qid, Ṽ2",
    );

    let out = h.decode::<8>(&[qd_samples, qid_samples], 12);
    // Qd: block 21 of group 1 and block 22 of group 2 give the same column, merged.
    assert_near(&columns(&out[0]), &[694.9], "Qd candidates");
    assert_eq!(out[0].candidates[0].groups.0, 0b11, "found by both groups");
    // c̃ = 22.9 in group 1 is 9.1 from a border, c̃ = 6.9 in group 2 only 6.9: group 1 wins.
    assert_eq!(out[0].candidates[0].group, Group::One);
    assert_eq!(out[0].candidates[0].block, 21);
    // Qid: blocks {16, 20} and {17, 21}; every (peak, block) pair is a candidate (eqs. 18–20),
    // the two groups agree on all four: {530.7, 539.4, 658.7, 667.4}.
    assert_near(
        &columns(&out[1]),
        &[530.7, 539.4, 658.7, 667.4],
        "Qid candidates",
    );
    for c in out[1].candidates.iter() {
        assert_eq!(c.groups.0, 0b11, "{c:?} found by both groups");
        let blocks: &[u16] = if c.group == Group::One {
            &[16, 20]
        } else {
            &[17, 21]
        };
        assert!(blocks.contains(&c.block), "{c:?}: block");
    }
}
