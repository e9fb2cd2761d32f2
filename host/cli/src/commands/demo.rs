//! `fsm demo`: the paper's comparison on a simulated mirror scene, no camera needed.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use fsm_core::{GroupCount, PhaseShiftPlan, PixelFlags, ScanPlan};
use fsm_host::column_map::viridis_rgb;
use fsm_host::image_files::{write_png_gray8, write_png_rgb8};
use fsm_host::outputs::{write_file, StagedDir};
use fsm_host::{Error, Result};
use fsm_scan::decoded::{DecodedImage, Method};
use fsm_scan::metrics::{compare, point_errors, Comparison, PointErrors, Truth};
use fsm_scan::output::{write_scan, ScanSummary, SelectionSummary};
use fsm_scan::triangulate::column_limits;
use fsm_scan::{SelectionParams, Surface};
use fsm_sim::{
    Capture, LightTransport, PixelTruth, Scene, Sensor, SurfaceClass, System, TransportSettings,
};
use serde::Serialize;

use super::simulate::parse_size;

/// Run the paper's comparison on simulated scenes: BFSM, EFSM and phase shift, with and
/// without a mirror's interreflection, and under glossy interreflection.
///
/// The bench scanner looks at a diffuse plane beside a planar mirror (`plane_mirror`): the
/// plane receives the projector's light directly and through the mirror. The same scene with
/// the mirror blackened (`plane_mirror_covered`) is the reference. Each is scanned with BFSM
/// (768 patterns), EFSM (cB 64, two groups: 152 patterns), phase shift + Gray code (6 + 7
/// patterns) and the EFSM patterns decoded by the local-maximum search (`EFSM-fast`, the
/// camera's fast decoder), each through the same decode → triangulate → select path, and
/// compared with the simulator's ground truth and with each other (paper Fig. 9: Ed, EnoI,
/// EwiI). BFSM and EFSM are also decoded by CLEAN (`-CLEAN`, the DFT search the cosine search
/// replaced). Every method also scans `vgroove_glossy` (two rough-metal facets whose light
/// reflected facet to facet outshines the direct light): how often the direct column is
/// among the candidates and the selected point is right.
///
/// Writes into the output folder:
///   report.md, report.json     the figures per method, with pictures
///   <method>/<scene>/          each scan's outputs (as `fsm scan` writes them)
///   <method>/column_error.png  |decoded − true column| with the mirror (0 to 1 column)
///   interreflection.png        where the mirror's light exceeds 20% of the direct light
///
/// Examples:
///   fsm demo
///   fsm demo --out my-demo --camera 640x480
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Output folder (created; must not exist or be empty, unless --force).
    #[arg(long, value_name = "DIR", default_value = "fsm-demo")]
    out: PathBuf,
    /// Camera size WxH (same field of view).
    #[arg(long, value_name = "WxH", default_value = "320x240", value_parser = parse_size)]
    camera: (u32, u32),
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Replace the output folder if it exists and is not empty.
    #[arg(long)]
    force: bool,
}

/// One method's entry of `report.json`.
#[derive(Serialize)]
struct MethodReport {
    method: &'static str,
    patterns: usize,
    figures: Comparison,
    /// Output points on `plane_mirror` against the true surface points.
    points: PointErrors,
    e_d_percent_of_standoff: f64,
    e_no_i_percent_of_standoff: f64,
    e_wi_i_percent_of_standoff: f64,
    glossy: GlossyFigures,
    seconds: f64,
}

/// A method on `vgroove_glossy`: rough metal, its direct light under a lobe about 13 times as
/// bright, spread over tens of columns.
#[derive(Serialize, Clone, Copy)]
struct GlossyFigures {
    /// Facet pixels (lit directly, away from edges).
    pixels: usize,
    /// Of them, with the direct column among the decoder's candidates (within 0.5 column).
    direct_among_candidates: f64,
    /// With a point after the selection.
    completeness: f64,
    /// Of the points, whose column is within 0.5 column of the direct one.
    points_within_half_column: f64,
    /// Every output point of the scene against the true surface points.
    points: PointErrors,
}

/// Output points more than this far from the true surface are wrong, mm.
const WRONG_BEYOND_MM: f64 = 1.0;

