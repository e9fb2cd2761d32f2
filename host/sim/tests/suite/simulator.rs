//! Sanity of the simulator against independent computations: the direct column and the
//! footprint's light, the virtual projector of the mirror, conservation of the projector's
//! flux through blur and mirror, the diffuse interreflection integral, the sensor's noise,
//! reproducibility and the row dump.

use std::sync::Arc;

use fsm_core::wire::row_dump::{decode_record, RowDumpHeader};
use fsm_core::{GroupCount, ScanPlan};
use fsm_io::progress::{Progress, Stage};
use fsm_sim::radiometry::{lambertian_signal, BlurKernel};
use fsm_sim::scene::presets::NAMES;
use fsm_sim::transport::paths::{arrivals, DiffusePoint};
use fsm_sim::{
    Capture, LightTransport, Material, PathKind, Scene, Sensor, SimError, SurfaceClass, System,
    TransportSettings,
};
use nalgebra::{Point3, Unit, Vector3};
use proptest::prelude::*;

fn transport(scene: &str, system: &System, rows: std::ops::Range<u32>) -> Arc<LightTransport> {
    Arc::new(
        LightTransport::compute_rows(
            &Scene::preset(scene).unwrap(),
            system,
            &TransportSettings::default(),
            rows,
        )
        .unwrap(),
    )
}

fn kind_total(lt: &LightTransport, x: u32, y: u32, kind: PathKind) -> f64 {
    lt.spans(x, y)
        .filter(|s| s.kind == kind)
        .map(|s| s.total())
        .sum()
}

#[test]
fn plane_truth_agrees_with_projection_and_with_the_footprint_light() {
    let system = System::bench();
    let cal = &system.calibration;
    let lt = transport("plane", &system, 60..64);
    let o = cal.projector_centre_mm();
    let n = Vector3::new(0.0, 0.0, -1.0);
    let mut worst_centroid: f64 = 0.0;
    let mut worst_energy: f64 = 0.0;
    let mut count = 0;
    for (x, y, t) in lt.ground_truth().iter() {
        assert_eq!(t.class, SurfaceClass::Diffuse);
        let p = Point3::from(t.point_mm);
        // On the plane, and seen at the pixel centre.
        assert!((p.z - 500.0).abs() < 1e-9);
        let pixel = cal.camera_pixel_of(&p).unwrap();
        assert!((pixel.x - x as f64).abs() < 1e-6 && (pixel.y - y as f64).abs() < 1e-6);
        // The direct column is the projection of the point.
        let column = cal.projector_column_of(&p).unwrap();
        assert!((column - t.direct_column).abs() < 1e-9);
        if !(5.0..=762.0).contains(&column) {
            continue;
        }
        // The footprint's direct light: centred on the true column (perspective across the
        // footprint and the blur move it by a few thousandths of a column) …
        let spans: Vec<_> = lt.spans(x, y).collect();
        assert_eq!(spans.len(), 1, "pixel ({x}, {y})");
        assert_eq!(spans[0].kind, PathKind::Direct);
        worst_centroid = worst_centroid.max((spans[0].centroid() - column).abs());
        // … and as strong as the Lambertian irradiance at the centre point (albedo 0.8).
        let depth = cal.pose.to_projector(&p).z;
        let expected = lambertian_signal(0.8, &p, &n, &o, depth, system.reference_distance_mm);
        worst_energy = worst_energy.max((spans[0].total() / expected - 1.0).abs());
        assert!(!t.edge && t.indirect == 0.0 && t.direct > 0.0);
        count += 1;
    }
    println!("plane: {count} pixels, footprint centroid within {worst_centroid:.4} column of the true column, light within {:.3}% of the centre's", 100.0 * worst_energy);
    assert!(count > 1000);
    assert!(worst_centroid < 0.01, "{worst_centroid}");
    assert!(worst_energy < 0.005, "{worst_energy}");
}

