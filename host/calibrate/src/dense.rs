//! Dense column constraints: every decoded pixel on a board's light squares, not only the
//! corners.
//!
//! A camera pixel `p` on the board of pose `i` sees the board point `X = s·ray(p)` where the
//! ray meets the board plane; the projector must put `X` at the column the scan decoded there:
//!
//! ```text
//! r = column_model(X(p; K, distortion, pose_i)) − c_decoded(p)
//! ```
//!
//! The pixel position is exact (the pixel grid) and the decoded column is precise (0.016
//! column RMS per pixel on the simulated bench's light squares), so the hundreds of samples per
//! pose tie the camera's ray geometry to the projector's more tightly than 54 corners at
//! 0.025 px can: on `tests/end_to_end.rs`, σ(cx) falls from 0.19 to 0.07 px and the plane's
//! shape error from 0.011 to 0.002 mm. They leave what the projector's columns do not see: the
//! camera's `cy`, and the scale (the focal lengths against the boards' distances).
//!
//! Only pixels whose whole footprint, widened by [`DenseSettings::edge_margin_px`], lies in one
//! light square are used: at a square's edge a pixel's decoded column is the albedo-weighted
//! mean of its footprint, pulled towards the light side; the dark squares (albedo ≈ 0.05)
//! return 17× less light.

use nalgebra::{Point2, Point3, Vector2, Vector3};

use crate::board::Checkerboard;
use crate::calibrate::ColumnMap;
use crate::homography::median;
use crate::projector::ColumnModel;
use crate::zhang::{BoardPose, CameraMatrix};
use fsm_geometry::BrownConrady;

/// Which pixels the dense constraints use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DenseSettings {
    /// Every `stride_px`-th pixel along each image axis.
    pub stride_px: usize,
    /// Margin around a pixel's footprint that must stay inside its light square, pixels.
    pub edge_margin_px: f64,
    /// Samples whose residual exceeds this many robust σ are dropped before each of the joint
    /// refinement's two passes.
    pub outlier_sigmas: f64,
}

impl Default for DenseSettings {
    fn default() -> Self {
        DenseSettings {
            stride_px: 4,
            edge_margin_px: 1.5,
            outlier_sigmas: 5.0,
        }
    }
}

/// One dense constraint: a camera pixel and the column decoded there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DenseSample {
    /// Camera pixel (integer position: the pixel's centre).
    pub pixel: Point2<f64>,
    /// Decoded projector column.
    pub column: f64,
}

/// The square `(c, r)` of `board` holding board point `b` (the one between corners `(c, r)` and
/// `(c + 1, r + 1)`), `None` outside the squares.
fn square_of(board: &Checkerboard, b: Point2<f64>) -> Option<(i64, i64)> {
    let (c, r) = (
        (b.x / board.square_mm).floor() as i64,
        (b.y / board.square_mm).floor() as i64,
    );
    (c >= -1 && r >= -1 && c < board.inner_columns as i64 && r < board.inner_rows as i64)
        .then_some((c, r))
}

/// Where the camera ray of `pixel` meets the board plane, camera frame; `None` when it does not
/// (or the distortion cannot be inverted there).
fn ray_on_board(
    k: &CameraMatrix,
    d: &BrownConrady,
    normal: &Vector3<f64>,
    normal_dot_t: f64,
    pixel: Point2<f64>,
) -> Option<Point3<f64>> {
    on_board(&ray(k, d, pixel)?, normal, normal_dot_t)
}

/// `s·ray` on the plane `normal·X = normal_dot_t`, in front of the camera.
fn on_board(ray: &Vector3<f64>, normal: &Vector3<f64>, normal_dot_t: f64) -> Option<Point3<f64>> {
    let denom = normal.dot(ray);
    if denom.abs() < 1e-12 {
        return None;
    }
    let s = normal_dot_t / denom;
    (s > 0.0).then(|| Point3::from(ray * s))
}

fn board_coordinates(pose: &BoardPose, x: &Point3<f64>) -> Point2<f64> {
    let b = pose.rotation.inverse() * (x.coords - pose.translation_mm);
    Point2::new(b.x, b.y)
}

