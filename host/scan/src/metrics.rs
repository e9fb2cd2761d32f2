//! The paper's Fig. 9 metrics, and the column errors the simulator's ground truth allows.
//!
//! - `Ed`: RMS distance between the points of the same pixels in two scans (with and without
//!   interreflection).
//! - `EnoI`, `EwiI`: RMS distance of a scan's points to their least-squares plane.
//! - completeness: the share of pixels that got a point.
//! - column errors against the true direct column: RMS, and the share within 0.5 column.
//! - point errors against the true surface point: the share of output points more than a
//!   distance off, and the share of the directly lit pixels that keep a right point.

use nalgebra::{Matrix3, SymmetricEigen, Vector3};

/// RMS distance between the points two scans chose for the same pixels (`Ed`), over the
/// pixels of `mask` where both have one; `None` if there are none.
pub fn rms_deviation_mm(
    a: &[Option<[f32; 3]>],
    b: &[Option<[f32; 3]>],
    mask: &[bool],
) -> Option<f64> {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for ((p, q), &m) in a.iter().zip(b).zip(mask) {
        if let (true, Some(p), Some(q)) = (m, p, q) {
            let d: f64 = (0..3).map(|i| (p[i] as f64 - q[i] as f64).powi(2)).sum();
            sum += d;
            n += 1;
        }
    }
    (n > 0).then(|| (sum / n as f64).sqrt())
}

/// RMS orthogonal distance of `points` to their least-squares plane (`EnoI`, `EwiI`): the
/// square root of the smallest eigenvalue of their covariance. `None` below 3 points.
pub fn plane_fit_rmse_mm(points: impl IntoIterator<Item = [f32; 3]>) -> Option<f64> {
    let points: Vec<Vector3<f64>> = points
        .into_iter()
        .map(|p| Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .collect();
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let centroid = points.iter().sum::<Vector3<f64>>() / n;
    let mut covariance = Matrix3::zeros();
    for p in &points {
        let d = p - centroid;
        covariance += d * d.transpose();
    }
    covariance /= n;
    let eigen = SymmetricEigen::new(covariance);
    Some(eigen.eigenvalues.min().max(0.0).sqrt())
}

/// Column errors of the chosen columns against the truth, over the pixels of `mask` that have
/// a true column.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ColumnErrors {
    /// Pixels compared (masked, with a true column).
    pub pixels: usize,
    /// Of those, pixels that got a column.
    pub decoded: usize,
    /// RMS error of the decoded columns within 0.5 column of the truth (the precision of the
    /// ones that are right).
    pub rms_columns: f64,
    /// Share of the compared pixels whose column is within 0.5 column of the truth.
    pub within_half_column: f64,
    /// RMS error of every decoded column, outliers included (how far off a method is).
    pub rms_all_columns: f64,
}

/// Compares chosen columns with true ones (`NaN` where a pixel has no true column).
pub fn column_errors(chosen: &[Option<f32>], truth: &[f64], mask: &[bool]) -> ColumnErrors {
    let (mut pixels, mut decoded, mut within, mut sum, mut sum_all) =
        (0usize, 0usize, 0usize, 0.0f64, 0.0f64);
    for ((c, &t), &m) in chosen.iter().zip(truth).zip(mask) {
        if !m || !t.is_finite() {
            continue;
        }
        pixels += 1;
        if let Some(c) = c {
            decoded += 1;
            let e = *c as f64 - t;
            sum_all += e * e;
            if e.abs() <= 0.5 {
                within += 1;
                sum += e * e;
            }
        }
    }
    ColumnErrors {
        pixels,
        decoded,
        rms_columns: if within > 0 {
            (sum / within as f64).sqrt()
        } else {
            f64::NAN
        },
        within_half_column: if pixels > 0 {
            within as f64 / pixels as f64
        } else {
            f64::NAN
        },
        rms_all_columns: if decoded > 0 {
            (sum_all / decoded as f64).sqrt()
        } else {
            f64::NAN
        },
    }
}

/// Ground truth of a scanned scene, per pixel (row-major, the surface's size).
#[derive(Clone, Copy, Debug)]
pub struct Truth<'a> {
    /// The direct column (SPEC §7), `NaN` where the projector does not light the pixel's point.
    pub direct_column: &'a [f64],
    /// Pixels whose indirect light exceeds 20% of their direct light.
    pub interreflection: &'a [bool],
    /// Pixels of the measured surface (the plane of the Fig. 9 metrics), away from edges.
    pub surface: &'a [bool],
}

/// The paper's Fig. 9 figures of one method on a scene with interreflection and its twin
/// without, plus column errors against the truth.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Comparison {
    /// Column errors in the interreflection region.
    pub interreflection: ColumnErrors,
    /// The same pixels in the scene without interreflection.
    pub interreflection_covered: ColumnErrors,
    /// Column errors over the whole surface, with interreflection.
    pub surface: ColumnErrors,
    /// `Ed`, mm: RMS distance between the two scans' points on the surface.
    pub e_d_mm: f64,
    /// `EnoI`, mm: plane-fit RMSE without interreflection.
    pub e_no_i_mm: f64,
    /// `EwiI`, mm: plane-fit RMSE with interreflection.
    pub e_wi_i_mm: f64,
    /// Share of the surface's pixels with a point, with interreflection.
    pub completeness: f64,
}

