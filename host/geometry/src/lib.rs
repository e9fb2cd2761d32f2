//! # fsm-geometry: camera and projector geometry (SPEC §5)
//!
//! | concept | module |
//! |---|---|
//! | Brown–Conrady distortion `(k1, k2, p1, p2, k3)`, OpenCV's order; iterative undistortion | [`distortion`] |
//! | pinhole `K` + distortion, shared by camera and projector (an inverse camera) | [`pinhole`] |
//! | pose `X_p = R·X_c + t`, mm | [`pose`] |
//! | depth limits of the measurement | [`volume`] |
//! | the calibrated pair | [`calibration`] |
//! | candidate `(pixel, column)` → 3D point; a pixel's reachable columns | [`triangulation`] |
//! | the calibration file (TOML, versioned, checksummed) | [`file`](mod@file) |
//! | OpenCV FileStorage calibrations of SLStudio, scan3d-capture, procam-calibration | [`opencv`] |
//!
//! Conventions: pixel `(0, 0)` has its centre at `(0, 0)`; projector column `j` has its centre
//! at `c = j` (SPEC §1); every length is in millimetres; the camera frame is the world frame.
//!
//! ```
//! use fsm_geometry::{BrownConrady, Calibration, Intrinsics, MeasurementVolume, Pinhole, Pose};
//! use nalgebra::{Point2, Point3, Vector3};
//!
//! let k = |f: f64, cx: f64, cy: f64| Intrinsics { fx_px: f, fy_px: f, cx_px: cx, cy_px: cy };
//! let camera = Pinhole::new("camera", 320, 240, k(640.0, 159.5, 119.5), BrownConrady::NONE)?;
//! let projector = Pinhole::new("projector", 768, 1024, k(1400.0, 383.5, 511.5), BrownConrady::NONE)?;
//! let pose = Pose::looking_at(
//!     Point3::new(200.0, 0.0, 0.0),
//!     Point3::new(0.0, 0.0, 500.0),
//!     Vector3::y(),
//! ).unwrap();
//! let cal = Calibration { camera, projector, pose, volume: MeasurementVolume::new(350.0, 700.0)? };
//! let point = Point3::new(10.0, -5.0, 520.0);
//! let pixel = cal.camera_pixel_of(&point).unwrap();
//! let column = cal.projector_column_of(&point).unwrap();
//! let back = cal.triangulate(pixel, column)?;
//! assert!((back - point).norm() < 1e-9);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod calibration;
pub mod distortion;
pub mod error;
pub mod file;
pub mod opencv;
pub mod pinhole;
pub mod pose;
pub mod triangulation;
pub mod volume;

pub use calibration::Calibration;
pub use distortion::{BrownConrady, UndistortError};
pub use error::ModelError;
pub use file::{CalibrationFileError, CalibrationFileErrorKind};
pub use pinhole::{Intrinsics, Pinhole};
pub use pose::Pose;
pub use triangulation::{ColumnInterval, PixelRay, TriangulationError};
pub use volume::MeasurementVolume;