/// The true surface point of every pixel, and which pixels are lit directly (away from edges).
fn truth_points(truth: &[PixelTruth]) -> (Vec<[f64; 3]>, Vec<bool>) {
    (
        truth.iter().map(|t| t.point_mm).collect(),
        truth.iter().map(PixelTruth::is_lit_directly).collect(),
    )
}

#[derive(Serialize)]
struct Report {
    camera: [u32; 2],
    standoff_mm: f64,
    seed: u64,
    interreflection_pixels: usize,
    methods: Vec<MethodReport>,
}

const STANDOFF_MM: f64 = 500.0;

enum Plan {
    Fsm(ScanPlan),
    PhaseShift(PhaseShiftPlan),
}

impl Plan {
    fn capture(
        &self,
        transport: Arc<LightTransport>,
        system: &System,
        seed: u64,
    ) -> Result<Capture> {
        let sensor = Sensor::default();
        match self {
            Plan::Fsm(p) => Capture::new(transport, p, system, sensor, seed),
            Plan::PhaseShift(p) => Capture::new(transport, p, system, sensor, seed),
        }
        .map_err(sim_error)
    }

    fn method(&self) -> Method<'_> {
        match self {
            Plan::Fsm(p) => Method::Fsm(p),
            Plan::PhaseShift(p) => Method::PhaseShift(p),
        }
    }

    fn patterns(&self) -> usize {
        match self {
            Plan::Fsm(p) => p.pattern_count(),
            Plan::PhaseShift(p) => p.sequence_len() - 2,
        }
    }

    fn fingerprint(&self) -> u64 {
        match self {
            Plan::Fsm(p) => p.fingerprint(),
            Plan::PhaseShift(p) => p.fingerprint(),
        }
    }
}

fn sim_error(e: impl std::fmt::Display) -> Error {
    Error::Usage(format!("simulation: {e}"))
}