/// The dense samples of one pose: pixels of `map` on a light square with their margin, located
/// with the camera model and pose given (the camera stage's).
pub fn select(
    map: &ColumnMap,
    board: &Checkerboard,
    k: &CameraMatrix,
    d: &BrownConrady,
    pose: &BoardPose,
    settings: &DenseSettings,
) -> Vec<DenseSample> {
    let normal = pose.normal();
    let nt = normal.dot(&pose.translation_mm);
    let m = settings.edge_margin_px + 0.5;
    let square_at = |p: Point2<f64>| {
        ray_on_board(k, d, &normal, nt, p)
            .and_then(|x| square_of(board, board_coordinates(pose, &x)))
    };
    let stride = settings.stride_px.max(1);
    let mut out = Vec::new();
    for y in (0..map.height).step_by(stride) {
        for x in (0..map.width).step_by(stride) {
            let column = map.columns[y * map.width + x] as f64;
            if !column.is_finite() {
                continue;
            }
            let pixel = Point2::new(x as f64, y as f64);
            let Some(sq) = square_at(pixel) else {
                continue;
            };
            if Checkerboard::square_is_dark(sq.0, sq.1) {
                continue;
            }
            let inside = [(-m, -m), (m, -m), (-m, m), (m, m)]
                .iter()
                .all(|&(dx, dy)| square_at(Point2::new(pixel.x + dx, pixel.y + dy)) == Some(sq));
            if inside {
                out.push(DenseSample { pixel, column });
            }
        }
    }
    out
}

/// The camera ray (`z = 1`) of every sample: the costly part of a residual (the distortion is
/// inverted by Newton's method), the same for every trial of the poses and the projector.
pub(crate) fn rays(
    k: &CameraMatrix,
    d: &BrownConrady,
    samples: &[Vec<DenseSample>],
) -> Option<Vec<Vec<Vector3<f64>>>> {
    samples
        .iter()
        .map(|pose| pose.iter().map(|s| ray(k, d, s.pixel)).collect())
        .collect()
}

fn ray(k: &CameraMatrix, d: &BrownConrady, pixel: Point2<f64>) -> Option<Vector3<f64>> {
    let q = Vector2::new((pixel.x - k.cx) / k.fx, (pixel.y - k.cy) / k.fy);
    let u = d.undistort_within(q, f64::INFINITY).ok()?;
    Some(Vector3::new(u.x, u.y, 1.0))
}

/// Appends `column_model(X) − column` for every sample of every pose, `X` where the sample's
/// ray (from [`rays`]) meets its board; `None` where a ray misses its board or a point is
/// behind the projector.
pub(crate) fn residuals(
    rays: &[Vec<Vector3<f64>>],
    poses: &[BoardPose],
    model: &ColumnModel,
    samples: &[Vec<DenseSample>],
    out: &mut Vec<f64>,
) -> Option<()> {
    for ((pose, samples), rays) in poses.iter().zip(samples).zip(rays) {
        let normal = pose.normal();
        let nt = normal.dot(&pose.translation_mm);
        for (s, ray) in samples.iter().zip(rays) {
            let x = on_board(ray, &normal, nt)?;
            out.push(model.column(&x)? - s.column);
        }
    }
    Some(())
}

/// The robust σ of the samples' residuals about `model` (columns), after dropping those beyond
/// `outlier_sigmas` of it; `None` where the model cannot be evaluated.
pub(crate) fn weigh_and_prune(
    model: (&CameraMatrix, &BrownConrady, &[BoardPose], &ColumnModel),
    samples: &mut [Vec<DenseSample>],
    outlier_sigmas: f64,
) -> Option<f64> {
    let (k, d, poses, projector) = model;
    let mut r = Vec::new();
    residuals(&rays(k, d, samples)?, poses, projector, samples, &mut r)?;
    let sigma = robust_sigma(&r).max(1e-6);
    let limit = outlier_sigmas * sigma;
    let mut it = r.iter();
    for pose in samples.iter_mut() {
        pose.retain(|_| it.next().is_some_and(|e| e.abs() <= limit));
    }
    Some(sigma)
}

