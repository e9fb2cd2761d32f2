//! Semi-global selection on synthetic candidate fields with known surfaces.

use fsm_scan::{select, CandidateField, Label, Paths, SelectionParams};
use proptest::prelude::*;

const FOOTPRINT_MM: f32 = 0.5;

/// A tilted plane facing the camera: pixel (x, y) sees (x, y)·footprint at depth 500 + 0.1·x mm.
fn plane(x: usize, y: usize) -> [f32; 3] {
    [
        x as f32 * FOOTPRINT_MM,
        y as f32 * FOOTPRINT_MM,
        500.0 + 0.1 * x as f32,
    ]
}

/// What a mirror beside the plane adds in a patch: a second, smooth surface 40 mm behind.
fn fictitious(x: usize, y: usize) -> [f32; 3] {
    let p = plane(x, y);
    [p[0] * 1.08, p[1] * 1.08, p[2] + 40.0 + 0.05 * y as f32]
}

fn in_patch(x: usize, y: usize) -> bool {
    (40..100).contains(&x) && (20..60).contains(&y)
}

fn mirror_field(direct: f32, indirect: f32) -> CandidateField {
    CandidateField::from_fn(120, 80, |x, y| {
        let mut labels = vec![Label {
            point_mm: plane(x, y),
            amplitude: direct,
            column: 0.0,
        }];
        if in_patch(x, y) {
            labels.push(Label {
                point_mm: fictitious(x, y),
                amplitude: indirect,
                column: 0.0,
            });
        }
        // Strongest first, as the decoder orders candidates.
        labels.sort_by(|a, b| b.amplitude.total_cmp(&a.amplitude));
        labels
    })
}

fn share_direct(field: &CandidateField, params: &SelectionParams) -> f64 {
    let selection = select(field, params);
    let (mut right, mut total) = (0, 0);
    for y in 0..field.height() {
        for x in 0..field.width() {
            if !in_patch(x, y) {
                continue;
            }
            total += 1;
            let chosen =
                selection.choice[y * field.width() + x].map(|i| field.labels(x, y)[i as usize]);
            right += chosen.is_some_and(|l| l.point_mm == plane(x, y)) as usize;
        }
    }
    right as f64 / total as f64
}

#[test]
fn the_continuous_surface_wins_even_where_the_indirect_light_is_stronger() {
    let params = SelectionParams::for_footprint(FOOTPRINT_MM);
    for (direct, indirect) in [(1.0, 0.5), (1.0, 1.0), (0.6, 1.0), (0.3, 1.0)] {
        let share = share_direct(&mirror_field(direct, indirect), &params);
        println!(
            "direct {direct}, indirect {indirect}: {:.2}% of the patch picks the real surface",
            100.0 * share
        );
        assert!(
            share >= 0.99,
            "direct {direct} indirect {indirect}: {share}"
        );
    }
    let eight = SelectionParams {
        paths: Paths::Eight,
        ..params
    };
    assert!(share_direct(&mirror_field(0.6, 1.0), &eight) >= 0.99);
}

#[test]
fn the_strongest_candidate_wins_without_a_neighbourhood_to_say_otherwise() {
    // The data term alone: isolated pixels (no neighbours with candidates).
    let field = CandidateField::from_fn(5, 1, |x, _| {
        if x == 2 {
            vec![
                Label {
                    point_mm: [0.0, 0.0, 500.0],
                    amplitude: 9.0,
                    column: 0.0,
                },
                Label {
                    point_mm: [0.0, 0.0, 700.0],
                    amplitude: 3.0,
                    column: 0.0,
                },
            ]
        } else {
            vec![]
        }
    });
    let s = select(&field, &SelectionParams::for_footprint(FOOTPRINT_MM));
    assert_eq!(s.choice, vec![None, None, Some(0), None, None]);
    assert_eq!((s.direct[2], s.indirect[2]), (9.0, 3.0));
}