pub fn run(args: Args) -> Result<()> {
    let staged = StagedDir::create(&args.out, args.force)?;
    let system = System::bench_with_camera(args.camera.0, args.camera.1);
    let (w, h) = (system.width() as usize, system.height() as usize);
    eprintln!(
        "fsm demo: simulating plane_mirror, plane_mirror_covered and vgroove_glossy ({w}x{h} camera)…"
    );
    let transports: Vec<Arc<LightTransport>> = ["plane_mirror", "plane_mirror_covered"]
        .iter()
        .map(|name| {
            let scene = Scene::by_name(name).map_err(sim_error)?;
            LightTransport::compute(&scene, &system, &TransportSettings::default())
                .map(Arc::new)
                .map_err(sim_error)
        })
        .collect::<Result<_>>()?;
    let glossy_transport = {
        let scene = Scene::by_name("vgroove_glossy").map_err(sim_error)?;
        LightTransport::compute(&scene, &system, &TransportSettings::default())
            .map(Arc::new)
            .map_err(sim_error)?
    };
    // The FSM plans state the simulated camera's sensor, as a user states theirs.
    let fsm = |mut plan: ScanPlan| {
        plan.decoding.sensor = Sensor::default().datasheet();
        Plan::Fsm(plan)
    };
    let methods = [
        ("BFSM", fsm(ScanPlan::paper_bfsm())),
        ("EFSM", fsm(ScanPlan::paper_efsm(GroupCount::Two))),
        // The same patterns decoded by CLEAN on the zero-padded DFT, as before the cosine
        // search.
        ("BFSM-CLEAN", fsm(ScanPlan::paper_bfsm().with_clean())),
        (
            "EFSM-CLEAN",
            fsm(ScanPlan::paper_efsm(GroupCount::Two).with_clean()),
        ),
        ("PS", Plan::PhaseShift(PhaseShiftPlan::paper())),
        // The same EFSM patterns decoded as a camera can at frame rate (the paper's
        // local-maximum search): what that costs in accuracy.
        (
            "EFSM-fast",
            fsm(ScanPlan::paper_efsm(GroupCount::Two).with_local_maxima()),
        ),
    ];
    let params = SelectionParams::for_calibration(&system.calibration);
    let mut truth_pixels: Vec<PixelTruth> = Vec::new();
    let mut reports = Vec::new();
    for (name, plan) in &methods {
        let started = Instant::now();
        let mut surfaces = Vec::new();
        for (t, scene) in transports
            .iter()
            .zip(["plane_mirror", "plane_mirror_covered"])
        {
            let capture = plan.capture(t.clone(), &system, args.seed)?;
            let limits = |y: usize| column_limits(&system.calibration, w, y);
            let decode_started = Instant::now();
            let decoded = DecodedImage::decode_rows(
                plan.method(),
                w,
                0..h,
                capture.bit_depth(),
                Some(&limits),
                |y| capture.row(y as u32).map_err(sim_error),
            )?;
            let decode_seconds = decode_started.elapsed().as_secs_f64();
            let (surface, times) = Surface::reconstruct(&decoded, &system.calibration, &params);
            let dir = staged.file(&format!("{}/{scene}", name.to_lowercase()));
            std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
            let summary = ScanSummary {
                method: name.to_string(),
                plan_fingerprint: format!("{:016x}", plan.fingerprint()),
                width: w,
                height: h,
                candidates: decoded
                    .pixels
                    .iter()
                    .map(|p| p.candidates.len() as u64)
                    .sum(),
                aliased_pixels: decoded
                    .pixels
                    .iter()
                    .filter(|p| p.flags.contains(PixelFlags::ALIASED))
                    .count() as u64,
                unresolved_pixels: decoded
                    .pixels
                    .iter()
                    .filter(|p| p.flags.contains(PixelFlags::UNRESOLVED))
                    .count() as u64,
                candidates_in_volume: surface.candidates,
                points: surface.points(),
                decode_seconds,
                triangulate_seconds: times.triangulate_seconds,
                select_seconds: times.select_seconds,
                selection: SelectionSummary {
                    paths: params.paths.count(),
                    epsilon_mm: params.epsilon_mm,
                    beta_per_mm: params.beta_per_mm,
                    drop_aliased: params.drop_aliased,
                    drop_fictitious: params.drop_fictitious,
                    min_quality: params.min_quality,
                },
                no_point: surface.no_point_counts(),
                rows_without_data: Vec::new(),
                bad_records: Vec::new(),
                calibration_checksum: format!("{:08x}", system.calibration.checksum()),
                truth: None,
            };
            write_scan(&dir, &surface, &summary)?;
            if truth_pixels.is_empty() {
                truth_pixels = (0..h)
                    .flat_map(|y| (0..w).map(move |x| (x, y)))
                    .map(|(x, y)| {
                        *capture
                            .ground_truth()
                            .pixel(x as u32, y as u32)
                            .expect("a rendered pixel")
                    })
                    .collect();
            }
            surfaces.push(surface);
        }
        let direct_column: Vec<f64> = truth_pixels.iter().map(|t| t.direct_column).collect();
        let interreflection: Vec<bool> = truth_pixels
            .iter()
            .map(|t| t.is_interreflection() && !t.edge)
            .collect();
        let surface_mask: Vec<bool> = truth_pixels
            .iter()
            .map(|t| t.class == SurfaceClass::Diffuse && !t.edge && t.direct_column.is_finite())
            .collect();
        let truth = Truth {
            direct_column: &direct_column,
            interreflection: &interreflection,
            surface: &surface_mask,
        };
        let figures = compare(&surfaces[0], &surfaces[1], &truth);
        let (truth_mm, lit) = truth_points(&truth_pixels);
        let points = point_errors(&surfaces[0].point_mm, &truth_mm, &lit, WRONG_BEYOND_MM);
        write_column_error(
            &staged.file(&format!("{}/column_error.png", name.to_lowercase())),
            w,
            h,
            &surfaces[0],
            &direct_column,
        )?;
        let glossy = glossy_figures(plan, &glossy_transport, &system, &params, args.seed)?;
        let seconds = started.elapsed().as_secs_f64();
        eprintln!(
            "  {name}: {:.2}% of interreflection pixels within 0.5 column, Ed {:.4} mm, EnoI {:.4} mm, EwiI {:.4} mm ({seconds:.1} s)",
            100.0 * figures.interreflection.within_half_column,
            figures.e_d_mm,
            figures.e_no_i_mm,
            figures.e_wi_i_mm
        );
        reports.push(MethodReport {
            method: name,
            patterns: plan.patterns(),
            figures,
            points,
            e_d_percent_of_standoff: 100.0 * figures.e_d_mm / STANDOFF_MM,
            e_no_i_percent_of_standoff: 100.0 * figures.e_no_i_mm / STANDOFF_MM,
            e_wi_i_percent_of_standoff: 100.0 * figures.e_wi_i_mm / STANDOFF_MM,
            glossy,
            seconds,
        });
    }
    let interreflection: Vec<u8> = truth_pixels
        .iter()
        .map(|t| if t.is_interreflection() { 255 } else { 0 })
        .collect();
    let path = staged.file("interreflection.png");
    let mut bytes = Vec::new();
    write_png_gray8(&mut bytes, w as u32, h as u32, &interreflection).map_err(|e| {
        Error::Encode {
            path: path.clone(),
            message: e.0,
        }
    })?;
    write_file(&path, &bytes)?;
    let report = Report {
        camera: [w as u32, h as u32],
        standoff_mm: STANDOFF_MM,
        seed: args.seed,
        interreflection_pixels: truth_pixels
            .iter()
            .filter(|t| t.is_interreflection())
            .count(),
        methods: reports,
    };
    let json = serde_json::to_vec_pretty(&report)
        .map_err(|e| Error::Usage(format!("report.json: {e}")))?;
    write_file(&staged.file("report.json"), &json)?;
    write_file(&staged.file("report.md"), markdown(&report).as_bytes())?;
    let out = staged.commit()?;
    eprintln!("fsm demo: report in {}", out.join("report.md").display());
    Ok(())
}

