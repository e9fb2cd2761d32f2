//! Every candidate of a decoded image → a 3D point (SPEC §5), ready for selection.
//!
//! Candidates whose point falls outside the measurement volume are fictitious and dropped; the
//! per-pixel column range of that volume can also be given to the decoder beforehand
//! ([`column_limits`]), which drops them before they are even triangulated.

use fsm_core::{ColumnRange, PixelFlags};
use fsm_geometry::Calibration;
use fsm_io::candidate_image::CandidateImage;
use nalgebra::Point2;
use rayon::prelude::*;

use crate::selection::{CandidateField, Label};
use crate::surface::NoPoint;

/// One row triangulated: each pixel's label count, the labels, each pixel's reason for having
/// none.
type TriangulatedRow = (Vec<u32>, Vec<Label>, Vec<Option<NoPoint>>);

/// Every candidate of `image` triangulated (rows in parallel, each into flat lists); none for
/// the pixels whose candidates may be mixtures ([`fsm_core::PixelFlags::is_mixed`]) when
/// `drop_aliased`. With the field, why each pixel that has no candidate in it has none.
pub fn candidate_field(
    calibration: &Calibration,
    image: &CandidateImage,
    drop_aliased: bool,
) -> (CandidateField, Vec<Option<NoPoint>>) {
    let width = image.width();
    let rows: Vec<TriangulatedRow> = (0..image.height())
        .into_par_iter()
        .map(|y| {
            let mut counts = Vec::with_capacity(width);
            let mut labels = Vec::new();
            let mut reasons = Vec::with_capacity(width);
            for x in 0..width {
                let before = labels.len();
                let reason = triangulate_pixel(calibration, image, x, y, drop_aliased, &mut labels);
                counts.push((labels.len() - before) as u32);
                reasons.push(reason.err());
            }
            (counts, labels, reasons)
        })
        .collect();
    let mut before = Vec::with_capacity(image.pixel_count());
    let mut counts = Vec::with_capacity(image.pixel_count());
    let mut labels = Vec::with_capacity(rows.iter().map(|r| r.1.len()).sum());
    for (c, l, r) in rows {
        counts.extend(c);
        labels.extend(l);
        before.extend(r);
    }
    let field = CandidateField::from_counts(width, image.height(), &counts, labels);
    (field, before)
}

/// Appends pixel `(x, y)`'s labels (`y` counted from the image's first row) to `labels`, or
/// says why it has none.
fn triangulate_pixel(
    calibration: &Calibration,
    image: &CandidateImage,
    x: usize,
    y: usize,
    drop_aliased: bool,
    labels: &mut Vec<Label>,
) -> Result<(), NoPoint> {
    let i = y * image.width() + x;
    let flags = image.flags(i);
    let candidates = image.candidates(i);
    if flags.contains(PixelFlags::NO_DATA) {
        return Err(NoPoint::NoData);
    }
    if candidates.is_empty() {
        return Err(NoPoint::NoLight);
    }
    if drop_aliased && flags.contains(PixelFlags::ALIASED) {
        return Err(NoPoint::Aliased);
    }
    if drop_aliased && flags.contains(PixelFlags::UNRESOLVED) {
        return Err(NoPoint::Unresolved);
    }
    let pixel = Point2::new(x as f64, (image.first_row() + y) as f64);
    let Ok(ray) = calibration.pixel_ray(pixel) else {
        return Err(NoPoint::OutsideVolume);
    };
    let before = labels.len();
    labels.extend(candidates.iter().filter_map(|c| {
        let p = ray.triangulate(c.column as f64).ok()?;
        Some(Label {
            point_mm: [p.x as f32, p.y as f32, p.z as f32],
            amplitude: c.amplitude,
            column: c.column,
        })
    }));
    if labels.len() == before {
        Err(NoPoint::OutsideVolume)
    } else {
        Ok(())
    }
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
