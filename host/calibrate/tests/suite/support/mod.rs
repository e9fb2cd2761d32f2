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

/// (yaw, pitch, roll) degrees, centre of the corner grid (camera frame, mm). The first nine
/// (those of `fsm simulate --board-poses`) are tilted by 15–30° about four axes; then two
/// boards parallel to the image, their edges along the pixel grid (one centred, one offset by
/// (¼, ½) px); then six turned by ±90° (portrait: the corners reach the top and bottom of the
/// image), four of them tilted by 25°.
///
/// What the poses are for: the principal point. The camera's tangential distortion is free, and
/// with the bench camera's narrow field (28°) a shift of the principal point is nearly the
/// same as a turn of the whole camera frame plus a change of `p1`, `p2`: only the perspective
/// of the turn, largest at the image's rim, tells them apart. With corners of 0.02 px noise
/// per axis (iid, synthetic, 8 trials), the first nine poses leave the principal point
/// σ = (0.41, 0.27) px (the plane 0.49 mm RMS off in 3D, raw); with the 17 here (0.21,
/// 0.19) px and 0.29 mm (measured; `p1 = p2 = 0` held fixed would give σ ≈ 0.1 px but a biased
/// principal point, the bench having `p1 = 5e-4`, `p2 = −3e-4`). Close boards (400 mm) would
/// help more but leave the projector's field; so would many more poses (σ falls as 1/√N).
/// With the simulator's former fixed 4 × 4 ray grid, the two fronto-parallel boards were off
/// by up to ±1/8 px along their grid-aligned edges (the plane 0.089% off); the rays are now
/// multi-jittered per pixel (`fsm_sim::transport::footprint`).
pub const POSES: [([f64; 3], [f64; 3]); 17] = [
    ([15.0, -15.0, 0.0], [0.0, 0.0, 540.0]),
    ([30.0, 0.0, 5.0], [0.0, 0.0, 560.0]),
    ([-30.0, 0.0, -5.0], [0.0, 0.0, 560.0]),
    ([0.0, 30.0, 0.0], [0.0, 0.0, 560.0]),
    ([0.0, -30.0, 8.0], [0.0, 0.0, 560.0]),
    ([20.0, 20.0, 10.0], [0.0, 0.0, 580.0]),
    ([-20.0, -20.0, -10.0], [0.0, 0.0, 570.0]),
    ([20.0, -20.0, 0.0], [0.0, 0.0, 560.0]),
    ([-20.0, 20.0, 5.0], [0.0, 0.0, 560.0]),
    ([0.0, 0.0, 0.0], [0.0, 0.0, 540.0]),
    ([0.0, 0.0, 0.0], [0.1875, 0.375, 480.0]),
    ([-2.0, 6.0, 90.0], [66.0, -7.0, 574.0]),
    ([4.0, -11.0, 90.0], [-34.0, -5.0, 527.0]),
    ([-25.0, 0.0, 90.0], [40.0, 0.0, 560.0]),
    ([25.0, 0.0, 90.0], [-20.0, 0.0, 540.0]),
    ([0.0, 25.0, -90.0], [30.0, 0.0, 560.0]),
    ([0.0, -25.0, -90.0], [-10.0, 0.0, 540.0]),
];
