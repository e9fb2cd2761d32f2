//! Calibration targets: a printed checkerboard at a chosen pose, its ground truth, and its white
//! frame.
//!
//! The board is two coplanar surfaces ([`Shape::Checker`]): its dark squares (albedo 0.05 by
//! default) and its light squares with a white margin around them (0.85). Both are ordinary
//! diffuse surfaces to the light transport, so a board scene renders through the existing
//! pipeline — the white frame, or every frame of any plan with [`crate::simulate`] — and each
//! camera pixel integrates its footprint over the squares' edges (`s × s` multi-jittered rays,
//! [`crate::TransportSettings::supersampling`]).
//!
//! The board frame is the one of `fsm-calibrate`'s `Checkerboard`: origin at inner corner
//! (0, 0), `+x` along a row of corners, `+y` down the rows, `z = 0` on the face, `+z` into the
//! board; the square diagonally outside corner (0, 0) is dark. A [`BoardPose`] maps board
//! points to the camera frame, `X_c = R·X_b + t` (mm); the true camera pixel of every corner is
//! its projection through the system's camera model ([`true_corner_pixels`]).
//!
//! ```no_run
//! use fsm_sim::target::{self, BoardPose, PrintedBoard};
//! use fsm_sim::{Scene, Sensor, System};
//!
//! let system = System::bench();
//! let board = PrintedBoard::bench(); // 9 × 6 inner corners, 20 mm squares
//! let pose = BoardPose::tilted(&board, [0.0, 0.0, 520.0], 25.0, -15.0, 10.0);
//! let scene = Scene::checkerboard(&board, &pose);
//! let white = target::white_frame(&scene, &system, Some(&Sensor::default()), 1, 4).unwrap();
//! let truth = target::true_corner_pixels(&system, &board, &pose); // row-major, Option<Point2>
//! # let _ = (white, truth);
//! ```

use nalgebra::{Point2, Point3, Rotation3, Vector3};
use rayon::prelude::*;

use fsm_calibrate::board::Checkerboard;

use crate::scene::{Material, Scene, Shape, Surface};
use crate::{PatternSequence, Sensor, SimError, System, TransportSettings};

/// Albedo of the printed dark squares (matte black toner on paper).
pub const DARK_ALBEDO: f64 = 0.05;
/// Albedo of the light squares and the margin (matte white paper).
pub const LIGHT_ALBEDO: f64 = 0.85;
/// Ambient light of a board scene: 2% of the reference white, as the presets.
pub const AMBIENT: f64 = 0.02;

/// A printed checkerboard as the simulator renders it: the corner grid of the target
/// definition (`fsm_calibrate`'s [`Checkerboard`], what `fsm calibrate target` reads), on paper
/// with a margin and two albedos.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrintedBoard {
    /// The inner corners and the square size.
    pub grid: Checkerboard,
    /// Width of the white margin around the squares, mm.
    pub margin_mm: f64,
    /// Albedo of the dark squares.
    pub dark_albedo: f64,
    /// Albedo of the light squares and the margin.
    pub light_albedo: f64,
}

impl PrintedBoard {
    /// `grid` printed with a margin of one square, albedos [`DARK_ALBEDO`] and [`LIGHT_ALBEDO`].
    pub fn new(grid: Checkerboard) -> PrintedBoard {
        PrintedBoard {
            grid,
            margin_mm: grid.square_mm,
            dark_albedo: DARK_ALBEDO,
            light_albedo: LIGHT_ALBEDO,
        }
    }

    /// The bench's target, `calibration/targets/checkerboard-9x6-20mm.toml`: 9 × 6 inner
    /// corners (10 × 7 squares, 200 mm × 140 mm), 20 mm squares, 20 mm margin. About 26 px per
    /// square at 500 mm with the bench camera.
    pub fn bench() -> PrintedBoard {
        PrintedBoard::new(Checkerboard {
            inner_columns: 9,
            inner_rows: 6,
            square_mm: 20.0,
        })
    }