/// Median absolute value × 1.4826: σ of Gaussian residuals, unmoved by a few outliers.
pub(crate) fn robust_sigma(r: &[f64]) -> f64 {
    let mut a: Vec<f64> = r.iter().map(|x| x.abs()).collect();
    1.4826 * median(&mut a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    const W: usize = 320;
    const H: usize = 240;

    fn camera() -> (CameraMatrix, BrownConrady) {
        let k = CameraMatrix {
            fx: 640.0,
            fy: 640.0,
            cx: 159.5,
            cy: 119.5,
        };
        let d = BrownConrady {
            k1: -0.06,
            k2: 0.02,
            p1: 5e-4,
            p2: -3e-4,
            k3: 0.0,
        };
        (k, d)
    }

    fn board() -> Checkerboard {
        Checkerboard {
            inner_columns: 9,
            inner_rows: 6,
            square_mm: 20.0,
        }
    }

    /// The 9 × 6 board tilted by 20° about the camera's `y` axis, its corner grid centred at
    /// 540 mm.
    fn pose() -> BoardPose {
        let rotation = Rotation3::from_axis_angle(&Vector3::y_axis(), 20f64.to_radians());
        let centre = Vector3::new(80.0, 50.0, 0.0);
        BoardPose {
            rotation,
            translation_mm: Vector3::new(0.0, 0.0, 540.0) - rotation * centre,
        }
    }

    fn projector() -> ColumnModel {
        ColumnModel {
            fx: 1400.0,
            cx: 383.5,
            distortion: BrownConrady {
                k1: 0.03,
                ..BrownConrady::NONE
            },
            rotation: Rotation3::from_axis_angle(&Vector3::y_axis(), -0.3),
            translation_mm: Vector3::new(-180.0, 0.0, 30.0),
        }
    }

    /// The column map `model` gives the board at `pose` (NaN off the board).
    fn column_map(pose: &BoardPose, model: &ColumnModel) -> ColumnMap {
        let (k, d) = camera();
        let normal = pose.normal();
        let nt = normal.dot(&pose.translation_mm);
        let mut columns = vec![f32::NAN; W * H];
        for y in 0..H {
            for x in 0..W {
                let p = Point2::new(x as f64, y as f64);
                let Some(x3) = ray_on_board(&k, &d, &normal, nt, p) else {
                    continue;
                };
                let b = board_coordinates(pose, &x3);
                if b.x.abs() < 400.0 && b.y.abs() < 400.0 {
                    columns[y * W + x] = model.column(&x3).unwrap() as f32;
                }
            }
        }
        ColumnMap {
            width: W,
            height: H,
            columns,
        }
    }

    #[test]
    fn the_board_of_its_corners_and_of_other_point_lists() {
        let corners = board().corners_mm();
        assert_eq!(Checkerboard::from_corners_mm(&corners), Some(board()));
        let mut shuffled = corners.clone();
        shuffled.swap(3, 7);
        assert_eq!(Checkerboard::from_corners_mm(&shuffled), None);
        let line: Vec<Point2<f64>> = (0..5).map(|i| Point2::new(i as f64, 0.0)).collect();
        assert_eq!(Checkerboard::from_corners_mm(&line), None);
        assert_eq!(Checkerboard::from_corners_mm(&corners[1..]), None);
    }

    /// Every sample's footprint and margin lie in one light square (checked at 25 points of
    /// its widened footprint, not only the 4 corners `select` looks at); the dark squares, the
    /// margin outside the squares and the NaN pixels give none.
    #[test]
    fn samples_lie_inside_light_squares() {
        let (k, d) = camera();
        let pose = pose();
        let mut map = column_map(&pose, &projector());
        for c in map.columns.iter_mut().skip(7).step_by(11) {
            *c = f32::NAN;
        }
        let settings = DenseSettings {
            stride_px: 1,
            ..DenseSettings::default()
        };
        let samples = select(&map, &board(), &k, &d, &pose, &settings);
        let normal = pose.normal();
        let nt = normal.dot(&pose.translation_mm);
        let square_at = |p: Point2<f64>| {
            let x = ray_on_board(&k, &d, &normal, nt, p).unwrap();
            square_of(&board(), board_coordinates(&pose, &x))
        };
        // Light squares are (c + r) odd: 35 of the 70 squares, each about 22 × 24 px on this
        // pose; 2 px off each side leaves about 35 × 18 × 20 ≈ 12,600 pixels, less the NaN ones.
        assert!(samples.len() > 8000, "{} samples", samples.len());
        let m = settings.edge_margin_px + 0.5;
        for s in &samples {
            let (x, y) = (s.pixel.x as usize, s.pixel.y as usize);
            assert!(map.columns[y * W + x].is_finite());
            assert_eq!(s.column, map.columns[y * W + x] as f64);
            let sq = square_at(s.pixel).unwrap();
            assert!(
                !Checkerboard::square_is_dark(sq.0, sq.1),
                "{:?} on dark square {sq:?}",
                s.pixel
            );
            for i in 0..5 {
                for j in 0..5 {
                    let p = Point2::new(
                        s.pixel.x - m + 0.5 * m * i as f64,
                        s.pixel.y - m + 0.5 * m * j as f64,
                    );
                    assert_eq!(
                        square_at(p),
                        Some(sq),
                        "{:?}: {p} leaves its square",
                        s.pixel
                    );
                }
            }
        }
    }

    /// The default samples of [`pose`] with the columns [`projector`] gives them.
    fn true_samples() -> (
        CameraMatrix,
        BrownConrady,
        BoardPose,
        ColumnModel,
        Vec<Vec<DenseSample>>,
    ) {
        let (k, d) = camera();
        let (pose, model) = (pose(), projector());
        let map = column_map(&pose, &model);
        let samples = select(&map, &board(), &k, &d, &pose, &DenseSettings::default());
        (k, d, pose, model, vec![samples])
    }

    /// At the model that made the map the residuals vanish; a pose moved by 0.1 mm along its
    /// normal moves them by what the projector's column scale says.
    #[test]
    fn residuals_vanish_at_the_true_model() {
        let (k, d, pose, model, samples) = true_samples();
        let rays = rays(&k, &d, &samples).unwrap();
        let mut r = Vec::new();
        residuals(&rays, &[pose], &model, &samples, &mut r).unwrap();
        assert_eq!(r.len(), samples[0].len());
        // The map is f32: a column near 700 is stored to ±3e-5.
        assert!(
            r.iter().all(|e| e.abs() < 1e-4),
            "{:?}",
            r.iter().fold(0.0f64, |m, e| m.max(e.abs()))
        );
        let moved = BoardPose {
            translation_mm: pose.translation_mm + 0.1 * pose.normal(),
            ..pose
        };
        let mut r2 = Vec::new();
        residuals(&rays, &[moved], &model, &samples, &mut r2).unwrap();
        let shift = (r2.iter().map(|e| e * e).sum::<f64>() / r2.len() as f64).sqrt();
        // 0.1 mm of depth at 540 mm and a 180 mm baseline: of the order of 1400·180·0.1/540²
        // ≈ 0.09 column.
        assert!(shift > 0.02 && shift < 0.3, "shift {shift}");
    }

    #[test]
    fn pruning_drops_outliers_and_reports_their_spread() {
        let (k, d, pose, model, mut samples) = true_samples();
        let n = samples[0].len();
        // A deterministic ±0.01 column pattern with every 50th sample 1 column off.
        for (i, s) in samples[0].iter_mut().enumerate() {
            s.column += if i % 50 == 0 {
                1.0
            } else if i % 2 == 0 {
                0.01
            } else {
                -0.01
            };
        }
        let sigma = weigh_and_prune((&k, &d, &[pose], &model), &mut samples, 5.0).unwrap();
        assert!((sigma - 0.01 * 1.4826).abs() < 2e-3, "sigma {sigma}");
        assert_eq!(samples[0].len(), n - n.div_ceil(50));
    }

    #[test]
    fn robust_sigma_of_gaussian_like_residuals() {
        assert!(robust_sigma(&[]).is_nan());
        let r: Vec<f64> = (0..1001).map(|i| (i as f64 - 500.0) / 500.0).collect();
        // Uniform on [−1, 1]: median |r| = 0.5.
        assert!((robust_sigma(&r) - 0.5 * 1.4826).abs() < 1e-9);
    }
}
