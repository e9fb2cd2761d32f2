//! OpenCV FileStorage calibrations of SLStudio, scan3d-capture and procam-calibration: each
//! format round-trips to the same geometry (same 3D point for the same pixel and column within
//! 1e-6 mm), each tool's pose convention is checked against a hand-computed projection, the
//! example files in `calibration/examples/` import to the bench calibration of
//! `calibration/bench.toml`, bad files fail with the file and the key in the message, and no
//! input makes the reader panic.

use std::path::{Path, PathBuf};

use fsm_geometry::opencv::{
    self, Document, ImportOptions, LengthUnit, Node, OpenCvErrorKind, Syntax, Tool,
};
use fsm_geometry::{BrownConrady, Calibration, Intrinsics, MeasurementVolume, Pinhole, Pose};
use nalgebra::{Matrix3, Point2, Point3, Rotation3, Vector3};
use proptest::prelude::*;

const TOLERANCE_MM: f64 = 1e-6;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A distorted pair, off-axis pose (not the bench: the fixtures test that one).
fn calibration() -> Calibration {
    let camera = Pinhole::new(
        "camera",
        640,
        480,
        Intrinsics {
            fx_px: 1210.25,
            fy_px: 1208.5,
            cx_px: 322.125,
            cy_px: 236.75,
        },
        BrownConrady {
            k1: -0.081,
            k2: 0.034,
            p1: 4e-4,
            p2: -2.5e-4,
            k3: -0.002,
        },
    )
    .unwrap();
    let projector = Pinhole::new(
        "projector",
        912,
        1140,
        Intrinsics {
            fx_px: 1650.0,
            fy_px: 1648.0,
            cx_px: 455.5,
            cy_px: 1102.0,
        },
        BrownConrady {
            k1: 0.025,
            k2: -0.008,
            p1: 1e-4,
            p2: 0.0,
            k3: 0.0,
        },
    )
    .unwrap();
    let pose = Pose::looking_at(
        Point3::new(-180.0, 35.0, 12.0),
        Point3::new(10.0, -5.0, 450.0),
        Vector3::new(0.05, 1.0, 0.02),
    )
    .unwrap();
    Calibration {
        camera,
        projector,
        pose,
        volume: MeasurementVolume::new(300.0, 650.0).unwrap(),
    }
}

fn options_for(c: &Calibration, unit: LengthUnit) -> ImportOptions {
    ImportOptions {
        camera_size: Some((c.camera.width_px(), c.camera.height_px())),
        projector_size: Some((c.projector.width_px(), c.projector.height_px())),
        near_mm: Some(c.volume.near_mm()),
        far_mm: Some(c.volume.far_mm()),
        unit,
    }
}

/// Candidates `(pixel, column)` of points spread over the volume, as `original` sees them.
fn candidates(original: &Calibration) -> Vec<(Point2<f64>, f64)> {
    let mut out = Vec::new();
    let (near, far) = (original.volume.near_mm(), original.volume.far_mm());
    for i in 0..5 {
        for j in 0..5 {
            for k in 0..3 {
                let z = near + (far - near) * (0.1 + 0.4 * k as f64);
                let u = original.camera.width_px() as f64 * (0.15 + 0.175 * i as f64);
                let v = original.camera.height_px() as f64 * (0.15 + 0.175 * j as f64);
                let ray = original.pixel_ray(Point2::new(u, v)).unwrap();
                let point = ray.point_at_depth(z);
                let Some(column) = original.projector_column_of(&point) else {
                    continue;
                };
                if column < 0.0 || column > original.projector.width_px() as f64 - 1.0 {
                    continue;
                }
                out.push((Point2::new(u, v), column));
            }
        }
    }
    assert!(out.len() > 20, "too few candidates: {}", out.len());
    out
}

/// Every candidate triangulates to the same point (within 1e-6 mm) with both calibrations.
fn assert_same_geometry(original: &Calibration, other: &Calibration, what: &str) {
    for (pixel, column) in candidates(original) {
        let a = original.triangulate(pixel, column).unwrap();
        let b = other
            .triangulate(pixel, column)
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        assert!(
            (a - b).norm() < TOLERANCE_MM,
            "{what}: pixel {pixel:?} column {column}: {a:?} vs {b:?} ({} mm apart)",
            (a - b).norm()
        );
    }
}

#[test]
fn every_format_round_trips_to_the_same_geometry() {
    let original = calibration();
    for tool in Tool::ALL {
        for syntax in [Syntax::Yaml, Syntax::Xml] {
            for unit in [LengthUnit::Mm, LengthUnit::Cm, LengthUnit::M] {
                let what = format!("{tool} {syntax:?} {unit:?}");
                let text = opencv::to_text(&original, tool, syntax, unit);
                assert_eq!(Syntax::of_text(&text), Some(syntax), "{what}");
                let imported =
                    opencv::from_text(&text, "memory", tool, &options_for(&original, unit))
                        .unwrap_or_else(|e| panic!("{what}: {e}\n{text}"));
                let back = imported.calibration;
                assert_same_geometry(&original, &back, &what);
                // Millimetres are exact: the numbers are written with 17 digits.
                if unit == LengthUnit::Mm {
                    assert_eq!(back, original, "{what}");
                }
                // And the same file comes out again.
                if unit == LengthUnit::Mm {
                    assert_eq!(opencv::to_text(&back, tool, syntax, unit), text, "{what}");
                }
            }
        }
    }
}

