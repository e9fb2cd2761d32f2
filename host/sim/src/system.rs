//! The simulated scanner: a calibrated camera–projector pair plus the projector's optics.

use fsm_geometry::{BrownConrady, Calibration, Intrinsics, MeasurementVolume, Pinhole, Pose};
use nalgebra::{Point3, Vector3};

/// The default blur of the projector's optics, columns (SPEC §7; paper §III-D2).
pub const DEFAULT_BLUR_SIGMA_COLUMNS: f64 = 0.7;

/// A camera–projector pair as the simulator renders it.
///
/// Radiometry, in units of the *reference white*: the signal of a pixel that sees an albedo-1
/// Lambertian surface facing the projector on its optical axis at `reference_distance_mm`,
/// under a full-on frame. A projector column emits its value over its whole width (SPEC §7),
/// blurred by a Gaussian of `blur_sigma_columns` in the projector's image plane.
#[derive(Clone, Debug, PartialEq)]
pub struct System {
    /// Camera, projector, pose and measurement volume: the simulator's ground truth geometry.
    pub calibration: Calibration,
    /// Std of the projector's defocus blur in columns; 0 = a perfectly sharp projector, with
    /// which every decoder is off the geometric truth by up to ±0.5 column when the camera
    /// out-resolves the projector (SPEC §7).
    pub blur_sigma_columns: f64,
    /// Projector response `output = black + (1 − black)·value^gamma`; 1 = linear.
    pub gamma: f64,
    /// Projector output for value 0 (leakage of a DMD), fraction of full output.
    pub black_level: f64,
    /// Distance of the reference white from the projector centre, mm.
    pub reference_distance_mm: f64,
}

impl System {
    /// The default bench scanner, 320 × 240 camera (renders and decodes in seconds).
    ///
    /// | | |
    /// |---|---|
    /// | camera | 320 × 240 px, `f` = 640 px (28° × 21° field), principal point at the centre, mild barrel distortion `k1 = −0.06, k2 = 0.02, p1 = 5e-4, p2 = −3e-4` |
    /// | projector | 768 columns (the paper's `cmax`) × 1024 rows, `f` = 1400 px (31° across the columns), pincushion `k1 = 0.03, k2 = −0.01` |
    /// | baseline | 200 mm along the camera's `x` axis (projector to the right) |
    /// | standoff | 500 mm: both optical axes meet at `(0, 0, 500)` in the camera frame |
    /// | measurement volume | depths 350–700 mm |
    /// | footprint | one camera pixel ≈ 0.78 mm ≈ 1.9 projector columns on the plane at 500 mm |
    /// | optics | blur σ = 0.7 column, linear (gamma 1), black level 0 |
    /// | reference white | albedo 1 at 538.5 mm (the projector's distance to the aim point) |
    pub fn bench() -> System {
        System::bench_with_camera(320, 240)
    }

    /// The bench with a camera of `width × height` pixels and the same field of view (focal
    /// length `2·width` px): e.g. 640 × 480 for a footprint under one projector column.
    pub fn bench_with_camera(width: u32, height: u32) -> System {
        let f = 2.0 * width as f64;
        let camera = Pinhole::new(
            "camera",
            width,
            height,
            Intrinsics {
                fx_px: f,
                fy_px: f,
                cx_px: (width as f64 - 1.0) / 2.0,
                cy_px: (height as f64 - 1.0) / 2.0,
            },
            BrownConrady {
                k1: -0.06,
                k2: 0.02,
                p1: 5e-4,
                p2: -3e-4,
                k3: 0.0,
            },
        )
        .expect("bench camera is valid");
        let projector = Pinhole::new(
            "projector",
            768,
            1024,
            Intrinsics {
                fx_px: 1400.0,
                fy_px: 1400.0,
                cx_px: 383.5,
                cy_px: 511.5,
            },
            BrownConrady {
                k1: 0.03,
                k2: -0.01,
                ..BrownConrady::NONE
            },
        )
        .expect("bench projector is valid");
        let centre = Point3::new(200.0, 0.0, 0.0);
        let aim = Point3::new(0.0, 0.0, 500.0);
        let pose = Pose::looking_at(centre, aim, Vector3::y()).expect("bench pose is valid");
        System {
            calibration: Calibration {
                camera,
                projector,
                pose,
                volume: MeasurementVolume::new(350.0, 700.0).expect("bench volume is valid"),
            },
            blur_sigma_columns: DEFAULT_BLUR_SIGMA_COLUMNS,
            gamma: 1.0,
            black_level: 0.0,
            reference_distance_mm: (aim - centre).norm(),
        }
    }

    /// Projector columns `cmax`.
    pub fn projector_columns(&self) -> u32 {
        self.calibration.projector.width_px()
    }

    /// Camera image width, pixels.
    pub fn width(&self) -> u32 {
        self.calibration.camera.width_px()
    }

    /// Camera image height, pixels.
    pub fn height(&self) -> u32 {
        self.calibration.camera.height_px()
    }

    /// Projector output for a pattern value in `[0, 1]` (gamma, black level): the value is the
    /// code the projector is given (pre-corrected codes: [`crate::capture::DrivenCodes`]).
    pub fn emitted(&self, value: f32) -> f32 {
        let v = value.clamp(0.0, 1.0) as f64;
        let shaped = if self.gamma == 1.0 {
            v
        } else {
            libm::pow(v, self.gamma)
        };
        (self.black_level + (1.0 - self.black_level) * shaped) as f32
    }

    /// Checks the optics' numbers; the message names the field.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.blur_sigma_columns.is_finite() && self.blur_sigma_columns >= 0.0) {
            return Err(format!(
                "system.blur_sigma_columns = {}: must be finite and not negative",
                self.blur_sigma_columns
            ));
        }
        if self.blur_sigma_columns > 8.0 {
            return Err(format!(
                "system.blur_sigma_columns = {}: at most 8 columns is supported",
                self.blur_sigma_columns
            ));
        }
        if !(self.gamma.is_finite() && self.gamma > 0.0) {
            return Err(format!("system.gamma = {}: must be above 0", self.gamma));
        }
        if !(0.0..1.0).contains(&self.black_level) {
            return Err(format!(
                "system.black_level = {}: must be in [0, 1)",
                self.black_level
            ));
        }
        if !(self.reference_distance_mm.is_finite() && self.reference_distance_mm > 0.0) {
            return Err(format!(
                "system.reference_distance_mm = {}: must be above 0",
                self.reference_distance_mm
            ));
        }
        Ok(())
    }
}