#[test]
fn mirror_light_arrives_at_the_virtual_projector_column() {
    let system = System::bench();
    let cal = &system.calibration;
    let lt = transport("plane_mirror", &system, 90..130);
    let (mut count, mut worst): (usize, f64) = (0, 0.0);
    let lit_by_mirror = |x: u32, y: u32| kind_total(&lt, x, y, PathKind::Specular) > 0.0;
    for (x, y, t) in lt.ground_truth().iter() {
        if t.class != SurfaceClass::Diffuse || t.edge || !lit_by_mirror(x, y) {
            continue;
        }
        // Inside the mirror-lit region: the whole footprint gets the mirror's light.
        let interior = x > 0
            && x + 1 < system.width()
            && lt.rows().contains(&(y - 1))
            && lt.rows().contains(&(y + 1))
            && [(x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)]
                .iter()
                .all(|&(a, b)| lit_by_mirror(a, b));
        if !interior {
            continue;
        }
        let specular: Vec<_> = lt
            .spans(x, y)
            .filter(|s| s.kind == PathKind::Specular)
            .collect();
        // Independent prediction: reflect the point in the mirror's plane x = -60 and project
        // the reflection into the real projector.
        let p = Point3::from(t.point_mm);
        let reflected = Point3::new(-120.0 - p.x, p.y, p.z);
        let predicted = cal.projector_column_of(&reflected).unwrap();
        assert_eq!(specular.len(), 1);
        worst = worst.max((specular[0].centroid() - predicted).abs());
        assert!(t.is_interreflection());
        count += 1;
    }
    println!("plane_mirror: {count} pixels lit through the mirror, light within {worst:.4} column of the virtual projector's column");
    assert!(count > 1000, "{count}");
    assert!(worst < 0.02, "{worst}");
}

#[test]
fn the_mirror_passes_on_its_reflectance_times_the_flux_it_receives() {
    // Flux on the mirror from the real projector, integrated over the mirror, against the flux
    // the plane receives from the virtual projector (the simulator's path code), integrated
    // over the plane: the second must be 0.9 × the first.
    let system = System::bench();
    let cal = &system.calibration;
    let scene = Scene::preset("plane_mirror").unwrap();
    let d_ref = system.reference_distance_mm;
    let o = cal.projector_centre_mm();
    let h = 0.25;
    let mut on_mirror = 0.0;
    let nm = Vector3::x();
    let mut z = 380.0 + h / 2.0;
    while z < 470.0 {
        let mut y = -60.0 + h / 2.0;
        while y < 60.0 {
            let m = Point3::new(-60.0, y, z);
            let depth = cal.pose.to_projector(&m).z;
            on_mirror += lambertian_signal(1.0, &m, &nm, &o, depth, d_ref) * h * h;
            y += h;
        }
        z += h;
    }
    let mut on_plane = 0.0;
    let mut out = Vec::new();
    let mut x = -60.0 + h / 2.0;
    while x < 60.0 {
        let mut y = -100.0 + h / 2.0;
        while y < 100.0 {
            let at = DiffusePoint {
                point: Point3::new(x, y, 500.0),
                normal: Unit::new_normalize(Vector3::new(0.0, 0.0, -1.0)),
                view: Unit::new_normalize(Point3::origin() - Point3::new(x, y, 500.0)),
                material: Material::Diffuse { albedo: 1.0 },
                throughput: 1.0,
                surface: 0,
                bounces: 0,
            };
            arrivals(&scene, cal, d_ref, 0.0, &at, &mut out);
            on_plane += out
                .iter()
                .filter(|a| a.via_mirror)
                .map(|a| a.signal)
                .sum::<f64>()
                * h
                * h;
            y += h;
        }
        x += h;
    }
    let ratio = on_plane / on_mirror;
    println!(
        "flux through the mirror: {on_plane:.2} / {on_mirror:.2} = {ratio:.4} (reflectance 0.9)"
    );
    assert!((ratio - 0.9).abs() < 0.005, "{ratio}");
}