/// Compares a scan with interreflection (`with`) and one of the same scene without
/// (`without`) against `truth`.
pub fn compare(with: &crate::Surface, without: &crate::Surface, truth: &Truth<'_>) -> Comparison {
    let on_surface = |s: &crate::Surface| -> Vec<[f32; 3]> {
        s.point_mm
            .iter()
            .zip(truth.surface)
            .filter_map(|(p, &m)| if m { *p } else { None })
            .collect()
    };
    let surface_pixels = truth.surface.iter().filter(|&&m| m).count();
    Comparison {
        interreflection: column_errors(&with.column, truth.direct_column, truth.interreflection),
        interreflection_covered: column_errors(
            &without.column,
            truth.direct_column,
            truth.interreflection,
        ),
        surface: column_errors(&with.column, truth.direct_column, truth.surface),
        e_d_mm: rms_deviation_mm(&with.point_mm, &without.point_mm, truth.surface)
            .unwrap_or(f64::NAN),
        e_no_i_mm: plane_fit_rmse_mm(on_surface(without)).unwrap_or(f64::NAN),
        e_wi_i_mm: plane_fit_rmse_mm(on_surface(with)).unwrap_or(f64::NAN),
        completeness: on_surface(with).len() as f64 / surface_pixels.max(1) as f64,
    }
}

/// Output points against the true surface point of their pixel ([`point_errors`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct PointErrors {
    /// The distance beyond which a point is wrong, mm.
    pub wrong_beyond_mm: f64,
    /// Pixels with a point.
    pub points: usize,
    /// Of those, more than `wrong_beyond_mm` from the truth, or on a pixel whose ray meets no
    /// surface.
    pub wrong: usize,
    /// Pixels the truth says are lit directly (the mask given).
    pub lit: usize,
    /// Of those, pixels whose point is within `wrong_beyond_mm` of the truth.
    pub lit_right: usize,
}

impl PointErrors {
    /// `wrong / points` (0 without points).
    pub fn wrong_share(&self) -> f64 {
        self.wrong as f64 / self.points.max(1) as f64
    }

    /// `lit_right / lit` (0 without lit pixels).
    pub fn completeness(&self) -> f64 {
        self.lit_right as f64 / self.lit.max(1) as f64
    }
}

/// Compares every point with the true surface point of its pixel (`NaN`s where the pixel's ray
/// meets no surface); `lit` masks the pixels the truth says are lit directly.
pub fn point_errors(
    points: &[Option<[f32; 3]>],
    truth_mm: &[[f64; 3]],
    lit: &[bool],
    wrong_beyond_mm: f64,
) -> PointErrors {
    let mut e = PointErrors {
        wrong_beyond_mm,
        ..PointErrors::default()
    };
    for ((p, t), &lit) in points.iter().zip(truth_mm).zip(lit) {
        let right = p.is_some_and(|p| {
            let d: f64 = (0..3).map(|k| (p[k] as f64 - t[k]).powi(2)).sum();
            // NaN (no true surface) is never right.
            d.sqrt() <= wrong_beyond_mm
        });
        if p.is_some() {
            e.points += 1;
            e.wrong += usize::from(!right);
        }
        if lit {
            e.lit += 1;
            e.lit_right += usize::from(right);
        }
    }
    e
}

/// [`point_errors`] against a true depth map (camera `z`, mm, `NaN` where the pixel sees no
/// surface), as `fsm simulate` writes it: each point's true point is the one on its own ray
/// (the camera's centre through the point) at the true depth.
pub fn point_errors_from_depth(
    points: &[Option<[f32; 3]>],
    true_depth_mm: &[f32],
    lit: &[bool],
    wrong_beyond_mm: f64,
) -> PointErrors {
    let truth_mm: Vec<[f64; 3]> = points
        .iter()
        .zip(true_depth_mm)
        .map(|(p, &z)| match p {
            Some(p) if p[2] != 0.0 => {
                let scale = z as f64 / p[2] as f64;
                [p[0] as f64 * scale, p[1] as f64 * scale, z as f64]
            }
            _ => [f64::NAN; 3],
        })
        .collect();
    point_errors(points, &truth_mm, lit, wrong_beyond_mm)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_truth_is_taken_along_each_points_ray() {
        // A point on a ray 13/12 as long as its depth ((150, 200, 600) mm), one on a pixel whose
        // ray meets no surface, and a lit pixel without a point.
        let points = [Some([150.0, 200.0, 600.0]), Some([0.0, 0.0, 500.0]), None];
        let e = point_errors_from_depth(
            &points,
            &[600.5, f32::NAN, 500.0],
            &[true, false, true],
            1.0,
        );
        // 0.5 mm of depth is 0.54 mm along the ray: right; NaN truth: wrong.
        assert_eq!((e.points, e.wrong, e.lit, e.lit_right), (2, 1, 2, 1));
        let e = point_errors_from_depth(&points[..1], &[601.0], &[true], 1.0);
        assert_eq!(e.wrong, 1, "1 mm of depth is 1.08 mm along the ray");
    }

    #[test]
    fn point_errors_count_far_points_and_points_on_no_surface_as_wrong() {
        let nan = [f64::NAN; 3];
        let truth = [[0.0, 0.0, 500.0], [0.0, 0.0, 500.0], nan, [0.0, 0.0, 500.0]];
        let points = [
            Some([0.0, 0.0, 500.5]),
            Some([0.0, 0.0, 502.0]),
            Some([0.0, 0.0, 500.0]),
            None,
        ];
        let e = point_errors(&points, &truth, &[true, true, false, true], 1.0);
        assert_eq!((e.points, e.wrong, e.lit, e.lit_right), (3, 2, 3, 1));
    }
}