#[test]
fn a_real_depth_step_keeps_both_sides() {
    // Two planes 30 mm apart meet at x = 60; every pixel has one candidate.
    let field = CandidateField::from_fn(120, 40, |x, y| {
        let mut p = plane(x, y);
        if x >= 60 {
            p[2] += 30.0;
        }
        vec![Label {
            point_mm: p,
            amplitude: 1.0,
            column: 0.0,
        }]
    });
    let s = select(&field, &SelectionParams::for_footprint(FOOTPRINT_MM));
    assert!(
        s.choice.iter().all(|c| *c == Some(0)),
        "pixels dropped at the step"
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// Whatever the field: choices index real candidates, and eqs. 12–13 split the light.
    #[test]
    fn choices_are_valid_and_split_the_light(
        seed in any::<u64>(),
        width in 1usize..12,
        height in 1usize..12,
        sixteen in any::<bool>(),
    ) {
        let mut state = seed | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let field = CandidateField::from_fn(width, height, |_, _| {
            let n = (next() * 5.0) as usize;
            (0..n).map(|_| Label { point_mm: [next() * 100.0, next() * 100.0, 400.0 + next() * 200.0], amplitude: next() * 100.0, column: 0.0 }).collect::<Vec<_>>()
        });
        let params = SelectionParams { paths: if sixteen { Paths::Sixteen } else { Paths::Eight }, ..SelectionParams::for_footprint(0.5) };
        let s = select(&field, &params);
        for y in 0..height {
            for x in 0..width {
                let i = y * width + x;
                let labels = field.labels(x, y);
                let total: f32 = labels.iter().map(|l| l.amplitude).sum();
                if let Some(c) = s.choice[i] {
                    prop_assert!((c as usize) < labels.len());
                }
                prop_assert!((s.direct[i] + s.indirect[i] - total).abs() <= 1e-3 * total.max(1.0));
            }
        }
    }
}

#[test]
fn an_isolated_choice_is_dropped() {
    // One pixel's only candidate lies 50 mm behind the plane its neighbours chose.
    let field = CandidateField::from_fn(9, 9, |x, y| {
        let mut p = plane(x, y);
        if (x, y) == (4, 4) {
            p[2] += 50.0;
        }
        vec![Label {
            point_mm: p,
            amplitude: 1.0,
            column: 0.0,
        }]
    });
    let params = SelectionParams::for_footprint(FOOTPRINT_MM);
    let s = select(&field, &params);
    assert_eq!(s.choice[4 * 9 + 4], None);
    assert_eq!((s.direct[4 * 9 + 4], s.indirect[4 * 9 + 4]), (0.0, 1.0));
    assert_eq!(s.choice.iter().filter(|c| c.is_some()).count(), 80);
    let kept = select(
        &field,
        &SelectionParams {
            drop_isolated: false,
            ..params
        },
    );
    assert_eq!(kept.choice[4 * 9 + 4], Some(0));
}

#[test]
fn the_choice_does_not_depend_on_the_number_of_threads() {
    // Many candidates close in cost: the sums of 16 paths decide, to the last bit.
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let field = CandidateField::from_fn(40, 30, |x, y| {
        let n = 1 + (next() * 4.0) as usize;
        let base = plane(x, y);
        (0..n)
            .map(|k| Label {
                point_mm: [base[0], base[1], base[2] + k as f32 * 3.0 * next()],
                amplitude: 50.0 + next() * 50.0,
                column: 0.0,
            })
            .collect::<Vec<_>>()
    });
    let params = SelectionParams::for_footprint(FOOTPRINT_MM);
    let with = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("a pool")
            .install(|| select(&field, &params))
    };
    let one = with(1);
    for threads in [2, 3, 5] {
        assert_eq!(with(threads), one, "{threads} threads");
    }
}

/// `fsm scan` reads its plan, calibration and truth before any work, each checked against the
/// others: the bench calibration (768 projector columns) takes the paper's BFSM plan and
/// refuses a plan for 1024 columns, naming both files; a missing truth folder is an error.
#[test]
fn scan_inputs_are_read_and_checked_together() {
    use fsm_io::plan_file::{write_method_plan, MethodKind, MethodPlan};
    use fsm_scan::pipeline::ScanInputs;
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let calibration = root.join("calibration/bench.toml");
    let dir = tempfile::tempdir().unwrap();
    let (paper, wide) = (dir.path().join("paper.toml"), dir.path().join("wide.toml"));
    let paper_plan = MethodPlan::Fsm(fsm_core::ScanPlan::paper_bfsm());
    write_method_plan(&paper_plan, &paper).unwrap();
    let wide_plan = MethodKind::Bfsm.plan(1024, 64, fsm_core::GroupCount::One);
    write_method_plan(&wide_plan, &wide).unwrap();

    let inputs = ScanInputs::read(&paper, &calibration, None).unwrap();
    assert_eq!(inputs.plan, paper_plan);
    assert_eq!(inputs.calibration.path, calibration);
    assert!(inputs.truth.is_none());
    let e = ScanInputs::read(&wide, &calibration, None).err().unwrap();
    let e = e.to_string();
    assert!(e.contains("bench.toml") && e.contains("wide.toml"), "{e}");
    assert!(e.contains("768 columns") && e.contains("1024"), "{e}");
    let no_truth = dir.path().join("truth");
    let e = ScanInputs::read(&paper, &calibration, Some(&no_truth))
        .err()
        .unwrap();
    assert!(e.to_string().contains("depth.tiff"), "{e}");
}