#[test]
fn vgroove_interreflection_matches_a_brute_force_integral() {
    let system = System::bench();
    let cal = &system.calibration;
    let scene = Scene::preset("vgroove").unwrap();
    let o = cal.projector_centre_mm();
    let d_ref = system.reference_distance_mm;
    // The left facet's pixels at three distances from the corner (x = 0) on row 120.
    let lt = transport("vgroove", &system, 120..121);
    let mut checked = 0;
    for target_distance in [30.0, 8.0, 2.5] {
        let (x, t) = (0..system.width())
            .filter_map(|x| lt.ground_truth().pixel(x, 120).map(|t| (x, *t)))
            .filter(|(_, t)| t.surface == Some(0) && !t.edge)
            .min_by(|a, b| {
                let da = (-a.1.point_mm[0] * std::f64::consts::SQRT_2 - target_distance).abs();
                let db = (-b.1.point_mm[0] * std::f64::consts::SQRT_2 - target_distance).abs();
                da.total_cmp(&db)
            })
            .unwrap();
        let p = Point3::from(t.point_mm);
        let n_a = Vector3::new(1.0, 0.0, -1.0).normalize();
        let n_b = Vector3::new(-1.0, 0.0, -1.0).normalize();
        // Midpoint rule on a uniform 0.2 mm grid of the right facet (corner (0, z=560) to
        // (150, z=410), heights ±110).
        let cells_slope = 1060;
        let cells_height = 1100;
        let slope = Vector3::new(150.0, 0.0, -150.0) / cells_slope as f64;
        let up = Vector3::new(0.0, 220.0, 0.0) / cells_height as f64;
        let area = slope.norm() * up.norm();
        let mut sum = 0.0;
        for i in 0..cells_slope {
            for j in 0..cells_height {
                let q = Point3::new(0.0, -110.0, 560.0)
                    + slope * (i as f64 + 0.5)
                    + up * (j as f64 + 0.5);
                let qp = cal.pose.to_projector(&q);
                let Some(img) = cal.projector.project(&qp) else {
                    continue;
                };
                if img.x < -0.5 || img.x > 767.5 || img.y < -0.5 || img.y > 1023.5 {
                    continue;
                }
                let s = lambertian_signal(0.8, &q, &n_b, &o, qp.z, d_ref);
                let r = q - p;
                let cos_a = n_a.dot(&r).max(0.0);
                let cos_b = (-n_b.dot(&r)).max(0.0);
                sum += s * cos_a * cos_b / r.norm_squared().powi(2) * area;
            }
        }
        let expected = 0.8 / std::f64::consts::PI * sum;
        let got = kind_total(&lt, x, 120, PathKind::Diffuse);
        println!(
            "vgroove pixel {x} ({:.1} mm from the corner): diffuse interreflection {got:.5}, brute force {expected:.5} ({:+.2}%), direct {:.4}",
            -p.x * std::f64::consts::SQRT_2,
            100.0 * (got / expected - 1.0),
            t.direct
        );
        assert!((got / expected - 1.0).abs() < 0.02, "{got} vs {expected}");
        checked += 1;
    }
    assert_eq!(checked, 3);
    let _ = scene;
}