    /// Inner corners in the board frame (`z = 0`), mm, row-major
    /// (`index = row · inner_columns + column`, as [`Checkerboard::corners_mm`]).
    pub fn corners_board_mm(&self) -> Vec<Point3<f64>> {
        self.grid
            .corners_mm()
            .iter()
            .map(|p| Point3::new(p.x, p.y, 0.0))
            .collect()
    }

    /// The centre of the inner corners' grid in the board frame, mm.
    pub fn centre_board_mm(&self) -> Point3<f64> {
        Point3::new(
            0.5 * (self.grid.inner_columns as f64 - 1.0) * self.grid.square_mm,
            0.5 * (self.grid.inner_rows as f64 - 1.0) * self.grid.square_mm,
            0.0,
        )
    }

    /// The board's outline (squares and margin) in the board frame: `(min, max)` of `x` and
    /// `y`, mm.
    pub fn outline_board_mm(&self) -> ([f64; 2], [f64; 2]) {
        let s = self.grid.square_mm;
        let m = self.margin_mm;
        (
            [-s - m, -s - m],
            [
                self.grid.inner_columns as f64 * s + m,
                self.grid.inner_rows as f64 * s + m,
            ],
        )
    }

    /// The board's two surfaces at `pose`: the dark squares, then the light squares and margin.
    pub fn surfaces(&self, pose: &BoardPose) -> [Surface; 2] {
        let origin = pose.to_camera(&Point3::origin());
        let axis_x = pose.rotation * Vector3::x();
        let axis_y = pose.rotation * Vector3::y();
        let shape = |dark| Shape::Checker {
            origin,
            axis_x,
            axis_y,
            square_mm: self.grid.square_mm,
            inner: [self.grid.inner_columns, self.grid.inner_rows],
            margin_mm: self.margin_mm,
            dark,
        };
        [
            Surface {
                name: "board_dark".into(),
                shape: shape(true),
                material: Material::Diffuse {
                    albedo: self.dark_albedo,
                },
            },
            Surface {
                name: "board_light".into(),
                shape: shape(false),
                material: Material::Diffuse {
                    albedo: self.light_albedo,
                },
            },
        ]
    }
}

/// Where a board is: board frame → camera frame, `X_c = rotation·X_b + translation_mm`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardPose {
    /// Board-to-camera rotation.
    pub rotation: Rotation3<f64>,
    /// The board origin (inner corner (0, 0)) in the camera frame, mm.
    pub translation_mm: Vector3<f64>,
}

impl BoardPose {
    /// A pose from its rotation and translation.
    pub fn new(rotation: Rotation3<f64>, translation_mm: Vector3<f64>) -> BoardPose {
        BoardPose {
            rotation,
            translation_mm,
        }
    }

    /// The board facing the camera squarely (board axes parallel to the camera's), the centre
    /// of its corner grid at `centre_mm` (camera frame).
    pub fn facing(board: &PrintedBoard, centre_mm: [f64; 3]) -> BoardPose {
        BoardPose::tilted(board, centre_mm, 0.0, 0.0, 0.0)
    }

    /// The board turned by `roll_deg` about its normal, then tilted by `pitch_deg` about the
    /// camera's `x` axis and `yaw_deg` about its `y` axis (`R = R_y(yaw)·R_x(pitch)·R_z(roll)`),
    /// the centre of its corner grid at `centre_mm` (camera frame). With all angles 0 the board
    /// faces the camera with its rows along the image rows.
    pub fn tilted(
        board: &PrintedBoard,
        centre_mm: [f64; 3],
        yaw_deg: f64,
        pitch_deg: f64,
        roll_deg: f64,
    ) -> BoardPose {
        let rotation = Rotation3::from_axis_angle(&Vector3::y_axis(), yaw_deg.to_radians())
            * Rotation3::from_axis_angle(&Vector3::x_axis(), pitch_deg.to_radians())
            * Rotation3::from_axis_angle(&Vector3::z_axis(), roll_deg.to_radians());
        let centre = Vector3::from(centre_mm);
        let translation_mm = centre - rotation * board.centre_board_mm().coords;
        BoardPose {
            rotation,
            translation_mm,
        }
    }

    /// A board point in the camera frame.
    pub fn to_camera(&self, board_point: &Point3<f64>) -> Point3<f64> {
        self.rotation * board_point + self.translation_mm
    }
}

