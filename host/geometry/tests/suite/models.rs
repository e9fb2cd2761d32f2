//! Behaviour of the models at their edges: errors that name the field, the volume and the
//! columns a pixel can reach, the calibration file's checks.

use fsm_geometry::{
    BrownConrady, Calibration, CalibrationFileErrorKind, Intrinsics, MeasurementVolume, Pinhole,
    Pose, TriangulationError,
};
use nalgebra::{Point2, Point3, Vector2, Vector3};

fn k(f: f64, cx: f64, cy: f64) -> Intrinsics {
    Intrinsics {
        fx_px: f,
        fy_px: f,
        cx_px: cx,
        cy_px: cy,
    }
}

fn rig(camera_d: BrownConrady, projector_d: BrownConrady) -> Calibration {
    Calibration {
        camera: Pinhole::new("camera", 320, 240, k(640.0, 159.5, 119.5), camera_d).unwrap(),
        projector: Pinhole::new("projector", 768, 1024, k(1400.0, 383.5, 511.5), projector_d)
            .unwrap(),
        pose: Pose::looking_at(
            Point3::new(200.0, 0.0, 0.0),
            Point3::new(0.0, 0.0, 500.0),
            Vector3::y(),
        )
        .unwrap(),
        volume: MeasurementVolume::new(350.0, 700.0).unwrap(),
    }
}

fn distorted() -> Calibration {
    rig(
        BrownConrady {
            k1: -0.12,
            k2: 0.08,
            p1: 0.001,
            p2: -0.0015,
            k3: 0.0,
        },
        BrownConrady {
            k1: 0.05,
            k2: -0.02,
            p1: -0.0005,
            p2: 0.0008,
            k3: 0.0,
        },
    )
}

#[test]
fn opencv_order_and_formula() {
    // OpenCV's projectPoints for distCoeffs (k1, k2, p1, p2, k3), written out independently.
    let d = BrownConrady::from_opencv([0.1, -0.05, 0.002, -0.003, 0.01]);
    assert_eq!(d.to_opencv(), [0.1, -0.05, 0.002, -0.003, 0.01]);
    let (x, y) = (0.3f64, -0.2f64);
    let r2 = x * x + y * y;
    let radial = 1.0 + 0.1 * r2 - 0.05 * r2 * r2 + 0.01 * r2 * r2 * r2;
    let xd = x * radial + 2.0 * 0.002 * x * y + (-0.003) * (r2 + 2.0 * x * x);
    let yd = y * radial + 0.002 * (r2 + 2.0 * y * y) + 2.0 * (-0.003) * x * y;
    let got = d.distort(Vector2::new(x, y));
    assert!((got.x - xd).abs() < 1e-15 && (got.y - yd).abs() < 1e-15);
    // The Jacobian agrees with finite differences.
    let j = d.jacobian(Vector2::new(x, y));
    let h = 1e-7;
    let dx = (d.distort(Vector2::new(x + h, y)) - d.distort(Vector2::new(x - h, y))) / (2.0 * h);
    let dy = (d.distort(Vector2::new(x, y + h)) - d.distort(Vector2::new(x, y - h))) / (2.0 * h);
    assert!((j[(0, 0)] - dx.x).abs() < 1e-7 && (j[(1, 0)] - dx.y).abs() < 1e-7);
    assert!((j[(0, 1)] - dy.x).abs() < 1e-7 && (j[(1, 1)] - dy.y).abs() < 1e-7);
}

#[test]
fn folding_distortion_is_refused_with_the_device_named() {
    // k1 = -0.6: the radial map folds at r = 1/sqrt(1.8) = 0.745, inside a wide-angle image.
    let d = BrownConrady {
        k1: -0.6,
        ..BrownConrady::NONE
    };
    assert!((d.max_radius() - (1.0f64 / 1.8).sqrt()).abs() < 1e-9);
    let err = Pinhole::new("camera", 320, 240, k(150.0, 159.5, 119.5), d).unwrap_err();
    assert!(
        err.to_string()
            .starts_with("camera: distortion is not invertible"),
        "{err}"
    );
    // The radial map peaks at r_d = 0.497 (at r = 0.745): a distorted point beyond has no
    // preimage, and one below has two; undistortion returns the one on the monotone branch.
    assert!(d.undistort(Vector2::new(0.55, 0.0)).is_err());
    let q = d.distort(Vector2::new(0.9, 0.0));
    let p = d.undistort(q).unwrap();
    assert!(p.norm() < d.max_radius() && (d.distort(p) - q).norm() < 1e-12);
}

#[test]
fn bad_parameters_name_the_field() {
    let err = Pinhole::new(
        "projector",
        768,
        1024,
        k(-5.0, 383.5, 511.5),
        BrownConrady::NONE,
    )
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "projector.fx_px = -5: must be a finite number above 0"
    );
    let err = MeasurementVolume::new(500.0, 400.0).unwrap_err();
    assert!(err.to_string().starts_with("volume.far_mm = 400"), "{err}");
    let mut r = nalgebra::Matrix3::identity();
    r[(0, 0)] = -1.0;
    let err = Pose::new(r, Vector3::zeros()).unwrap_err();
    assert!(err.to_string().contains("determinant +1"), "{err}");
}

#[test]
fn closed_form_and_one_dimensional_solve_agree_without_distortion() {
    let cal = rig(BrownConrady::NONE, BrownConrady::NONE);
    let ray = cal.pixel_ray(Point2::new(100.0, 60.0)).unwrap();
    for depth in [360.0, 500.0, 690.0] {
        let c = ray.column_at_depth(depth).unwrap();
        let z = ray.depth_of_column_plane(c).unwrap();
        assert!((z - depth).abs() < 1e-9, "{z} vs {depth}");
    }
}

