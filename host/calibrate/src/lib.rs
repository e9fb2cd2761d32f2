//! Geometric calibration of a camera–projector pair from scans of a planar checkerboard
//! (SPEC §5): the board and its inner corners, sub-pixel corner detection in the camera image,
//! Zhang's closed form, Levenberg–Marquardt refinement, and the projector as an inverse camera
//! observed through its column coordinate only (Moreno–Taubin local homographies).

pub mod board;
pub mod calibrate;
pub mod corners;
pub mod dense;
pub mod homography;
pub mod pose_folder;
pub mod projector;
pub mod refine;
pub mod report;
pub mod response;
pub mod zhang;

pub use calibrate::{
    calibrate, calibrate_from_columns, CalibrateError, CalibrationReport, CalibrationSettings,
    ColumnMap, PoseObservation,
};
