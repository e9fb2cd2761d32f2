//! What the calibration tests share.

#![allow(dead_code)] // each test binary uses part of it

use fsm_geometry::Calibration;
use nalgebra::{Matrix3, Point2, Point3, Vector3};

/// How far the `plane` scene triangulated with a recovered calibration is from the truth, mm
/// (RMS over the pixels).
#[derive(Clone, Copy, Debug)]
pub struct PlaneDeviation {
    /// Distance of each triangulated point from its true point, camera frame, no alignment.
    pub raw_mm: f64,
    /// Depth (`z`) of each triangulated point minus its true depth, camera frame, no alignment.
    pub depth_mm: f64,
    /// Distance after the best rigid alignment of the triangulated points to the true ones
    /// (Kabsch).
    pub aligned_mm: f64,
}

/// The `plane` scene (plane z = 500 mm facing the camera) seen at every 4th pixel of the true
/// camera: each pixel's true point and true column, triangulated with `cal`, compared with the
/// true points raw (3D distance and depth) and after the best rigid alignment (Kabsch). The
/// camera frame is defined by the calibration itself: an error `δ` of the principal point turns
/// the whole frame by `δ/f`, which moves the points sideways by `δ/f` × 500 mm and their depth
/// only by `δ/f` × their distance from the optical axis.
pub fn plane_deviation(truth: &Calibration, cal: &Calibration) -> PlaneDeviation {
    let (w, h) = (truth.camera.width_px(), truth.camera.height_px());
    let mut got = Vec::new();
    let mut want = Vec::new();
    for y in (0..h).step_by(4) {
        for x in (0..w).step_by(4) {
            let px = Point2::new(x as f64, y as f64);
            let ray = truth.camera.ray(px).unwrap();
            let point = Point3::from(ray * (500.0 / ray.z));
            let Some(c) = truth.projector_column_of(&point) else {
                continue;
            };
            if !(0.0..truth.projector_columns() as f64).contains(&c) {
                continue;
            }
            got.push(cal.triangulate(px, c).unwrap());
            want.push(point);
        }
    }
    let n = got.len() as f64;
    let rms = |a: &[Point3<f64>], b: &[Point3<f64>]| {
        (a.iter()
            .zip(b)
            .map(|(p, q)| (p - q).norm_squared())
            .sum::<f64>()
            / n)
            .sqrt()
    };
    let raw = rms(&got, &want);
    let depth = (got
        .iter()
        .zip(&want)
        .map(|(p, q)| (p.z - q.z).powi(2))
        .sum::<f64>()
        / n)
        .sqrt();
    let cg = got.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
    let cw = want.iter().map(|p| p.coords).sum::<Vector3<f64>>() / n;
    let mut m = Matrix3::zeros();
    for (p, q) in got.iter().zip(&want) {
        m += (p.coords - cg) * (q.coords - cw).transpose();
    }
    let svd = m.svd(true, true);
    let (u, v_t) = (svd.u.unwrap(), svd.v_t.unwrap());
    let mut d = Matrix3::identity();
    if (v_t.transpose() * u.transpose()).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    let r = v_t.transpose() * d * u.transpose();
    let aligned: Vec<Point3<f64>> = got
        .iter()
        .map(|p| Point3::from(r * (p.coords - cg) + cw))
        .collect();
    PlaneDeviation {
        raw_mm: raw,
        depth_mm: depth,
        aligned_mm: rms(&aligned, &want),
    }
}

/// The bench's calibration poses, `fsm_sim::folder::CALIBRATION_POSES` (why these: its doc).
pub const POSES: [fsm_sim::folder::BoardPlacement; 17] = fsm_sim::folder::CALIBRATION_POSES;