/// Scans `vgroove_glossy` with `plan` and scores it against the truth.
fn glossy_figures(
    plan: &Plan,
    transport: &Arc<LightTransport>,
    system: &System,
    params: &SelectionParams,
    seed: u64,
) -> Result<GlossyFigures> {
    let (w, h) = (system.width() as usize, system.height() as usize);
    let capture = plan.capture(transport.clone(), system, seed)?;
    let limits = |y: usize| column_limits(&system.calibration, w, y);
    let decoded = DecodedImage::decode_rows(
        plan.method(),
        w,
        0..h,
        capture.bit_depth(),
        Some(&limits),
        |y| capture.row(y as u32).map_err(sim_error),
    )?;
    let (surface, _) = Surface::reconstruct(&decoded, &system.calibration, params);
    let truth: Vec<PixelTruth> = (0..w * h)
        .map(|i| {
            *capture
                .ground_truth()
                .pixel((i % w) as u32, (i / w) as u32)
                .expect("a rendered pixel")
        })
        .collect();
    let (truth_mm, lit) = truth_points(&truth);
    let all_points = point_errors(&surface.point_mm, &truth_mm, &lit, WRONG_BEYOND_MM);
    let (mut pixels, mut among, mut points, mut right) = (0usize, 0usize, 0usize, 0usize);
    for (i, p) in decoded.pixels.iter().enumerate() {
        let t = &truth[i];
        if t.class != SurfaceClass::Glossy || t.edge || !t.direct_column.is_finite() {
            continue;
        }
        pixels += 1;
        let near = |c: f32| (c as f64 - t.direct_column).abs() <= 0.5;
        among += p.candidates.iter().any(|c| near(c.column)) as usize;
        if let Some(c) = surface.column[i] {
            points += 1;
            right += near(c) as usize;
        }
    }
    let share = |a: usize, b: usize| a as f64 / b.max(1) as f64;
    Ok(GlossyFigures {
        pixels,
        direct_among_candidates: share(among, pixels),
        completeness: share(points, pixels),
        points_within_half_column: share(right, points),
        points: all_points,
    })
}

/// `|decoded − true column|` per pixel, viridis from 0 to 1 column, black where either is
/// missing.
fn write_column_error(
    path: &Path,
    w: usize,
    h: usize,
    surface: &Surface,
    truth: &[f64],
) -> Result<()> {
    let errors: Vec<f32> = surface
        .column
        .iter()
        .zip(truth)
        .map(|(c, t)| match c {
            Some(c) if t.is_finite() => (*c as f64 - t).abs() as f32,
            _ => f32::NAN,
        })
        .collect();
    let mut bytes = Vec::new();
    write_png_rgb8(
        &mut bytes,
        w as u32,
        h as u32,
        &viridis_rgb(&errors, 0.0, 1.0),
    )
    .map_err(|e| Error::Encode {
        path: path.to_path_buf(),
        message: e.0,
    })?;
    write_file(path, &bytes)
}