impl Scene {
    /// A scene of `board` at `pose` alone (nothing behind it: the background is black), ambient
    /// light [`AMBIENT`]. Push more surfaces for a backdrop.
    pub fn checkerboard(board: &PrintedBoard, pose: &BoardPose) -> Scene {
        Scene {
            name: format!(
                "checkerboard_{}x{}_{}mm",
                board.grid.inner_columns, board.grid.inner_rows, board.grid.square_mm
            ),
            surfaces: board.surfaces(pose).to_vec(),
            ambient: AMBIENT,
            diffuse_emitters: vec![],
        }
    }
}

/// The inner corners of `board` at `pose` in the camera frame, mm, row-major.
pub fn corners_camera_mm(board: &PrintedBoard, pose: &BoardPose) -> Vec<Point3<f64>> {
    board
        .corners_board_mm()
        .iter()
        .map(|p| pose.to_camera(p))
        .collect()
}

/// The true camera pixel of every inner corner (SPEC §1: pixel centres at integer
/// coordinates), row-major: its projection through the system's camera model (distortion
/// included); `None` for a corner behind the camera or beyond the model's valid radius. A
/// pixel may lie off the image: check it with `system.calibration.camera.contains`.
pub fn true_corner_pixels(
    system: &System,
    board: &PrintedBoard,
    pose: &BoardPose,
) -> Vec<Option<Point2<f64>>> {
    corners_camera_mm(board, pose)
        .iter()
        .map(|p| system.calibration.camera.project(p))
        .collect()
}

/// A pattern sequence of one full-on frame: the white frame every plan captures.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WhiteFrame {
    /// Projector columns.
    pub columns: u16,
}

impl PatternSequence for WhiteFrame {
    fn projector_columns(&self) -> u16 {
        self.columns
    }

    fn frame_count(&self) -> usize {
        1
    }

    fn frame_intensity(&self, _frame: usize, _column: u32) -> f32 {
        1.0
    }

    fn fingerprint(&self) -> u64 {
        0x5768_6974_6546_726d // "WhiteFrm"
    }

    fn pattern_fingerprint(&self) -> u64 {
        self.fingerprint()
    }
}