#[test]
fn the_written_files_carry_the_tools_own_keys_and_shapes() {
    let c = calibration();
    let shape = |doc: &Document, key: &str| doc.matrix(key).unwrap().unwrap().shape();
    for syntax in [Syntax::Yaml, Syntax::Xml] {
        let doc =
            Document::parse(&opencv::to_text(&c, Tool::SlStudio, syntax, LengthUnit::Mm)).unwrap();
        // SLStudio's loader converts into Matx33f / Vec<float, 5> / Vec3f: exactly these.
        for (key, s) in [
            ("Kc", "3x3"),
            ("kc", "5x1"),
            ("Kp", "3x3"),
            ("kp", "5x1"),
            ("Rp", "3x3"),
            ("Tp", "3x1"),
        ] {
            assert_eq!(shape(&doc, key), s, "SLStudio {key}");
        }
        for (key, v) in [
            ("frameWidth", 640.0),
            ("frameHeight", 480.0),
            ("screenResX", 912.0),
            ("screenResY", 1140.0),
        ] {
            assert_eq!(doc.get(key).and_then(Node::number), Some(v), "{key}");
        }

        let doc = Document::parse(&opencv::to_text(
            &c,
            Tool::Scan3dCapture,
            syntax,
            LengthUnit::Mm,
        ))
        .unwrap();
        for (key, s) in [
            ("cam_K", "3x3"),
            ("cam_kc", "1x5"),
            ("proj_K", "3x3"),
            ("proj_kc", "1x5"),
            ("R", "3x3"),
            ("T", "3x1"),
            ("E", "3x3"),
            ("F", "3x3"),
        ] {
            assert_eq!(shape(&doc, key), s, "scan3d-capture {key}");
        }
        // E and F are what scan3d-capture's loader requires; check them as epipolar
        // constraints: x_p^T E x_c = 0 for normalised points, q_p^T F q_c = 0 for pixels.
        let m = |key: &str| {
            let m = doc.matrix(key).unwrap().unwrap();
            Matrix3::from_fn(|i, j| m.at(i, j))
        };
        let (e, f) = (m("E"), m("F"));
        let point = Point3::new(20.0, -15.0, 480.0);
        let xc = point.coords / point.z;
        let pp = c.pose.to_projector(&point);
        let xp = pp.coords / pp.z;
        let residual = (xp.transpose() * e * xc)[0];
        assert!(residual.abs() < 1e-9 * e.norm(), "E: {residual}");
        let k = |p: &Pinhole| {
            let k = p.intrinsics();
            Matrix3::new(k.fx_px, 0.0, k.cx_px, 0.0, k.fy_px, k.cy_px, 0.0, 0.0, 1.0)
        };
        let qc = k(&c.camera) * xc;
        let qp = k(&c.projector) * xp;
        let residual = (qp.transpose() * f * qc)[0];
        assert!(
            residual.abs() < 1e-9 * f.norm() * qc.norm() * qp.norm(),
            "F: {residual}"
        );

        let doc =
            Document::parse(&opencv::to_text(&c, Tool::Procam, syntax, LengthUnit::Mm)).unwrap();
        for (key, s) in [
            ("cam_int", "3x3"),
            ("cam_dist", "1x5"),
            ("proj_int", "3x3"),
            ("proj_dist", "1x5"),
            ("roration", "3x3"),
            ("translation", "3x1"),
            ("img_shape", "2x1"),
        ] {
            assert_eq!(shape(&doc, key), s, "procam {key}");
        }
        assert_eq!(
            doc.matrix("img_shape").unwrap().unwrap().data,
            vec![480.0, 640.0],
            "img_shape is (height, width)"
        );
    }
}

/// `R` rotating about an oblique axis (not symmetric, so a transposed read shows), `T` mm.
fn hand_pose() -> (Matrix3<f64>, Vector3<f64>) {
    let r = Rotation3::from_axis_angle(
        &nalgebra::Unit::new_normalize(Vector3::new(0.2, -1.0, 0.1)),
        0.35,
    );
    (*r.matrix(), Vector3::new(-195.5, 12.25, 40.0))
}

fn numbers(values: &[f64], sep: &str) -> String {
    values
        .iter()
        .map(|v| format!("{v:e}"))
        .collect::<Vec<_>>()
        .join(sep)
}

fn row_major(m: &Matrix3<f64>) -> Vec<f64> {
    (0..3)
        .flat_map(|i| (0..3).map(move |j| m[(i, j)]))
        .collect()
}

/// A file in the layout each tool writes, typed out here rather than by our writer: SLStudio
/// XML with float matrices and 5×1 vectors; scan3d-capture YAML (OpenCV 2.4 header, no `---`)
/// with 1×5 rows; procam XML with `img_shape`, `rms` and a 4-coefficient projector vector.
fn hand_written(tool: Tool, r: &Matrix3<f64>, t: &Vector3<f64>) -> String {
    let kc = [800.0, 0.0, 319.5, 0.0, 805.0, 239.5, 0.0, 0.0, 1.0];
    let kp = [1500.0, 0.0, 511.5, 0.0, 1500.0, 383.5, 0.0, 0.0, 1.0];
    let r = row_major(r);
    let t = [t.x, t.y, t.z];
    let xml_matrix = |key: &str, rows: usize, cols: usize, dt: &str, data: &[f64]| {
        format!(
            "<{key} type_id=\"opencv-matrix\">\n  <rows>{rows}</rows>\n  <cols>{cols}</cols>\n  <dt>{dt}</dt>\n  <data>\n    {}</data></{key}>\n",
            numbers(data, " ")
        )
    };
    match tool {
        Tool::SlStudio => {
            let mut s = String::from("<?xml version=\"1.0\"?>\n<opencv_storage>\n");
            s += &xml_matrix("Kc", 3, 3, "f", &kc);
            s += &xml_matrix("kc", 5, 1, "f", &[0.0; 5]);
            s += &xml_matrix("Kp", 3, 3, "f", &kp);
            s += &xml_matrix("kp", 5, 1, "f", &[0.0; 5]);
            s += &xml_matrix("Rp", 3, 3, "f", &r);
            s += &xml_matrix("Tp", 3, 1, "f", &t);
            s += "<cam_error>1.2e-01</cam_error>\n<proj_error>2.0e-01</proj_error>\n<stereo_error>1.5e-01</stereo_error>\n";
            s += "<frameWidth>640</frameWidth>\n<frameHeight>480</frameHeight>\n<screenResX>1024</screenResX>\n<screenResY>768</screenResY>\n";
            s + "</opencv_storage>\n"
        }
        Tool::Scan3dCapture => {
            let yml = |key: &str, rows: usize, cols: usize, data: &[f64]| {
                format!(
                    "{key}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n",
                    numbers(data, ",\n       ")
                )
            };
            let mut s = String::from("%YAML:1.0\n");
            s += &yml("cam_K", 3, 3, &kc);
            s += &yml("cam_kc", 1, 5, &[0.0; 5]);
            s += &yml("proj_K", 3, 3, &kp);
            s += &yml("proj_kc", 1, 5, &[0.0; 5]);
            s += &yml("R", 3, 3, &r);
            s += &yml("T", 3, 1, &t);
            s += "cam_error: 1.8e-01\nproj_error: 2.5e-01\nstereo_error: 3.0e-01\n";
            s
        }
        Tool::Procam => {
            let mut s = String::from("<?xml version=\"1.0\"?>\n<opencv_storage>\n");
            s += &xml_matrix("img_shape", 2, 1, "d", &[480.0, 640.0]);
            s += "<rms>4.2e-01</rms>\n";
            s += &xml_matrix("cam_int", 3, 3, "d", &kc);
            s += &xml_matrix("cam_dist", 1, 5, "d", &[0.0; 5]);
            s += &xml_matrix("proj_int", 3, 3, "d", &kp);
            s += &xml_matrix("proj_dist", 1, 4, "d", &[0.0; 4]);
            s += &xml_matrix("roration", 3, 3, "d", &r);
            s += &xml_matrix("translation", 3, 1, "d", &t);
            s + "</opencv_storage>\n"
        }
    }
}