#[test]
fn sensor_noise_has_the_modelled_mean_and_variance() {
    let system = System::bench();
    let lt = transport("plane", &system, 100..104);
    let sensor = Sensor::default();
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let capture = Capture::new(lt, &plan, &system, sensor, 3).unwrap();
    let n = capture.frame_count() * capture.width() as usize;
    let (mut codes, mut signal) = (vec![0u16; n], vec![0.0f32; n]);
    let (mut sum, mut sum_sq, mut count) = (0.0, 0.0, 0usize);
    for y in capture.rows() {
        capture.render_row(y, &mut codes).unwrap();
        capture.signal_row(y, &mut signal).unwrap();
        for (&c, &s) in codes.iter().zip(&signal) {
            let mean_e = s as f64 * sensor.white_electrons;
            let var = sensor.gain_dn_per_electron.powi(2)
                * (mean_e + sensor.read_noise_electrons.powi(2))
                + 1.0 / 12.0;
            let z = (c as f64 - sensor.expected_dn(s as f64)) / var.sqrt();
            sum += z;
            sum_sq += z * z;
            count += 1;
        }
    }
    let mean = sum / count as f64;
    let std = (sum_sq / count as f64 - mean * mean).sqrt();
    println!("sensor: {count} samples, normalised residual mean {mean:+.4}, std {std:.4}");
    assert!(
        mean.abs() < 0.01 && (std - 1.0).abs() < 0.01,
        "{mean} {std}"
    );

    // Saturation: an exposure 10x too long clips every lit sample of a white frame at the top code.
    let lt = transport("plane", &system, 100..101);
    let bright = Sensor {
        white_electrons: 1e5,
        ..sensor
    };
    let capture = Capture::new(lt.clone(), &plan, &system, bright, 3).unwrap();
    let row = capture.row(100).unwrap();
    let white = plan.white_index().unwrap() * capture.width() as usize;
    assert!(row[white..white + capture.width() as usize]
        .iter()
        .all(|&c| c == bright.max_code()));
    // Noise off: every code is the rounded expectation.
    let quiet = sensor.noiseless();
    let capture = Capture::new(lt, &plan, &system, quiet, 3).unwrap();
    let row = capture.row(100).unwrap();
    let mut sig = vec![0.0f32; row.len()];
    capture.signal_row(100, &mut sig).unwrap();
    for (&c, &s) in row.iter().zip(&sig) {
        assert_eq!(c as f64, quiet.expected_dn(s as f64).round());
    }
}

#[test]
fn rows_are_reproducible_and_independent_of_the_band() {
    let system = System::bench();
    let plan = ScanPlan::paper_efsm(GroupCount::One);
    let a = Capture::new(
        transport("plane_mirror", &system, 100..104),
        &plan,
        &system,
        Sensor::default(),
        9,
    )
    .unwrap();
    let b = Capture::new(
        transport("plane_mirror", &system, 102..110),
        &plan,
        &system,
        Sensor::default(),
        9,
    )
    .unwrap();
    let c = Capture::new(
        transport("plane_mirror", &system, 102..103),
        &plan,
        &system,
        Sensor::default(),
        10,
    )
    .unwrap();
    assert_eq!(a.row(102).unwrap(), b.row(102).unwrap());
    assert_eq!(a.row(103).unwrap(), a.row(103).unwrap());
    assert_ne!(a.row(102).unwrap(), c.row(102).unwrap());
    assert!(matches!(a.row(104), Err(SimError::Rows { .. })));
    assert!(matches!(
        a.write_row_dump(Vec::new(), &Progress::hidden()),
        Err(SimError::PartialCapture { .. })
    ));
}

