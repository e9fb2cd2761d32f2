//! The measured surface: one point (or none) per pixel after selection, with its column and
//! the direct / indirect illumination images (eqs. 12–13).

use fsm_geometry::Calibration;

use crate::ply::PlyPoint;
use crate::selection::{select, CandidateField, Selection, SelectionParams};

/// The result of a scan.
#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// The chosen point of every pixel, camera frame, mm.
    pub point_mm: Vec<Option<[f32; 3]>>,
    /// The chosen candidate's projector column.
    pub column: Vec<Option<f32>>,
    /// `I_d` (eq. 12), sensor DN.
    pub direct: Vec<f32>,
    /// `I_id` (eq. 13), sensor DN.
    pub indirect: Vec<f32>,
    /// Candidates that triangulated inside the measurement volume.
    pub candidates: usize,
}

impl Surface {
    /// Selects the direct candidate of every pixel of `field` and gathers its point.
    pub fn select(field: &CandidateField, params: &SelectionParams) -> Surface {
        let selection: Selection = select(field, params);
        let pixels = field.width() * field.height();
        let mut surface = Surface {
            width: field.width(),
            height: field.height(),
            point_mm: vec![None; pixels],
            column: vec![None; pixels],
            direct: selection.direct,
            indirect: selection.indirect,
            candidates: field.len(),
        };
        for (i, choice) in selection.choice.iter().enumerate() {
            if let Some(c) = choice {
                let label = field.labels(i % field.width(), i / field.width())[*c as usize];
                surface.point_mm[i] = Some(label.point_mm);
                surface.column[i] = Some(label.column);
            }
        }
        surface
    }

    /// Pixels with a point.
    pub fn points(&self) -> usize {
        self.point_mm.iter().filter(|p| p.is_some()).count()
    }

    /// Depth (camera `z`, mm) per pixel, `NaN` where none.
    pub fn depth_mm(&self) -> Vec<f32> {
        self.point_mm
            .iter()
            .map(|p| p.map_or(f32::NAN, |p| p[2]))
            .collect()
    }

    /// The points as PLY vertices.
    pub fn ply_points(&self) -> Vec<PlyPoint> {
        self.point_mm
            .iter()
            .enumerate()
            .filter_map(|(i, p)| {
                p.map(|p| PlyPoint {
                    point_mm: p,
                    intensity: self.direct[i],
                    pixel: [(i % self.width) as u16, (i / self.width) as u16],
                })
            })
            .collect()
    }
}

impl SelectionParams {
    /// Defaults for a calibrated system: the pixel footprint at the middle of the measurement
    /// volume, depth over the camera's focal length.
    pub fn for_calibration(calibration: &Calibration) -> Self {
        let depth = 0.5 * (calibration.volume.near_mm() + calibration.volume.far_mm());
        let focal = calibration
            .camera
            .intrinsics()
            .fx_px
            .max(calibration.camera.intrinsics().fy_px);
        SelectionParams::for_footprint((depth / focal) as f32)
    }
}

/// Seconds spent in each stage after decoding.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Triangulating every candidate.
    pub triangulate_seconds: f64,
    /// Selecting the direct candidates.
    pub select_seconds: f64,
}

impl Surface {
    /// Triangulates every candidate of `decoded` and selects the direct ones.
    pub fn reconstruct(
        decoded: &crate::decoded::DecodedImage,
        calibration: &Calibration,
        params: &SelectionParams,
    ) -> (Surface, StageTimes) {
        let started = std::time::Instant::now();
        let field = crate::triangulate::candidate_field(
            calibration,
            decoded.first_row,
            decoded.width,
            decoded.height,
            &decoded.pixels,
            params.drop_aliased,
        );
        let triangulated = std::time::Instant::now();
        let surface = Surface::select(&field, params);
        let times = StageTimes {
            triangulate_seconds: (triangulated - started).as_secs_f64(),
            select_seconds: triangulated.elapsed().as_secs_f64(),
        };
        (surface, times)
    }
}