#[test]
fn each_tools_pose_maps_camera_to_projector() {
    let (r, t) = hand_pose();
    for tool in Tool::ALL {
        let text = hand_written(tool, &r, &t);
        let options = ImportOptions {
            projector_size: Some((1024, 768)),
            camera_size: (tool == Tool::Scan3dCapture).then_some((640, 480)),
            near_mm: Some(250.0),
            far_mm: Some(900.0),
            unit: LengthUnit::Mm,
        };
        let cal = opencv::from_text(&text, "hand.txt", tool, &options)
            .unwrap_or_else(|e| panic!("{tool}: {e}"))
            .calibration;
        assert_eq!((cal.camera.width_px(), cal.camera.height_px()), (640, 480));
        // The projection by hand: X_p = R·X_c + T, then the projector's pinhole.
        for point in [
            Point3::new(0.0, 0.0, 500.0),
            Point3::new(-40.0, 25.0, 420.0),
            Point3::new(55.0, -30.0, 610.0),
        ] {
            let p = r * point.coords + t;
            let column = 1500.0 * p.x / p.z + 511.5;
            let got = cal.projector_column_of(&point).unwrap();
            // SLStudio's float matrices carry about 7 digits.
            let tol = if tool == Tool::SlStudio { 2e-3 } else { 1e-9 };
            assert!(
                (got - column).abs() < tol,
                "{tool}: column {got} vs {column}"
            );
            let pixel = Point2::new(
                800.0 * point.x / point.z + 319.5,
                805.0 * point.y / point.z + 239.5,
            );
            let back = cal.triangulate(pixel, column).unwrap();
            let tol_mm = if tool == Tool::SlStudio { 0.05 } else { 1e-6 };
            assert!(
                (back - point).norm() < tol_mm,
                "{tool}: {back:?} vs {point:?}"
            );
        }
    }
}

#[test]
fn translation_units_scale_to_millimetres() {
    let (r, t) = hand_pose();
    let text_mm = hand_written(Tool::Procam, &r, &t);
    let text_m = hand_written(Tool::Procam, &r, &(t / 1000.0));
    let options = |unit| ImportOptions {
        projector_size: Some((1024, 768)),
        near_mm: Some(250.0),
        far_mm: Some(900.0),
        unit,
        ..ImportOptions::default()
    };
    let a = opencv::from_text(&text_mm, "mm", Tool::Procam, &options(LengthUnit::Mm))
        .unwrap()
        .calibration;
    let b = opencv::from_text(&text_m, "m", Tool::Procam, &options(LengthUnit::M))
        .unwrap()
        .calibration;
    for point in [
        Point3::new(0.0, 0.0, 500.0),
        Point3::new(-40.0, 25.0, 420.0),
        Point3::new(55.0, -30.0, 610.0),
    ] {
        let pixel = a.camera_pixel_of(&point).unwrap();
        let column = a.projector_column_of(&point).unwrap();
        let from_a = a.triangulate(pixel, column).unwrap();
        let from_b = b.triangulate(pixel, column).unwrap();
        assert!((from_a - point).norm() < TOLERANCE_MM);
        assert!(
            (from_b - point).norm() < TOLERANCE_MM,
            "{from_b:?} vs {point:?}"
        );
    }
    assert!((b.pose.translation_mm() - t).norm() < 1e-9);
}

fn fixture_options(bench: &Calibration, tool: Tool) -> ImportOptions {
    // Only what each tool's file lacks: SLStudio has all sizes, procam the camera's.
    ImportOptions {
        camera_size: (tool == Tool::Scan3dCapture)
            .then_some((bench.camera.width_px(), bench.camera.height_px())),
        projector_size: (tool != Tool::SlStudio)
            .then_some((bench.projector.width_px(), bench.projector.height_px())),
        near_mm: Some(bench.volume.near_mm()),
        far_mm: Some(bench.volume.far_mm()),
        unit: LengthUnit::Mm,
    }
}