#[test]
fn row_dump_round_trips_through_the_core_reader() {
    let system = System::bench_with_camera(40, 30);
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let scene = Scene::preset("plane_mirror").unwrap();
    let capture =
        fsm_sim::simulate(&plan, &scene, &system, &Sensor::with_bit_depth(10), 1).unwrap();
    let mut bytes = Vec::new();
    let progress = Progress::hidden();
    capture.write_row_dump(&mut bytes, &progress).unwrap();
    // Every row is reported, in one stage.
    assert_eq!(
        progress.stages(),
        [Stage {
            message: "rendering rows",
            total: 30,
            done: 30
        }]
    );
    let header = RowDumpHeader::decode(&bytes).unwrap();
    header.check_plan(&plan).unwrap();
    assert_eq!(
        (header.width, header.height, header.bit_depth),
        (40, 30, 10)
    );
    let len = header.record_len().unwrap();
    assert_eq!(bytes.len(), 64 + 30 * len);
    let mut samples = vec![0u16; header.samples_per_row()];
    for y in 0..30u32 {
        let record = decode_record(&header, &bytes[64 + y as usize * len..]).unwrap();
        assert_eq!(record.row, y);
        record.copy_to(&mut samples).unwrap();
        assert_eq!(samples, capture.row(y).unwrap());
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scan.fsmrows");
    capture
        .write_row_dump_file(&path, &Progress::hidden())
        .unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), bytes);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    // A failed write leaves nothing behind and names the file.
    let err = capture
        .write_row_dump_file(
            &dir.path().join("missing/scan.fsmrows"),
            &Progress::hidden(),
        )
        .unwrap_err();
    assert!(err.to_string().contains("missing/scan.fsmrows"), "{err}");
}

#[test]
fn every_preset_renders_and_shows_the_light_it_was_built_for() {
    let system = System::bench();
    for name in NAMES {
        let lt = transport(name, &system, 118..122);
        let mut totals = [0.0f64; 3];
        for (x, y, _) in lt.ground_truth().iter() {
            for (k, kind) in [PathKind::Direct, PathKind::Specular, PathKind::Diffuse]
                .into_iter()
                .enumerate()
            {
                totals[k] += kind_total(&lt, x, y, kind);
            }
        }
        println!(
            "{name}: direct {:.1}, specular {:.1}, diffuse {:.1} (reference whites over 4 rows)",
            totals[0], totals[1], totals[2]
        );
        assert!(totals[0] > 0.0, "{name}");
        let mirror = name == "plane_mirror" || name == "sphere_mirror";
        assert_eq!(totals[1] > 0.0, mirror, "{name}");
        let groove = name == "vgroove" || name == "vgroove_glossy";
        assert_eq!(totals[2] > 0.0, groove, "{name}");
    }
    assert!(matches!(
        Scene::by_name("nope"),
        Err(SimError::UnknownScene(_))
    ));
}

#[test]
fn plan_and_projector_must_agree_on_the_columns() {
    let system = System::bench();
    let plan = ScanPlan::efsm(512, 64, GroupCount::One);
    let err = Capture::new(
        transport("plane", &system, 0..1),
        &plan,
        &system,
        Sensor::default(),
        0,
    )
    .unwrap_err();
    assert!(err.to_string().contains("512"), "{err}");
}

proptest! {
    #[test]
    fn blur_moves_light_between_columns_without_creating_any(
        u in 20.0..748.0f64,
        sigma in prop_oneof![Just(0.0), 0.05..3.0f64],
    ) {
        let kernel = BlurKernel::new(sigma);
        let mut acc = vec![0.0f32; 768];
        kernel.deposit(&mut acc, u, 1.0).unwrap();
        let total: f64 = acc.iter().map(|&w| w as f64).sum();
        prop_assert!((total - 1.0).abs() < 1e-5, "{total}");
        let centroid: f64 = acc.iter().enumerate().map(|(j, &w)| j as f64 * w as f64).sum::<f64>() / total;
        // The centroid is u up to the ripple of a box sampled at integers, whose amplitude is
        // (1/π)·exp(−2π²σ²) (first Fourier term of the box-and-Gaussian kernel's first moment):
        // 0.002 column at σ = 0.5, 1e-5 at the default 0.7.
        // Below σ ≈ 0.3 the higher harmonics count too; the bound is then the box's ±0.5.
        let ripple = if sigma < 0.3 {
            0.5
        } else {
            0.33 * (-2.0 * std::f64::consts::PI.powi(2) * sigma * sigma).exp() + 1e-4
        };
        let tolerance = ripple;
        prop_assert!((centroid - u).abs() <= tolerance, "{centroid} vs {u}");
    }
}

