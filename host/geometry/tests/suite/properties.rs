//! Property tests of the geometric models: distortion and projection round trips, triangulation
//! round trips with and without distortion, calibration file round trips, and parsers that
//! never panic on arbitrary input.

use fsm_geometry::{
    BrownConrady, Calibration, Intrinsics, MeasurementVolume, Pinhole, Pose, TriangulationError,
};
use nalgebra::{Point2, Point3, Vector2, Vector3};
use proptest::prelude::*;

fn distortion(scale: f64) -> impl Strategy<Value = BrownConrady> {
    (
        -0.3..0.3f64,
        -0.1..0.1f64,
        -0.004..0.004f64,
        -0.004..0.004f64,
        -0.05..0.05f64,
    )
        .prop_map(move |(k1, k2, p1, p2, k3)| BrownConrady {
            k1: k1 * scale,
            k2: k2 * scale,
            p1: p1 * scale,
            p2: p2 * scale,
            k3: k3 * scale,
        })
}

fn intrinsics(width: u32, height: u32) -> impl Strategy<Value = Intrinsics> {
    (0.8..1.6f64, 0.95..1.05f64, -0.05..0.05f64, -0.05..0.05f64).prop_map(
        move |(f, aspect, dx, dy)| Intrinsics {
            fx_px: f * width as f64 * 2.0,
            fy_px: f * width as f64 * 2.0 * aspect,
            cx_px: (width as f64 - 1.0) * (0.5 + dx),
            cy_px: (height as f64 - 1.0) * (0.5 + dy),
        },
    )
}

/// A bench-like rig: projector 120–300 mm to the side, toed in at a target 400–600 mm away.
fn calibration(distorted: bool) -> impl Strategy<Value = Calibration> {
    let scale = if distorted { 1.0 } else { 0.0 };
    (
        intrinsics(320, 240),
        distortion(scale),
        intrinsics(768, 1024),
        distortion(scale * 0.5),
        (120.0..300.0f64, -40.0..40.0f64, -30.0..30.0f64),
        (400.0..600.0f64, -0.2..0.2f64),
    )
        .prop_filter_map(
            "valid models",
            |(kc, dc, kp, dp, (bx, by, bz), (target, roll))| {
                let camera = Pinhole::new("camera", 320, 240, kc, dc).ok()?;
                // The projector's field must cover the camera's: scale its focal length down.
                let kp = Intrinsics {
                    fx_px: kp.fx_px * 0.5,
                    fy_px: kp.fy_px * 0.5,
                    ..kp
                };
                let projector = Pinhole::new("projector", 768, 1024, kp, dp).ok()?;
                let pose = Pose::looking_at(
                    Point3::new(bx, by, bz),
                    Point3::new(0.0, 0.0, target),
                    Vector3::new(roll, 1.0, 0.0),
                )?;
                let volume = MeasurementVolume::new(0.6 * target, 1.5 * target).ok()?;
                Some(Calibration {
                    camera,
                    projector,
                    pose,
                    volume,
                })
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn undistort_inverts_distort(d in distortion(1.0), x in -0.5..0.5f64, y in -0.5..0.5f64) {
        let p = Vector2::new(x, y);
        prop_assume!(p.norm() < 0.8 * d.max_radius());
        // Only where the map is locally invertible.
        prop_assume!(d.jacobian(p).determinant() > 0.05);
        let q = d.distort(p);
        let back = d.undistort(q).expect("undistorts");
        prop_assert!((back - p).norm() < 1e-9, "{p} -> {q} -> {back}");
    }

    #[test]
    fn pixel_ray_projects_back_to_the_pixel(
        k in intrinsics(320, 240),
        d in distortion(1.0),
        u in -0.5..319.5f64,
        v in -0.5..239.5f64,
        depth in 50.0..5000.0f64,
    ) {
        let Ok(camera) = Pinhole::new("camera", 320, 240, k, d) else { return Ok(()); };
        let pixel = Point2::new(u, v);
        let ray = camera.ray(pixel).expect("every pixel of a validated model has a ray");
        let point = Point3::from(ray * depth);
        let back = camera.project(&point).expect("projects");
        prop_assert!((back - pixel).norm() < 1e-7, "{pixel} -> {back}");
    }

    #[test]
    fn triangulation_round_trip_without_distortion(
        cal in calibration(false),
        u in 0.0..319.0f64,
        v in 0.0..239.0f64,
        t in 0.0..1.0f64,
    ) {
        round_trip(&cal, u, v, t)?;
    }

    #[test]
    fn triangulation_round_trip_with_distortion(
        cal in calibration(true),
        u in 0.0..319.0f64,
        v in 0.0..239.0f64,
        t in 0.0..1.0f64,
    ) {
        round_trip(&cal, u, v, t)?;
    }

    #[test]
    fn file_round_trip_is_exact(cal in calibration(true)) {
        let text = cal.to_toml();
        let back = Calibration::from_toml(&text, "test").expect("own output parses");
        prop_assert_eq!(back, cal);
        prop_assert_eq!(back.checksum(), cal.checksum());
    }

    #[test]
    fn parsing_arbitrary_text_never_panics(text in any::<String>()) {
        let _ = Calibration::from_toml(&text, "fuzz");
    }

    #[test]
    fn parsing_a_mutated_file_never_panics_and_never_returns_other_numbers(
        cal in calibration(true),
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<char>()), 1..6),
    ) {
        let mut text: Vec<char> = cal.to_toml().chars().collect();
        for (at, c) in edits {
            let i = at.index(text.len());
            text[i] = c;
        }
        let text: String = text.into_iter().collect();
        // Either an error, or the same calibration (an edit of a comment or whitespace), or a
        // file whose checksum no longer guards it because the edit removed it.
        if let Ok(back) = Calibration::from_toml(&text, "fuzz") {
            if text.contains("checksum_crc32") {
                prop_assert_eq!(back, cal);
            }
        }
    }
}

/// The point at fraction `t` of the volume on pixel `(u, v)`'s ray triangulates back to itself
/// from its own pixel and column.
fn round_trip(cal: &Calibration, u: f64, v: f64, t: f64) -> Result<(), TestCaseError> {
    let ray = cal.pixel_ray(Point2::new(u, v)).expect("pixel has a ray");
    let depth = cal.volume.near_mm() + t * (cal.volume.far_mm() - cal.volume.near_mm());
    let point = ray.point_at_depth(depth);
    let Some(column) = cal.projector_column_of(&point) else {
        return Ok(());
    };
    let Ok(range) = ray.column_range() else {
        return Ok(());
    };
    prop_assert!(
        range.contains(column)
            || (column - range.first)
                .abs()
                .min((column - range.last).abs())
                < 1e-9,
        "column {column} outside {range:?}"
    );
    let pixel = cal.camera_pixel_of(&point).expect("in front of the camera");
    match cal.triangulate(pixel, column) {
        Ok(back) => prop_assert!(
            (back - point).norm() < 1e-6 * depth,
            "{point} -> ({pixel}, {column}) -> {back}"
        ),
        // Only at the very limits of the volume may rounding put the column outside.
        Err(TriangulationError::NotInVolume { reachable, .. }) => prop_assert!(
            (column - reachable.first)
                .abs()
                .min((column - reachable.last).abs())
                < 1e-6,
            "{column} vs {reachable:?}"
        ),
        Err(e) => prop_assert!(false, "{e}"),
    }
    Ok(())
}
