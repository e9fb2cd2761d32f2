//! The joint refinement's dense column samples on exact synthetic scans: the bench's board at
//! the first nine of the end-to-end test's poses (`support::POSES`), true corner pixels with
//! 0.02 px of Gaussian noise, and column maps computed from the bench's true geometry with
//! 0.004 column of noise (no rendering, so this runs in seconds).

use crate::support;

use fsm_calibrate::board::Checkerboard;
use fsm_calibrate::{calibrate, CalibrationSettings, ColumnMap, PoseObservation};
use fsm_sim::target;
use fsm_sim::System;
use nalgebra::{Point2, Point3};
use support::POSES;

/// A reproducible standard normal sequence (xorshift + Box–Muller).
struct Normal(u64);

impl Normal {
    fn uniform(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    fn next(&mut self) -> f64 {
        let (u, v) = (self.uniform(), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

/// The observations; `keep(pixel, corners)` says which decoded pixels the column map keeps.
fn observations(keep: impl Fn(Point2<f64>, &[Point2<f64>]) -> bool) -> Vec<PoseObservation> {
    let system = System::bench();
    let truth = system.calibration;
    let board = target::PrintedBoard::bench();
    let (w, h) = (system.width() as usize, system.height() as usize);
    let (lo, hi) = board.outline_board_mm();
    let mut noise = Normal(0x5eed);
    POSES[..9]
        .iter()
        .enumerate()
        .map(|(i, placement)| {
            let pose = placement.pose(&board);
            let true_px: Vec<Point2<f64>> = target::true_corner_pixels(&system, &board, &pose)
                .into_iter()
                .map(|p| p.unwrap())
                .collect();
            let normal = pose.rotation * nalgebra::Vector3::z();
            let t = pose.translation_mm;
            let mut columns = vec![f32::NAN; w * h];
            for y in 0..h {
                for x in 0..w {
                    let px = Point2::new(x as f64, y as f64);
                    if !keep(px, &true_px) {
                        continue;
                    }
                    let d = truth.camera.ray(px).unwrap();
                    let on_board = Point3::from(d * (normal.dot(&t) / normal.dot(&d)));
                    let b = pose.rotation.inverse() * (on_board.coords - t);
                    if b.x < lo[0] || b.y < lo[1] || b.x > hi[0] || b.y > hi[1] {
                        continue;
                    }
                    if let Some(c) = truth.projector_column_of(&on_board) {
                        columns[y * w + x] = (c + 0.004 * noise.next()) as f32;
                    }
                }
            }
            PoseObservation {
                label: format!("pose{i}"),
                corners_px: true_px
                    .iter()
                    .map(|p| Point2::new(p.x + 0.02 * noise.next(), p.y + 0.02 * noise.next()))
                    .collect(),
                columns: ColumnMap {
                    width: w,
                    height: h,
                    columns,
                },
            }
        })
        .collect()
}

fn board() -> Checkerboard {
    target::PrintedBoard::bench().grid
}

/// With whole column maps, the joint refinement uses hundreds of samples per pose, and their
/// residual after the fit is the maps' own noise.
#[test]
fn dense_samples_fit_to_the_column_noise() {
    let obs = observations(|_, _| true);
    let settings = CalibrationSettings::new(320, 240, 768, 1024);
    let (_, report) = calibrate(&board().corners_mm(), &obs, &settings).unwrap();
    for p in &report.poses {
        assert!(
            p.dense_samples > 300,
            "{}: {} samples",
            p.label,
            p.dense_samples
        );
    }
    let rms = report.dense_rms_columns.unwrap();
    assert!((rms - 0.004).abs() < 0.0008, "dense RMS {rms} column");
}

/// Column maps kept only within 2.5 px of the corners (nearer than 2 px to two edges: no sample
/// there): the joint refinement falls back to the corners' columns, and says so.
#[test]
fn too_few_dense_samples_fall_back_to_the_corners_columns() {
    let obs = observations(|px, corners| corners.iter().any(|c| (c - px).norm() < 2.5));
    let settings = CalibrationSettings::new(320, 240, 768, 1024);
    let (_, report) = calibrate(&board().corners_mm(), &obs, &settings).unwrap();
    assert_eq!(report.dense_rms_columns, None);
    assert!(report.poses.iter().all(|p| p.dense_samples == 0));
    assert!(report.projector_rms_columns < 0.05);
    // The projector was refined jointly from the corners' columns: its parameters have a σ
    // (without any projector residual the joint normal equations are singular: no σ).
    let fx = report.projector.iter().find(|p| p.name == "fx_px").unwrap();
    assert!(fx.std_dev.is_some_and(|s| s > 0.0), "{fx:?}");
}
