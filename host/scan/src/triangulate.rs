//! Every candidate of a decoded image → a 3D point (SPEC §5), ready for selection.
//!
//! Candidates whose point falls outside the measurement volume are fictitious and dropped; the
//! per-pixel column range of that volume can also be given to the decoder beforehand
//! ([`column_limits`]), which drops them before they are even triangulated.

use fsm_core::{ColumnRange, PixelCandidates, PixelFlags};
use fsm_geometry::Calibration;
use nalgebra::Point2;
use rayon::prelude::*;

use crate::selection::{CandidateField, Label};
use crate::surface::NoPoint;

/// The candidates of `height` camera rows from `first_row` on, `width` pixels each (row-major
/// `pixels`), triangulated; none for the pixels whose candidates may be mixtures
/// ([`fsm_core::PixelFlags::is_mixed`]) when `drop_aliased`. With the field, why each pixel
/// that has no candidate in it has none.
pub fn candidate_field<const K: usize>(
    calibration: &Calibration,
    first_row: usize,
    width: usize,
    height: usize,
    pixels: &[PixelCandidates<K>],
    drop_aliased: bool,
) -> (CandidateField, Vec<Option<NoPoint>>) {
    assert_eq!(pixels.len(), width * height, "one candidate list per pixel");
    let rows: Vec<Vec<Result<Vec<Label>, NoPoint>>> = (0..height)
        .into_par_iter()
        .map(|y| {
            (0..width)
                .map(|x| {
                    let pixel = Point2::new(x as f64, (first_row + y) as f64);
                    let candidates = &pixels[y * width + x];
                    if candidates.flags.contains(PixelFlags::NO_DATA) {
                        return Err(NoPoint::NoData);
                    }
                    if candidates.candidates.is_empty() {
                        return Err(NoPoint::NoLight);
                    }
                    if drop_aliased && candidates.flags.contains(PixelFlags::ALIASED) {
                        return Err(NoPoint::Aliased);
                    }
                    if drop_aliased && candidates.flags.contains(PixelFlags::UNRESOLVED) {
                        return Err(NoPoint::Unresolved);
                    }
                    let Ok(ray) = calibration.pixel_ray(pixel) else {
                        return Err(NoPoint::OutsideVolume);
                    };
                    let labels: Vec<Label> = candidates
                        .candidates
                        .iter()
                        .filter_map(|c| {
                            let p = ray.triangulate(c.column as f64).ok()?;
                            Some(Label {
                                point_mm: [p.x as f32, p.y as f32, p.z as f32],
                                amplitude: c.amplitude,
                                column: c.column,
                            })
                        })
                        .collect();
                    if labels.is_empty() {
                        Err(NoPoint::OutsideVolume)
                    } else {
                        Ok(labels)
                    }
                })
                .collect()
        })
        .collect();
    let field = CandidateField::from_fn(width, height, |x, y| {
        rows[y][x].as_ref().map_or(Vec::new(), Clone::clone)
    });
    let before = rows
        .iter()
        .flatten()
        .map(|r| r.as_ref().err().copied())
        .collect();
    (field, before)
}

/// The projector columns pixel `(x, y)` can see inside the measurement volume, for
/// [`fsm_core::Row::column_limits`]; an empty range where the pixel sees none.
pub fn column_limits(calibration: &Calibration, width: usize, y: usize) -> Vec<ColumnRange> {
    (0..width)
        .map(
            |x| match calibration.column_range(Point2::new(x as f64, y as f64)) {
                Ok(range) => range.to_column_range(),
                Err(_) => ColumnRange {
                    first: 1.0,
                    last: 0.0,
                },
            },
        )
        .collect()
}