fn fixture(tool: Tool) -> PathBuf {
    let name = match tool {
        Tool::SlStudio => "slstudio.xml",
        Tool::Scan3dCapture => "scan3d-capture.yml",
        Tool::Procam => "procam.xml",
    };
    repo().join("calibration/examples").join(name)
}

#[test]
fn the_example_files_are_the_bench_calibration() {
    let bench = Calibration::read(&repo().join("calibration/bench.toml")).unwrap();
    for tool in Tool::ALL {
        let path = fixture(tool);
        let imported = opencv::read(&path, tool, &fixture_options(&bench, tool))
            .unwrap_or_else(|e| panic!("{e}"));
        assert_same_geometry(&bench, &imported.calibration, &path.display().to_string());
        assert_eq!(imported.calibration, bench, "{}", path.display());
        // Round trip of the fixture: export what was imported, read it again.
        let syntax = Syntax::of_path(&path).unwrap();
        assert_eq!(syntax, tool.native_syntax());
        let again = opencv::to_text(&imported.calibration, tool, syntax, LengthUnit::Mm);
        let back = opencv::from_text(&again, "again", tool, &fixture_options(&bench, tool))
            .unwrap()
            .calibration;
        assert_same_geometry(&bench, &back, "fixture exported again");
        // The file is what the exporter writes today (it cannot go stale).
        assert_eq!(
            std::fs::read_to_string(&path).unwrap(),
            again,
            "{} differs from the export of calibration/bench.toml: regenerate it (calibration/README.md)",
            path.display()
        );
    }
}

#[test]
fn sizes_come_from_the_file_when_it_has_them() {
    let (r, t) = hand_pose();
    let base = ImportOptions {
        near_mm: Some(250.0),
        far_mm: Some(900.0),
        ..ImportOptions::default()
    };
    // SLStudio: frameWidth/frameHeight and screenResX/screenResY.
    let sl = opencv::from_text(
        &hand_written(Tool::SlStudio, &r, &t),
        "sl.xml",
        Tool::SlStudio,
        &base,
    )
    .unwrap();
    assert_eq!(sl.calibration.projector.width_px(), 1024);
    assert_eq!(sl.calibration.projector.height_px(), 768);
    assert!(
        sl.notes.iter().any(|n| n.contains("screenResX")),
        "{:?}",
        sl.notes
    );
    // An option that disagrees with the file wins, with a warning.
    let over = ImportOptions {
        projector_size: Some((912, 1140)),
        ..base
    };
    let sl = opencv::from_text(
        &hand_written(Tool::SlStudio, &r, &t),
        "sl.xml",
        Tool::SlStudio,
        &over,
    )
    .unwrap();
    assert_eq!(sl.calibration.projector.width_px(), 912);
    assert!(sl
        .notes
        .iter()
        .any(|n| n.starts_with("warning") && n.contains("1024x768")));
    // SLStudio's "unknown" 0 (and uninitialised garbage) is not a size.
    let zero = hand_written(Tool::SlStudio, &r, &t)
        .replace(
            "<screenResX>1024</screenResX>",
            "<screenResX>0</screenResX>",
        )
        .replace(
            "<screenResY>768</screenResY>",
            "<screenResY>-858993460</screenResY>",
        );
    let err = opencv::from_text(&zero, "sl0.xml", Tool::SlStudio, &base).unwrap_err();
    assert!(err.to_string().contains("--projector-size"), "{err}");
    // procam: img_shape is (height, width) of the camera; the projector is not in the file.
    let pc = opencv::from_text(
        &hand_written(Tool::Procam, &r, &t),
        "pc.xml",
        Tool::Procam,
        &base,
    )
    .unwrap_err();
    assert!(pc.to_string().contains("pc.xml"));
    assert!(pc.to_string().contains("--projector-size"), "{pc}");
}

/// Deletes the top-level entry `key` from a file written by our writer.
fn without(text: &str, key: &str, syntax: Syntax) -> String {
    let mut out = String::new();
    let mut skipping = false;
    for line in text.lines() {
        let starts = match syntax {
            Syntax::Yaml => line.starts_with(&format!("{key}:")),
            Syntax::Xml => {
                line.starts_with(&format!("<{key}>")) || line.starts_with(&format!("<{key} "))
            }
        };
        if starts {
            skipping = true;
        } else if skipping {
            let top = match syntax {
                Syntax::Yaml => !line.starts_with(' '),
                Syntax::Xml => line.starts_with('<') && !line.starts_with("  "),
            };
            if top {
                skipping = false;
            }
        }
        let ends_here = syntax == Syntax::Xml && skipping && line.ends_with(&format!("</{key}>"));
        if !skipping {
            out.push_str(line);
            out.push('\n');
        }
        if ends_here {
            skipping = false;
        }
    }
    out
}

#[test]
fn a_missing_key_is_named_with_the_file() {
    let c = calibration();
    for tool in Tool::ALL {
        let k = tool.keys();
        for syntax in [Syntax::Yaml, Syntax::Xml] {
            let text = opencv::to_text(&c, tool, syntax, LengthUnit::Mm);
            for key in [
                k.camera_matrix,
                k.camera_distortion,
                k.projector_matrix,
                k.projector_distortion,
                k.rotation,
                k.translation,
            ] {
                let cut = without(&text, key, syntax);
                assert!(cut.len() < text.len(), "{key} not removed");
                let err =
                    opencv::from_text(&cut, "their.file", tool, &options_for(&c, LengthUnit::Mm))
                        .unwrap_err();
                assert!(
                    matches!(err.kind, OpenCvErrorKind::MissingKey { key: k2, .. } if k2 == key),
                    "{tool} {syntax:?} {key}: {err}"
                );
                let msg = err.to_string();
                assert!(msg.starts_with("their.file: "), "{msg}");
                assert!(msg.contains(&format!("`{key}` is missing")), "{msg}");
            }
        }
    }
    // A file of another tool: the message lists what the file has.
    let text = opencv::to_text(&c, Tool::Scan3dCapture, Syntax::Yaml, LengthUnit::Mm);
    let err = opencv::from_text(
        &text,
        "calib.yml",
        Tool::SlStudio,
        &options_for(&c, LengthUnit::Mm),
    )
    .unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("`Kc` is missing") && msg.contains("`cam_K`"),
        "{msg}"
    );
}