fn markdown(report: &Report) -> String {
    let mut md = String::new();
    md.push_str(&format!(
        "# fsm demo: a mirror's interreflection, {} methods\n\n",
        report.methods.len()
    ));
    md.push_str(&format!(
        "Simulated bench scanner (baseline 200 mm, standoff {} mm, 768-column projector, {}×{} camera, seed {}). \
         The scene `plane_mirror` is a diffuse plane beside a planar mirror: {} camera pixels receive more than 20% \
         of their light through the mirror (white in `interreflection.png`). `plane_mirror_covered` is the same \
         scene with the mirror blackened. Every method goes through the same path: decode, triangulate every \
         candidate, select the direct one semi-globally. BFSM and EFSM decode with the cosine search (the exact \
         inverse of their full band); `-CLEAN` rows decode the same captures with CLEAN on the zero-padded DFT, \
         `EFSM-fast` with the paper's local maxima. Where a pixel's direct and mirrored columns fall within one \
         footprint of each other modulo the block width (2Δc for the DFT searches), EFSM cannot separate them \
         (paper §IV-C): the decoder flags the pixel aliased and it gets no point, which the completeness column \
         shows.\n\n",
        report.standoff_mm, report.camera[0], report.camera[1], report.seed, report.interreflection_pixels
    ));
    md.push_str("| method | patterns | interreflection pixels within 0.5 column | column RMS there (covered) | Ed mm (% standoff) | EnoI mm | EwiI mm | completeness | points > 1 mm off | directly lit pixels with a right point |\n");
    md.push_str("|---|---|---|---|---|---|---|---|---|---|\n");
    for m in &report.methods {
        let f = &m.figures;
        md.push_str(&format!(
            "| {} | {} | {:.2}% | {:.4} ({:.4}) | {:.4} ({:.4}%) | {:.4} | {:.4} | {:.1}% | {:.2}% | {:.2}% |\n",
            m.method,
            m.patterns,
            100.0 * f.interreflection.within_half_column,
            f.interreflection.rms_columns,
            f.interreflection_covered.rms_columns,
            f.e_d_mm,
            m.e_d_percent_of_standoff,
            f.e_no_i_mm,
            f.e_wi_i_mm,
            100.0 * f.completeness,
            100.0 * m.points.wrong_share(),
            100.0 * m.points.completeness()
        ));
    }
    md.push_str(
        "\nEd: RMS distance between the points of the scans with and without the mirror. EnoI, EwiI: RMS \
         distance to a fitted plane without and with the mirror (paper Fig. 9). Column RMS: of the pixels within \
         0.5 column of the truth. Points > 1 mm off: the share of all output points more than 1 mm from the \
         true surface point of their pixel (a point on a pixel that sees no surface counts as off); directly lit \
         pixels with a right point: of the pixels the projector lights directly (away from edges), the share \
         whose point is within 1 mm.\n\n",
    );
    md.push_str(
        "\n## Glossy interreflection: `vgroove_glossy`\n\nTwo rough-metal facets (GGX, roughness 0.2) in a V: the \
         light reflected facet to facet is about 13 times the direct light at the median pixel and spreads over \
         tens of projector columns.\n\n| method | facet pixels | direct column among the candidates | with a point | \
         points within 0.5 column | points > 1 mm off | directly lit pixels with a right point |\n\
         |---|---|---|---|---|---|---|\n",
    );
    for m in &report.methods {
        let g = &m.glossy;
        md.push_str(&format!(
            "| {} | {} | {:.2}% | {:.1}% | {:.2}% | {:.2}% | {:.2}% |\n",
            m.method,
            g.pixels,
            100.0 * g.direct_among_candidates,
            100.0 * g.completeness,
            100.0 * g.points_within_half_column,
            100.0 * g.points.wrong_share(),
            100.0 * g.points.completeness()
        ));
    }
    md.push_str("\n| method | depth with the mirror | direct light | indirect light | column error (0–1 column) |\n|---|---|---|---|---|\n");
    for m in &report.methods {
        let d = m.method.to_lowercase();
        md.push_str(&format!(
            "| {} | ![]({d}/plane_mirror/depth.png) | ![]({d}/plane_mirror/direct.png) | ![]({d}/plane_mirror/indirect.png) | ![]({d}/column_error.png) |\n",
            m.method
        ));
    }
    md.push_str("\nEach scan's points, depth and column maps are in `<method>/<scene>/` (`points.ply` opens in MeshLab, CloudCompare, Open3D).\n");
    md
}