/// The white frame of `scene` (every projector column full on), row-major `W × H`: sensor codes
/// (as `f32`) with `Some(sensor)` (noise seeded by `seed`), or the noise-free signal in reference
/// whites with `None`. `supersampling` rays per pixel along each axis (the default transport has
/// 4; more anti-aliases the board's edges more finely).
pub fn white_frame(
    scene: &Scene,
    system: &System,
    sensor: Option<&Sensor>,
    seed: u64,
    supersampling: u32,
) -> Result<Vec<f32>, SimError> {
    if supersampling == 0 {
        return Err(SimError::Settings(
            "supersampling must be at least 1".into(),
        ));
    }
    let settings = TransportSettings {
        supersampling,
        ..TransportSettings::default()
    };
    let frame = WhiteFrame {
        columns: system.projector_columns() as u16,
    };
    let capture = crate::simulate_with(
        &frame,
        scene,
        system,
        &sensor.copied().unwrap_or_default(),
        seed,
        &settings,
        &fsm_io::progress::Progress::hidden(),
    )?;
    let w = capture.width() as usize;
    let rows: Vec<Result<Vec<f32>, SimError>> = capture
        .rows()
        .into_par_iter()
        .map(|y| match sensor {
            Some(_) => Ok(capture.row(y)?.into_iter().map(f32::from).collect()),
            None => {
                let mut out = vec![0.0f32; w];
                capture.signal_row(y, &mut out)?;
                Ok(out)
            }
        })
        .collect();
    let mut image = Vec::with_capacity(w * capture.height() as usize);
    for r in rows {
        image.extend(r?);
    }
    Ok(image)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::checker_colour;

    /// The board's two surfaces tile it: every point of the outline is in exactly one of them,
    /// and the dark one holds the squares of even `a + b`.
    #[test]
    fn the_two_colours_tile_the_board() {
        let board = PrintedBoard::new(Checkerboard {
            inner_columns: 5,
            inner_rows: 4,
            square_mm: 10.0,
        });
        let pose = BoardPose::tilted(&board, [10.0, -5.0, 500.0], 20.0, -10.0, 30.0);
        let [dark, light] = board.surfaces(&pose);
        let (lo, hi) = board.outline_board_mm();
        let mut counts = [0usize; 2];
        let n = 97;
        for i in 0..n {
            for j in 0..n {
                // Off the squares' borders, where rounding decides the colour.
                let bx = lo[0] + (hi[0] - lo[0]) * (i as f64 + 0.37) / n as f64;
                let by = lo[1] + (hi[1] - lo[1]) * (j as f64 + 0.61) / n as f64;
                let p = pose.to_camera(&Point3::new(bx, by, 0.0));
                let in_dark = dark.shape.rectangle_contains(&p);
                let in_light = light.shape.rectangle_contains(&p);
                assert!(in_dark != in_light, "board point ({bx}, {by})");
                counts[in_dark as usize] += 1;
                let on_squares = (-10.0..50.0).contains(&bx) && (-10.0..40.0).contains(&by);
                let expected_dark = on_squares
                    && (((bx / 10.0).floor() + (by / 10.0).floor()) as i64).rem_euclid(2) == 0;
                assert_eq!(in_dark, expected_dark, "board point ({bx}, {by})");
            }
        }
        assert!(counts[0] > 0 && counts[1] > 0);
        assert_eq!(checker_colour(-5.0, -5.0, 10.0, [5, 4], 10.0), Some(true));
        assert_eq!(checker_colour(5.0, -5.0, 10.0, [5, 4], 10.0), Some(false));
        assert_eq!(checker_colour(-25.0, 0.0, 10.0, [5, 4], 10.0), None);
    }

    /// A camera ray through a corner's true pixel meets the board at the corner.
    #[test]
    fn the_true_pixel_of_a_corner_looks_at_the_corner() {
        let system = System::bench();
        let board = PrintedBoard::bench();
        let pose = BoardPose::tilted(&board, [5.0, 3.0, 520.0], 30.0, -20.0, 12.0);
        let scene = Scene::checkerboard(&board, &pose);
        let corners = corners_camera_mm(&board, &pose);
        for (pixel, corner) in true_corner_pixels(&system, &board, &pose)
            .iter()
            .zip(&corners)
        {
            let pixel = pixel.expect("every corner projects");
            let dir = system.calibration.camera.ray(pixel).unwrap();
            let hit = scene
                .nearest_hit(&Point3::origin(), &dir, f64::INFINITY, None)
                .expect("the ray meets the board");
            assert!(
                (hit.point - corner).norm() < 1e-6,
                "{:?} vs {corner:?}",
                hit.point
            );
        }
    }

    /// Noise-free white frame of a board facing the camera: pixels inside squares read the
    /// squares' albedo ratio, and each pixel straddling an edge reads the share of its footprint
    /// on each colour (integrated independently here with 32 × 32 rays per pixel), without bias.
    /// Measured: 108 straddling of 888 pixels, mean signed difference +0.0027 (standard error
    /// 0.0015), std 0.016, worst 0.037 of a light pixel.
    #[test]
    fn the_white_frame_integrates_each_pixel_over_the_squares() {
        let system = System::bench_with_camera(96, 72);
        let board = PrintedBoard {
            margin_mm: 10.0,
            ..PrintedBoard::new(Checkerboard {
                inner_columns: 3,
                inner_rows: 2,
                square_mm: 40.0,
            })
        };
        // Rolled by 17° so that the edges cross the pixel grid at every phase.
        let pose = BoardPose::tilted(&board, [0.0, 0.0, 500.0], 0.0, 0.0, 17.0);
        let scene = Scene::checkerboard(&board, &pose);
        let s = 8;
        let image = white_frame(&scene, &system, None, 0, s).unwrap();
        let (w, h) = (system.width() as usize, system.height() as usize);
        assert_eq!(image.len(), w * h);
        let cam = &system.calibration.camera;
        let n = 32;
        let mut worst = 0.0f64;
        let mut straddling = 0;
        let (mut sum, mut count) = (0.0, 0usize);
        // Signed error and its square over the pixels that straddle an edge.
        let (mut signed, mut squares) = (0.0, 0.0);
        for y in (0..h).step_by(2) {
            for x in (0..w).step_by(2) {
                // Dark share of the footprint, the pixel's light relative to a light pixel.
                let mut dark = 0usize;
                let mut on_board = 0usize;
                for i in 0..n {
                    for j in 0..n {
                        let p = Point2::new(
                            x as f64 + (i as f64 + 0.5) / n as f64 - 0.5,
                            y as f64 + (j as f64 + 0.5) / n as f64 - 0.5,
                        );
                        let dir = cam.ray(p).unwrap();
                        if let Some(hit) =
                            scene.nearest_hit(&Point3::origin(), &dir, f64::INFINITY, None)
                        {
                            on_board += 1;
                            dark += (hit.surface == 0) as usize;
                        }
                    }
                }
                if on_board < n * n {
                    continue;
                }
                let f = dark as f64 / (n * n) as f64;
                let straddles = f > 0.0 && f < 1.0;
                straddling += straddles as usize;
                // Expected light, up to the smooth variation of irradiance over the board:
                // compare with the light of the same pixel were it all light.
                let pixel = Point2::new(x as f64, y as f64);
                let dir = cam.ray(pixel).unwrap();
                let hit = scene
                    .nearest_hit(&Point3::origin(), &dir, f64::INFINITY, None)
                    .unwrap();
                let all_light = light_of_point(&system, &hit.point, &hit.normal, LIGHT_ALBEDO);
                let expected = all_light * (1.0 - f + f * DARK_ALBEDO / LIGHT_ALBEDO);
                let got = image[y * w + x] as f64;
                let e = (got - expected) / all_light;
                worst = worst.max(e.abs());
                sum += e.abs();
                count += 1;
                if straddles {
                    signed += e;
                    squares += e * e;
                }
            }
        }
        let bias = signed / straddling as f64;
        let spread = (squares / straddling as f64 - bias * bias).sqrt();
        eprintln!(
            "{straddling} straddling of {count} pixels: worst {worst:.4}, mean |difference| {:.5}; straddling: mean {bias:+.5}, std {spread:.4}",
            sum / count as f64
        );
        assert!(straddling > 50, "{straddling} pixels straddle an edge");
        // 8 × 8 multi-jittered rendering rays vs a fixed 32 × 32 grid here. The jittered rays
        // read a straight edge without bias, with an error independent from pixel to pixel: an
        // edge crosses about s = 8 of the pixel's cells, each cut cell's ray is a Bernoulli
        // draw weighing 1/s², so a share's std is at most √(s/4)/s² = 0.022 (× the contrast
        // 0.94 of a light pixel) and the worst of a few hundred straddling pixels about 3 of
        // those. (A fixed 8 × 8 grid was off by at most a few 1/64 per pixel, but the same way
        // at the same phase in every pixel along an edge: worst 0.018, mean 0.0006.)
        // No bias: the mean signed difference within 4 standard errors of 0.
        let standard_error = spread / (straddling as f64).sqrt();
        assert!(
            bias.abs() < 4.0 * standard_error,
            "mean signed difference {bias} on straddling pixels (standard error {standard_error})"
        );
        assert!(spread < 0.022, "std {spread} on straddling pixels");
        assert!(worst < 0.07, "worst relative difference {worst}");
        assert!(sum / (count as f64) < 0.002, "mean relative difference");
    }

    /// Lambertian white-frame signal of a point (direct light plus ambient), as the transport.
    fn light_of_point(
        system: &System,
        x: &Point3<f64>,
        normal: &nalgebra::Unit<Vector3<f64>>,
        albedo: f64,
    ) -> f64 {
        let cal = &system.calibration;
        let o = cal.projector_centre_mm();
        let n = if normal.dot(&(o - x)) > 0.0 {
            normal.into_inner()
        } else {
            -normal.into_inner()
        };
        let depth = cal.pose.to_projector(x).z;
        crate::radiometry::lambertian_signal(albedo, x, &n, &o, depth, system.reference_distance_mm)
            + albedo * AMBIENT
    }
}