/// Replaces the matrix at `key` (YAML syntax) with one of another shape.
fn with_matrix(text: &str, key: &str, rows: usize, cols: usize, data: &[f64]) -> String {
    let cut = without(text, key, Syntax::Yaml);
    format!(
        "{cut}{key}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n",
        numbers(data, ", ")
    )
}

fn import_error(text: &str, tool: Tool) -> String {
    let c = calibration();
    opencv::from_text(text, "their.yml", tool, &options_for(&c, LengthUnit::Mm))
        .map(|_| ())
        .unwrap_err()
        .to_string()
}

#[test]
fn wrong_shapes_and_values_are_named() {
    let c = calibration();
    let text = opencv::to_text(&c, Tool::Scan3dCapture, Syntax::Yaml, LengthUnit::Mm);
    let check = |modified: String, needles: &[&str]| {
        let msg = import_error(&modified, Tool::Scan3dCapture);
        assert!(msg.starts_with("their.yml: "), "{msg}");
        for n in needles {
            assert!(msg.contains(n), "`{n}` not in: {msg}");
        }
    };
    check(
        with_matrix(&text, "cam_K", 3, 1, &[1.0, 2.0, 3.0]),
        &["`cam_K`", "3x3", "3x1"],
    );
    check(
        with_matrix(
            &text,
            "cam_kc",
            1,
            8,
            &[0.1, 0.0, 0.0, 0.0, 0.0, 0.02, 0.0, 0.0],
        ),
        &["`cam_kc`", "1x8", "k4 = 0.02"],
    );
    check(
        with_matrix(&text, "proj_kc", 1, 3, &[0.1, 0.0, 0.0]),
        &["`proj_kc`", "1x3", "4 or 5"],
    );
    check(
        with_matrix(&text, "proj_kc", 2, 3, &[0.0; 6]),
        &["`proj_kc`", "2x3"],
    );
    check(
        with_matrix(&text, "T", 2, 1, &[1.0, 2.0]),
        &["`T`", "2x1", "3 entries"],
    );
    check(
        with_matrix(
            &text,
            "R",
            3,
            3,
            &[1.0, 0.1, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        ),
        &["`R`", "orthonormal"],
    );
    check(
        with_matrix(
            &text,
            "R",
            3,
            3,
            &[-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        ),
        &["`R`", "determinant"],
    );
    check(
        with_matrix(
            &text,
            "cam_K",
            3,
            3,
            &[800.0, 1.5, 320.0, 0.0, 800.0, 240.0, 0.0, 0.0, 1.0],
        ),
        &["`cam_K`", "skew"],
    );
    check(
        with_matrix(
            &text,
            "proj_K",
            3,
            3,
            &[-800.0, 0.0, 320.0, 0.0, 800.0, 240.0, 0.0, 0.0, 1.0],
        ),
        &["`proj_K`", "fx_px"],
    );
    check(
        text.replace(
            "cam_K: !!opencv-matrix\n   rows: 3",
            "cam_K: !!opencv-matrix\n   rows: 4",
        ),
        &["`cam_K`", "4x3", "9 values"],
    );
    check(
        text.replace(
            "proj_kc: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d",
            "proj_kc: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: 3d",
        ),
        &["`proj_kc`", "single-channel"],
    );
    check(
        without(&text, "T", Syntax::Yaml) + "T: 12.5\n",
        &["`T`", "opencv-matrix", "12.5"],
    );
    // Strongly folding distortion: the model's invertibility check, with the keys.
    check(
        with_matrix(&text, "cam_kc", 1, 5, &[-3.0, 0.0, 0.0, 0.0, 0.0]),
        &["`cam_K`, `cam_kc`", "camera"],
    );
    // 4 coefficients and 8 with zero rational terms are accepted, as 5×1 or 1×5.
    for (rows, cols, data) in [
        (1, 4, vec![-0.08, 0.03, 4e-4, -2.5e-4]),
        (4, 1, vec![-0.08, 0.03, 4e-4, -2.5e-4]),
        (8, 1, vec![-0.08, 0.03, 4e-4, -2.5e-4, 0.0, 0.0, 0.0, 0.0]),
    ] {
        let t = with_matrix(&text, "cam_kc", rows, cols, &data);
        let cal = opencv::from_text(
            &t,
            "x",
            Tool::Scan3dCapture,
            &options_for(&c, LengthUnit::Mm),
        )
        .unwrap()
        .calibration;
        assert_eq!(cal.camera.distortion().to_opencv()[..4], data[..4]);
        assert_eq!(cal.camera.distortion().k3, 0.0);
    }
}

#[test]
fn missing_options_say_what_to_give() {
    let c = calibration();
    let text = opencv::to_text(&c, Tool::Scan3dCapture, Syntax::Yaml, LengthUnit::Mm);
    let full = options_for(&c, LengthUnit::Mm);
    let msg = |o: ImportOptions| {
        opencv::from_text(&text, "cal.yml", Tool::Scan3dCapture, &o)
            .unwrap_err()
            .to_string()
    };
    let m = msg(ImportOptions {
        camera_size: None,
        ..full
    });
    assert!(m.contains("cal.yml") && m.contains("--camera-size"), "{m}");
    let m = msg(ImportOptions {
        projector_size: None,
        ..full
    });
    assert!(m.contains("--projector-size"), "{m}");
    let m = msg(ImportOptions {
        far_mm: None,
        ..full
    });
    assert!(m.contains("--near-mm") && m.contains("--far-mm"), "{m}");
    let m = msg(ImportOptions {
        near_mm: Some(700.0),
        far_mm: Some(300.0),
        ..full
    });
    assert!(m.contains("far_mm"), "{m}");
}

#[test]
fn the_reader_takes_what_opencv_writes() {
    // Block and flow collections, comments, quoted strings, nested maps, a sequence of maps,
    // OpenCV's `.Nan`, integer-valued doubles written as `640.`.
    let yaml = "%YAML:1.0\n---\n# a comment\nname: \"a string # not a comment\"\nsize: 640. # comment\n\
        nested:\n   a: 1\n   b: [ 1, 2,\n       3 ]\n   c: { x: 1, y: \"two\" }\n\
        list:\n   - 1\n   - { k: v }\n   - k: 1\n     l: 2\n   -\n      m: 3\n\
        nan: .Nan\nm: !!opencv-matrix\n   rows: 1\n   cols: 2\n   dt: f\n   data: [ -1.5e+00, 2. ]\n";
    let doc = Document::parse(yaml).unwrap();
    assert_eq!(doc.syntax, Syntax::Yaml);
    assert_eq!(doc.keys(), ["name", "size", "nested", "list", "nan", "m"]);
    assert_eq!(
        doc.get("name"),
        Some(&Node::Scalar {
            text: "a string # not a comment".into(),
            quoted: true
        })
    );
    assert_eq!(doc.get("size").and_then(Node::number), Some(640.0));
    assert!(doc.get("nan").and_then(Node::number).unwrap().is_nan());
    let nested = doc.get("nested").unwrap();
    assert_eq!(
        nested.get("b"),
        Some(&Node::Seq(vec![
            Node::Scalar {
                text: "1".into(),
                quoted: false
            },
            Node::Scalar {
                text: "2".into(),
                quoted: false
            },
            Node::Scalar {
                text: "3".into(),
                quoted: false
            },
        ]))
    );
    assert_eq!(
        nested
            .get("c")
            .and_then(|c| c.get("x"))
            .and_then(Node::number),
        Some(1.0)
    );
    let Some(Node::Seq(list)) = doc.get("list") else {
        panic!("list")
    };
    assert_eq!(list.len(), 4);
    assert_eq!(list[2].get("l").and_then(Node::number), Some(2.0));
    assert_eq!(list[3].get("m").and_then(Node::number), Some(3.0));
    let m = doc.matrix("m").unwrap().unwrap();
    assert_eq!(
        (m.rows, m.cols, m.dt, m.data.clone()),
        (1, 2, 'f', vec![-1.5, 2.0])
    );

    let xml = "<?xml version=\"1.0\"?>\n<!-- written by hand -->\n<opencv_storage>\n\
        <name>\"two words\"</name>\n<amp>a&amp;b</amp>\n<seq>\n  1 2 3</seq>\n\
        <map>\n  <a>1</a>\n  <b>2.5e+00</b></map>\n<items>\n  <_>1</_>\n  <_>2</_></items>\n\
        <m type_id=\"opencv-matrix\">\n  <rows>1</rows>\n  <cols>1</cols>\n  <dt>d</dt>\n  <data>\n    7.</data></m>\n\
        </opencv_storage>\n";
    let doc = Document::parse(xml).unwrap();
    assert_eq!(doc.keys(), ["name", "amp", "seq", "map", "items", "m"]);
    assert_eq!(
        doc.get("name"),
        Some(&Node::Scalar {
            text: "two words".into(),
            quoted: true
        })
    );
    assert_eq!(
        doc.get("amp"),
        Some(&Node::Scalar {
            text: "a&b".into(),
            quoted: false
        })
    );
    assert!(matches!(doc.get("seq"), Some(Node::Seq(v)) if v.len() == 3));
    assert_eq!(
        doc.get("map")
            .and_then(|m| m.get("b"))
            .and_then(Node::number),
        Some(2.5)
    );
    assert!(matches!(doc.get("items"), Some(Node::Seq(v)) if v.len() == 2));
    assert_eq!(doc.matrix("m").unwrap().unwrap().data, vec![7.0]);
}

#[test]
fn syntax_errors_have_lines() {
    let cases: [(&str, usize, &str); 7] = [
        ("", 1, "FileStorage"),
        ("{\"json\": 1}", 1, "FileStorage"),
        ("%YAML:1.0\nKc: [ 1, 2\nkc: 3\n", 2, "never closed"),
        ("%YAML:1.0\na: 1\n  b: 2\n", 3, "indentation"),
        ("%YAML:1.0\na: 1\na: 2\n", 3, "twice"),
        (
            "<?xml version=\"1.0\"?>\n<opencv_storage>\n<a>1</b>\n</opencv_storage>\n",
            3,
            "closes",
        ),
        (
            "<?xml version=\"1.0\"?>\n<root>\n</root>\n",
            1,
            "opencv_storage",
        ),
    ];
    for (text, line, needle) in cases {
        let e = Document::parse(text).unwrap_err();
        assert_eq!(e.line, line, "{text:?}: {e}");
        assert!(e.message.contains(needle), "{text:?}: {e}");
    }
    let e = opencv::from_text(
        "%YAML:1.0\na: [\n",
        "bad.yml",
        Tool::Procam,
        &ImportOptions::default(),
    )
    .unwrap_err();
    assert!(e.to_string().starts_with("bad.yml: line 2: "), "{e}");
}

/// `body` inside `<opencv_storage>`, after the `<?xml …?>` line: it starts on line 3.
fn xml_with(body: &str) -> String {
    format!("<?xml version=\"1.0\"?>\n<opencv_storage>\n{body}\n</opencv_storage>\n")
}

#[test]
fn the_xml_reader_takes_cdata_references_and_prolog_markup() {
    let scalar = |text: &str, quoted| Node::Scalar {
        text: text.into(),
        quoted,
    };
    // CDATA is element text: tokenized like the rest, its markup and `&` not interpreted.
    let doc = Document::parse(&xml_with(
        "<a><![CDATA[1 \"x y\"]]> 2</a>\n<b><![CDATA[<c>&amp;]]></b>",
    ))
    .unwrap();
    assert_eq!(
        doc.get("a"),
        Some(&Node::Seq(vec![
            scalar("1", false),
            scalar("x y", true),
            scalar("2", false)
        ]))
    );
    assert_eq!(doc.get("b"), Some(&scalar("<c>&amp;", false)));
    // The five entities and character references, in text and in `type_id`.
    let doc = Document::parse(&xml_with(
        "<a>&lt;&gt;&amp;&apos;&#x41;&#66;</a>\n<q>&quot;two words&quot;</q>\n\
         <m type_id='opencv&#x2d;matrix'></m>",
    ))
    .unwrap();
    assert_eq!(doc.get("a"), Some(&scalar("<>&'AB", false)));
    assert_eq!(doc.get("q"), Some(&scalar("two words", true)));
    assert!(matches!(doc.get("m"), Some(Node::Map { tag: Some(t), .. }) if t == "opencv-matrix"));
    // A BOM, comments and processing instructions around the root, `</a >`.
    let text = "\u{feff}<!-- c --><?xml version=\"1.0\"?><?xml-stylesheet href='s'?>\n\
        <opencv_storage><a >1</a ></opencv_storage>\n<!-- end --><?pi?>\n";
    assert_eq!(Document::parse(text).unwrap().keys(), ["a"]);
}

#[test]
fn xml_refusals_name_the_line_and_the_element() {
    let cases: &[(String, usize, &[&str])] = &[
        // Tags: mismatched, unclosed, bad names.
        (
            xml_with("<a>\n<b>1</a>"),
            4,
            &["</a> closes <b> (opened on line 4)"],
        ),
        (
            "<?xml version=\"1.0\"?>\n<opencv_storage>\n<a>\n<b>1</b>".into(),
            3,
            &["<a> is never closed"],
        ),
        (
            "<?xml version=\"1.0\"?>\n<opencv_storage>\n<a b='1'".into(),
            3,
            &["without its closing `>`"],
        ),
        (xml_with("<>1</>"), 3, &["expected an element name"]),
        (
            xml_with("<a>1</ a>"),
            3,
            &["expected an element name after `</`"],
        ),
        // Attributes, the line of the attribute in a tag over several lines.
        (
            xml_with("<a\n\n b=x>1</a>"),
            5,
            &["<a>", "`b`", "without quotes"],
        ),
        (xml_with("<a b>1</a>"), 3, &["<a>", "`b` without a value"]),
        (
            xml_with("<a b=>1</a>"),
            3,
            &["<a>", "`b` without a value after `=`"],
        ),
        (
            xml_with("<a\n type_id='x'\n type_id='y'>1</a>"),
            5,
            &["`type_id` given twice"],
        ),
        (xml_with("<a b=\"x>1</a>"), 3, &["closing quote"]),
        // Found by fuzzing: Unicode white space (U+0085) inside an attribute's name.
        (
            xml_with("<a b\u{85}c>1</a>"),
            3,
            &["attribute `b\u{85}c` without a value"],
        ),
        // References.
        (
            xml_with("<a>\n1 & 2</a>"),
            4,
            &["`&` that does not start an entity"],
        ),
        (xml_with("<a>&nbsp;</a>"), 3, &["unknown entity `&nbsp;`"]),
        (
            xml_with("<a>&#0;</a>"),
            3,
            &["`&#0;`", "character reference"],
        ),
        (xml_with("<a b='&foo;'/>"), 3, &["unknown entity `&foo;`"]),
        // Markup OpenCV does not write.
        (
            "<?xml version=\"1.0\"?>\n<!DOCTYPE opencv_storage>\n<opencv_storage/>".into(),
            2,
            &["DOCTYPE"],
        ),
        (xml_with("<!DOCTYPE x>"), 3, &["DOCTYPE"]),
        (
            xml_with("<a>1<?pi?></a>"),
            3,
            &["processing instruction inside <a>"],
        ),
        (
            xml_with("<!ELEMENT a>"),
            3,
            &["unexpected markup after `<!`"],
        ),
        (xml_with("<a><![CDATA[1</a>"), 3, &["unclosed CDATA"]),
        (xml_with("<!-->"), 3, &["unclosed comment"]),
        (
            "<?xml version=\"1.0\"?>\n<?xml version=\"1.0\"?>\n<opencv_storage/>".into(),
            2,
            &["second `<?xml`"],
        ),
        // Around the root.
        (
            "<?xml version=\"1.0\"?>\n<opencv_storage/>\n\n  x".into(),
            4,
            &["text after </opencv_storage>"],
        ),
        (
            "<?xml version=\"1.0\"?>\n<opencv_storage/>\n<b/>".into(),
            3,
            &["<b> after </opencv_storage>"],
        ),
        (
            "<?xml version=\"1.0\"?>\n<opencv_storage/>\n</b>".into(),
            3,
            &["</b> after </opencv_storage>"],
        ),
        (
            "<?xml version=\"1.0\"?>\nx<opencv_storage/>".into(),
            2,
            &["expected the root element <opencv_storage>, found text"],
        ),
        (
            "<?xml version=\"1.0\"?>\n<!-- only -->\n".into(),
            3,
            &["expected the root element", "end of the text"],
        ),
    ];
    for (text, line, needles) in cases {
        let e = Document::parse(text).unwrap_err();
        assert_eq!(e.line, *line, "{text:?}: {e}");
        for n in *needles {
            assert!(e.to_string().contains(n), "{text:?}: `{n}` not in: {e}");
        }
    }
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    for text in [
        format!(
            "%YAML:1.0\na: {}1{}\n",
            "[".repeat(100_000),
            "]".repeat(100_000)
        ),
        format!("%YAML:1.0\na: {}\n", "{b: ".repeat(50_000)),
        format!(
            "<?xml version=\"1.0\"?>\n<opencv_storage>{}</opencv_storage>",
            "<a>".repeat(100_000)
        ),
        format!(
            "%YAML:1.0\n{}",
            (0..2000)
                .map(|i| format!("{}- \n", " ".repeat(i)))
                .collect::<String>()
        ),
    ] {
        let e = Document::parse(&text).unwrap_err();
        assert!(!e.message.is_empty());
    }
}

#[test]
fn writing_is_whole_or_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let c = calibration();
    let good = dir.path().join("cal.yml");
    opencv::write(&c, Tool::Scan3dCapture, &good, LengthUnit::Mm).unwrap();
    let imported =
        opencv::read(&good, Tool::Scan3dCapture, &options_for(&c, LengthUnit::Mm)).unwrap();
    assert_eq!(imported.calibration, c);
    let bad_name = dir.path().join("cal.txt");
    let e = opencv::write(&c, Tool::Scan3dCapture, &bad_name, LengthUnit::Mm).unwrap_err();
    assert!(
        e.to_string().contains("cal.txt") && e.to_string().contains(".xml"),
        "{e}"
    );
    let no_dir = dir.path().join("missing/cal.xml");
    assert!(opencv::write(&c, Tool::Procam, &no_dir, LengthUnit::Mm).is_err());
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, [std::ffi::OsString::from("cal.yml")]);
    let e = opencv::read(
        &dir.path().join("none.xml"),
        Tool::Procam,
        &ImportOptions::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("none.xml"));
}