#[test]
fn column_range_spans_the_volume_and_is_monotone() {
    for cal in [rig(BrownConrady::NONE, BrownConrady::NONE), distorted()] {
        for (u, v) in [(0.0, 0.0), (319.0, 239.0), (160.0, 120.0), (5.0, 230.0)] {
            let ray = cal.pixel_ray(Point2::new(u, v)).unwrap();
            let range = ray.column_range().unwrap();
            let columns: Vec<f64> = (0..=64)
                .map(|i| {
                    ray.column_at_depth(350.0 + 350.0 * i as f64 / 64.0)
                        .unwrap()
                })
                .collect();
            // The projector sits at +x and looks back across the camera's axis: farther points
            // move to higher columns.
            for w in columns.windows(2) {
                assert!(w[1] > w[0], "not monotone at pixel ({u}, {v})");
            }
            assert!(columns.iter().all(|&c| range.widened(1e-9).contains(c)));
            assert!((range.first - columns[0]).abs() < 1e-9);
        }
    }
}

#[test]
fn a_column_outside_the_volume_is_refused_with_the_reachable_range() {
    let cal = distorted();
    let pixel = Point2::new(160.0, 120.0);
    let range = cal.column_range(pixel).unwrap();
    let err = cal.triangulate(pixel, range.last + 1.0).unwrap_err();
    match err {
        TriangulationError::NotInVolume { reachable, .. } => assert_eq!(reachable, range),
        e => panic!("{e}"),
    }
    assert!(err.to_string().contains("outside the columns"), "{err}");
    assert!(cal.triangulate(pixel, f64::NAN).is_err());
    // At the limits themselves the point is at the limit depths.
    let near = cal.triangulate(pixel, range.first).unwrap();
    let far = cal.triangulate(pixel, range.last).unwrap();
    assert!((near.z - 350.0).abs() < 1e-6 && (far.z - 700.0).abs() < 1e-6);
    let r = range.to_column_range();
    assert!(r.first <= r.last);
}

#[test]
fn file_round_trip_and_checks() {
    let cal = distorted();
    let text = cal.to_toml();
    assert!(text.contains("format = \"fsm-calibration\""));
    assert_eq!(Calibration::from_toml(&text, "x").unwrap(), cal);

    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("cal.toml");
    cal.write(&path).unwrap();
    assert_eq!(Calibration::read(&path).unwrap(), cal);
    // No temporary file is left behind.
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);

    // A changed number is caught by the checksum, and the message names the file.
    let edited = text.replacen("far_mm = 700.0", "far_mm = 701.0", 1);
    assert_ne!(edited, text);
    let err = Calibration::from_toml(&edited, "cal.toml").unwrap_err();
    assert!(matches!(
        err.kind,
        CalibrationFileErrorKind::Checksum { .. }
    ));
    assert!(
        err.to_string()
            .starts_with("calibration file cal.toml: checksum_crc32"),
        "{err}"
    );
    // Without the checksum the edit is accepted.
    let unguarded: String = edited
        .lines()
        .filter(|l| !l.starts_with("checksum_crc32"))
        .collect::<Vec<_>>()
        .join("\n");
    assert_eq!(
        Calibration::from_toml(&unguarded, "x")
            .unwrap()
            .volume
            .far_mm(),
        701.0
    );

    // Invalid values name the field.
    let bad = unguarded.replacen("near_mm = 350.0", "near_mm = -1.0", 1);
    let err = Calibration::from_toml(&bad, "cal.toml").unwrap_err();
    assert!(err.to_string().contains("volume.near_mm = -1"), "{err}");
    // Unknown keys (typos) and missing keys are syntax errors that name the key.
    let typo = unguarded.replacen("fx_px", "fxpx", 1);
    let err = Calibration::from_toml(&typo, "cal.toml").unwrap_err();
    assert!(err.to_string().contains("fxpx"), "{err}");
    // Another version or another kind of file.
    let v2 = text.replacen("version = 1", "version = 2", 1);
    let err = Calibration::from_toml(&v2, "cal.toml").unwrap_err();
    assert!(
        matches!(err.kind, CalibrationFileErrorKind::Version(Some(2))),
        "{err}"
    );
    let err = Calibration::from_toml("a = 1", "cal.toml").unwrap_err();
    assert!(
        matches!(err.kind, CalibrationFileErrorKind::Format(None)),
        "{err}"
    );
    let err = Calibration::read(&dir.path().join("missing.toml")).unwrap_err();
    assert!(err.to_string().contains("missing.toml"), "{err}");
}

#[test]
fn every_pixel_and_depth_of_the_bench_rig_triangulates_back() {
    for cal in [rig(BrownConrady::NONE, BrownConrady::NONE), distorted()] {
        let mut worst: f64 = 0.0;
        let mut count = 0;
        for u in (0..320).step_by(29) {
            for v in (0..240).step_by(23) {
                let ray = cal.pixel_ray(Point2::new(u as f64, v as f64)).unwrap();
                for depth in [350.0, 420.0, 500.0, 611.0, 700.0] {
                    let point = ray.point_at_depth(depth);
                    let column = cal.projector_column_of(&point).unwrap();
                    let pixel = cal.camera_pixel_of(&point).unwrap();
                    let back = cal.triangulate(pixel, column).unwrap();
                    worst = worst.max((back - point).norm());
                    count += 1;
                }
            }
        }
        assert_eq!(count, 12 * 11 * 5);
        assert!(worst < 1e-7, "worst {worst} mm");
    }
}