#[test]
fn a_simulated_folder_reports_the_transport_and_the_rendering_row_by_row() {
    let rendering = fsm_sim::folder::Rendering {
        system: System::bench_with_camera(40, 30),
        seed: 1,
        supersampling: 1,
    };
    let plan = fsm_io::plan_file::MethodPlan::Fsm(ScanPlan::paper_efsm(GroupCount::One));
    let scene = Scene::preset("plane").unwrap();
    let progress = Progress::hidden();
    let dir = tempfile::tempdir().unwrap();
    fsm_sim::folder::write_scene(dir.path(), &scene, &plan, &rendering, true, &progress).unwrap();
    let frames = plan.frame_count() as u64;
    let stage = |message, total| Stage {
        message,
        total,
        done: total,
    };
    assert_eq!(
        progress.stages(),
        [
            stage("light transport", 30),
            stage("rendering rows", 30),
            stage("writing images", frames)
        ]
    );
}

/// `truth/` as `fsm scan --truth` reads it back: the depth and the directly lit pixels of the
/// capture, refused (naming the file and both sizes) by a camera of another size.
#[test]
fn the_truth_folder_reads_back_for_the_scan() {
    let system = System::bench_with_camera(40, 30);
    let rendering = fsm_sim::folder::Rendering {
        system: system.clone(),
        seed: 1,
        supersampling: 1,
    };
    let plan = ScanPlan::paper_efsm(GroupCount::One);
    let scene = Scene::preset("plane_mirror").unwrap();
    let progress = Progress::hidden();
    let capture = fsm_sim::folder::capture_of(&scene, &plan, &rendering, &progress).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let truth_dir = dir.path().join("truth");
    fsm_sim::folder::write_truth(&capture, &truth_dir).unwrap();
    let truth = fsm_scan::pipeline::Truth::read(&truth_dir, &system.calibration.camera).unwrap();
    let pixels: Vec<_> = capture.ground_truth().iter().collect();
    assert_eq!((truth.depth_mm.len(), truth.lit.len()), (40 * 30, 40 * 30));
    for (x, y, p) in pixels {
        let i = (y * 40 + x) as usize;
        assert_eq!(truth.lit[i], p.direct_column.is_finite(), "({x}, {y})");
        assert!(truth.depth_mm[i] == p.point_mm[2] as f32 || truth.depth_mm[i].is_nan());
    }
    let other = System::bench_with_camera(20, 15);
    let e = fsm_scan::pipeline::Truth::read(&truth_dir, &other.calibration.camera)
        .err()
        .expect("another size is refused")
        .to_string();
    assert!(
        e.contains("depth.tiff") && e.contains("40x30") && e.contains("20x15"),
        "{e}"
    );
}

/// `fsm simulate --scene checkerboard` prints a line per board pose written: the pose, its
/// noise seed and the seconds since the start.
#[test]
fn a_board_simulation_reports_each_pose() {
    use fsm_sim::folder::{Rendering, SimulationRequest, CHECKERBOARD};
    let request = SimulationRequest {
        scene: CHECKERBOARD.into(),
        plan: None,
        preset: None,
        rendering: Rendering {
            system: System::bench_with_camera(64, 48),
            seed: 7,
            supersampling: 1,
        },
        images: true,
        board: None,
        board_pose: Some("25,-15,10,520".parse().unwrap()),
        board_poses: None,
    };
    let dir = tempfile::tempdir().unwrap();
    let mut lines = Vec::new();
    let simulation = request.resolve().unwrap();
    let done = |line| lines.push(line);
    simulation
        .write(dir.path(), &Progress::hidden(), done)
        .unwrap();
    assert_eq!(lines.len(), 1, "{lines:?}");
    let pose = "pose: yaw 25 pitch -15 roll 10 deg, centre (0, 0, 520) mm, seed 7 (";
    assert!(
        lines[0].starts_with(pose) && lines[0].ends_with(" s)"),
        "{lines:?}"
    );
}