fn valid_files() -> Vec<String> {
    let c = calibration();
    let mut out = Vec::new();
    for tool in Tool::ALL {
        for syntax in [Syntax::Yaml, Syntax::Xml] {
            out.push(opencv::to_text(&c, tool, syntax, LengthUnit::Mm));
        }
    }
    let (r, t) = hand_pose();
    for tool in Tool::ALL {
        out.push(hand_written(tool, &r, &t));
    }
    out
}

fn import_anything(bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    let options = ImportOptions {
        camera_size: Some((64, 48)),
        projector_size: Some((100, 80)),
        near_mm: Some(100.0),
        far_mm: Some(900.0),
        unit: LengthUnit::Cm,
    };
    for tool in Tool::ALL {
        match opencv::from_text(&text, "fuzz", tool, &options) {
            Ok(imported) => {
                // Whatever was accepted is a valid calibration that writes and reads again.
                let again =
                    opencv::to_text(&imported.calibration, tool, Syntax::Xml, LengthUnit::Cm);
                let back = opencv::from_text(&again, "again", tool, &options).unwrap();
                assert_eq!(back.calibration.camera, imported.calibration.camera);
            }
            Err(e) => assert!(e.to_string().starts_with("fuzz: ")),
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400), yaml in any::<bool>()) {
        let mut input = if yaml { b"%YAML:1.0\n".to_vec() } else { b"<?xml version=\"1.0\"?>\n<opencv_storage>".to_vec() };
        input.extend(&bytes);
        import_anything(&input);
        import_anything(&bytes);
    }

    #[test]
    fn arbitrary_structured_text_never_panics(text in "[%YAML:1.0\n<>/ a-z_!\\[\\]{},:\"'#&;.0-9-]{0,300}") {
        import_anything(format!("%YAML:1.0\n{text}").as_bytes());
        import_anything(format!("<?xml version=\"1.0\"?>\n<opencv_storage>{text}").as_bytes());
    }

    #[test]
    fn mutated_files_never_panic(
        which in 0usize..9,
        edits in proptest::collection::vec((any::<usize>(), any::<u8>(), 0u8..4), 1..6),
    ) {
        let mut bytes = valid_files()[which].clone().into_bytes();
        for (at, byte, op) in edits {
            if bytes.is_empty() {
                break;
            }
            let at = at % bytes.len();
            match op {
                0 => bytes[at] ^= byte | 1,
                1 => bytes.truncate(at),
                2 => bytes.insert(at, byte),
                _ => {
                    bytes.remove(at);
                }
            }
        }
        import_anything(&bytes);
    }
}

#[test]
fn import_and_export_say_what_they_wrote() {
    let (r, t) = hand_pose();
    let options = ImportOptions {
        near_mm: Some(250.0),
        far_mm: Some(900.0),
        ..ImportOptions::default()
    };
    let text = hand_written(Tool::SlStudio, &r, &t);
    let sl = opencv::from_text(&text, "sl.xml", Tool::SlStudio, &options).unwrap();
    assert!(!sl.notes.is_empty());
    let report = sl.report(Tool::SlStudio, Path::new("sl.xml"), Path::new("cal.toml"));
    let lines: Vec<&str> = report.lines().collect();
    // The notes first, one per line, then what was written.
    assert_eq!(
        lines[..sl.notes.len()],
        sl.notes.iter().map(String::as_str).collect::<Vec<_>>()
    );
    let summary = sl.calibration.summary();
    let wrote = format!("wrote cal.toml: SLStudio calibration from sl.xml; {summary}");
    assert_eq!(lines[sl.notes.len()..], [wrote.as_str()]);

    let (yml, xml) = (Path::new("out.yml"), Path::new("out.xml"));
    let source = Path::new("cal.toml");
    let from = "calibration (translation in cm) from cal.toml";
    assert_eq!(
        opencv::export_report(Tool::SlStudio, LengthUnit::Cm, yml, source),
        format!("note: SLStudio loads only .xml calibration files\nwrote out.yml: SLStudio {from}")
    );
    assert_eq!(
        opencv::export_report(Tool::SlStudio, LengthUnit::Cm, xml, source),
        format!("wrote out.xml: SLStudio {from}")
    );
    assert_eq!(
        opencv::export_report(Tool::Scan3dCapture, LengthUnit::Cm, yml, source),
        format!("wrote out.yml: scan3d-capture {from}")
    );
}
