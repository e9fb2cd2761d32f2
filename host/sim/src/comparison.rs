//! The paper's comparison on simulated scenes (its Fig. 9 metrics), as `fsm demo` runs it and
//! the workspace's scan tests use it: render a capture, decode it with the host's pipeline and
//! the calibration's column limits, triangulate, select, and score against the ground truth.
//!
//! [`scan_capture`] is the one path from a simulated capture to a [`Surface`]; [`run`] scans
//! `plane_mirror`, `plane_mirror_covered`, `sphere_mirror` and `vgroove_glossy` with every method
//! of [`Plans`] and
//! writes each scan's outputs, [`markdown`] and [`html`] turn the [`Report`] into `report.md`
//! and `report.html` (one document, two renderers: `document.rs`).

mod document;

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use fsm_core::{
    CodeEnsemblePlan, GroupCount, LineScanPlan, MicroPhaseShiftPlan, PhaseShiftPlan, ScanPlan,
};
use fsm_io::image_files::write_png_gray8;
use fsm_io::map_picture::{write_map_png, Palette, Scale};
use fsm_io::outputs::write_file;
use fsm_io::plan_file::MethodPlan;
use fsm_io::{Error, Result};
use fsm_scan::decoded::DecodedImage;
use fsm_scan::metrics::{compare, point_errors, Comparison, PointErrors, Truth};
use fsm_scan::output::{write_scan, ScanSummary, StageSeconds};
use fsm_scan::triangulate::column_limits;
use fsm_scan::{SelectionParams, Surface};
use serde::Serialize;

use document::{Block, Cell, Document, Picture, Table};

use crate::{
    Capture, LightTransport, PixelTruth, Scene, Sensor, SurfaceClass, System, TransportSettings,
};

/// The scenes [`run`] scans, in order: the mirror, the mirror covered (the reference), the
/// sphere with its mirror, the glossy groove.
pub const SCENES: [&str; 4] = [
    "plane_mirror",
    "plane_mirror_covered",
    "sphere_mirror",
    "vgroove_glossy",
];

/// What `fsm demo` says as it starts [`run`] on `system`: `simulating plane_mirror, …,
/// sphere_mirror and vgroove_glossy (320x240 camera)…`. Made here, from [`SCENES`], so that
/// the list cannot drift from what is run.
pub fn announcement(system: &System) -> String {
    let (last, rest) = SCENES.split_last().expect("scenes");
    let (w, h) = (system.width(), system.height());
    format!(
        "simulating {} and {last} ({w}x{h} camera)…",
        rest.join(", ")
    )
}

/// Output points more than this far from the true surface are wrong, mm.
pub const WRONG_BEYOND_MM: f64 = 1.0;

/// The bench's standoff, mm: what the paper's errors are given as a share of.
pub const STANDOFF_MM: f64 = 500.0;

/// One scan of a simulated capture: the surface, the truth of its pixels (row-major, the
/// capture's rows), the decoded candidates and the stages' times.
pub struct Scanned {
    /// The selected points and every pixel's reason for having none.
    pub surface: Surface,
    /// The candidates the selection chose from.
    pub decoded: DecodedImage,
    /// The ground truth of every pixel of the capture's rows.
    pub truth: Vec<PixelTruth>,
    /// How long each stage took.
    pub seconds: StageSeconds,
}

/// Decodes every row of `capture` with `method` and the calibration's column limits,
/// triangulates and selects with `params` (the stages `fsm scan` runs on a real capture): the
/// path of `fsm demo` and of the workspace's scan tests.
pub fn scan_capture(
    capture: &Capture,
    method: &MethodPlan,
    system: &System,
    params: &SelectionParams,
) -> Result<Scanned> {
    let width = capture.width() as usize;
    let rows = capture.rows().start as usize..capture.rows().end as usize;
    let limits = |y: usize| column_limits(&system.calibration, width, y);
    let started = Instant::now();
    let decoded = DecodedImage::decode_rows(
        method,
        width,
        rows,
        capture.bit_depth(),
        Some(&limits),
        |y| capture.row(y as u32).map_err(Error::from),
    )?;
    let decode_seconds = started.elapsed().as_secs_f64();
    let (surface, times) = Surface::reconstruct(&decoded, &system.calibration, params);
    let truth = capture
        .rows()
        .flat_map(|y| (0..width as u32).map(move |x| (x, y)))
        .map(|(x, y)| {
            capture.ground_truth().pixel(x, y).copied().ok_or_else(|| {
                Error::Usage(format!(
                    "simulation: no truth for the rendered pixel ({x}, {y})"
                ))
            })
        })
        .collect::<Result<_>>()?;
    Ok(Scanned {
        surface,
        decoded,
        truth,
        seconds: StageSeconds {
            decode: decode_seconds,
            triangulate: times.triangulate_seconds,
            select: times.select_seconds,
        },
    })
}

/// The true surface point of every pixel, and which pixels are lit directly (away from edges).
pub fn truth_points(truth: &[PixelTruth]) -> (Vec<[f64; 3]>, Vec<bool>) {
    (
        truth.iter().map(|t| t.point_mm).collect(),
        truth.iter().map(PixelTruth::is_lit_directly).collect(),
    )
}

/// One method's entry of `report.json`.
#[derive(Serialize, Clone, Debug)]
pub struct MethodReport {
    /// The method's name in the tables (`BFSM`, `EFSM`, `PS`, …).
    pub method: &'static str,
    /// Patterns shown (reference frames not counted).
    pub patterns: usize,
    /// The paper's Fig. 9 figures on `plane_mirror` against `plane_mirror_covered`.
    pub figures: Comparison,
    /// Output points on `plane_mirror` against the true surface points.
    pub points: PointErrors,
    /// Ed as a share of the standoff, %.
    pub e_d_percent_of_standoff: f64,
    /// EnoI as a share of the standoff, %.
    pub e_no_i_percent_of_standoff: f64,
    /// EwiI as a share of the standoff, %.
    pub e_wi_i_percent_of_standoff: f64,
    /// The method on `sphere_mirror`.
    pub sphere: SphereFigures,
    /// The method on `vgroove_glossy`.
    pub glossy: GlossyFigures,
    /// Seconds for the method's three scans.
    pub seconds: f64,
}

/// A method on `vgroove_glossy`: rough metal, its direct light under a lobe about 13 times as
/// bright, spread over tens of columns.
#[derive(Serialize, Clone, Copy, Debug)]
pub struct GlossyFigures {
    /// Facet pixels (lit directly, away from edges).
    pub pixels: usize,
    /// Of them, with the direct column among the decoder's candidates (within 0.5 column).
    pub direct_among_candidates: f64,
    /// With a point after the selection.
    pub completeness: f64,
    /// Of the points, whose column is within 0.5 column of the direct one.
    pub points_within_half_column: f64,
    /// Every output point of the scene against the true surface points.
    pub points: PointErrors,
}

/// A method on `sphere_mirror`: a diffuse sphere before a wall, a plane mirror beside them that
/// lights the sphere and shows the wall.
#[derive(Serialize, Clone, Copy, Debug)]
pub struct SphereFigures {
    /// Every output point of the scene against the true surface points.
    pub points: PointErrors,
    /// Pixels whose point a plane mirror found by the scan hides (virtual images).
    pub behind_mirror: usize,
    /// Plane mirrors the scan found.
    pub mirrors: usize,
}

/// `report.json`.
#[derive(Serialize, Clone, Debug)]
pub struct Report {
    /// Camera size `[W, H]`.
    pub camera: [u32; 2],
    /// The bench's standoff, mm.
    pub standoff_mm: f64,
    /// Noise seed.
    pub seed: u64,
    /// Pixels of `plane_mirror` with more than 20% of their light through the mirror.
    pub interreflection_pixels: usize,
    /// One entry per method, in [`Plans::methods`] order.
    pub methods: Vec<MethodReport>,
}

/// The compared methods' plans: the paper's BFSM and EFSM (cB 64, two groups) decoded by the
/// cosine search; the same captures decoded by CLEAN on the zero-padded DFT (as before the
/// cosine search); phase shift + Gray code; Micro Phase Shifting ("16–15", 17 patterns); Code
/// Ensemble (4 binary codes, 80 patterns); line
/// scanning with as many patterns as BFSM (paper Fig. 13); the EFSM patterns decoded by the
/// paper's local maxima (as a camera can at frame rate). The FSM and line-scan plans state the
/// simulated camera's sensor, as a user states theirs.
pub struct Plans {
    bfsm: ScanPlan,
    efsm: ScanPlan,
    bfsm_clean: ScanPlan,
    efsm_clean: ScanPlan,
    efsm_fast: ScanPlan,
    phase_shift: PhaseShiftPlan,
    micro_phase_shift: MicroPhaseShiftPlan,
    line_scan: LineScanPlan,
    code_ensemble: CodeEnsemblePlan,
}

impl Plans {
    /// The paper's plans, stating the default simulated sensor.
    pub fn paper() -> Plans {
        let sensor = Sensor::default().datasheet();
        let stated = |mut plan: ScanPlan| {
            plan.decoding.sensor = sensor;
            plan
        };
        Plans {
            bfsm: stated(ScanPlan::paper_bfsm()),
            efsm: stated(ScanPlan::paper_efsm(GroupCount::Two)),
            bfsm_clean: stated(ScanPlan::paper_bfsm().with_clean()),
            efsm_clean: stated(ScanPlan::paper_efsm(GroupCount::Two).with_clean()),
            efsm_fast: stated(ScanPlan::paper_efsm(GroupCount::Two).with_local_maxima()),
            phase_shift: PhaseShiftPlan::paper(),
            micro_phase_shift: MicroPhaseShiftPlan::paper(),
            line_scan: LineScanPlan {
                sensor,
                ..LineScanPlan::paper()
            },
            code_ensemble: CodeEnsemblePlan::paper(),
        }
    }

    /// Every method with its name in the tables, in the report's order.
    pub fn methods(&self) -> [(&'static str, MethodPlan); 9] {
        [
            ("BFSM", MethodPlan::Fsm(self.bfsm)),
            ("EFSM", MethodPlan::Fsm(self.efsm)),
            ("BFSM-CLEAN", MethodPlan::Fsm(self.bfsm_clean)),
            ("EFSM-CLEAN", MethodPlan::Fsm(self.efsm_clean)),
            ("PS", MethodPlan::PhaseShift(self.phase_shift)),
            ("MPS", MethodPlan::MicroPhaseShift(self.micro_phase_shift)),
            ("CE", MethodPlan::CodeEnsemble(self.code_ensemble)),
            ("LS", MethodPlan::LineScan(self.line_scan)),
            ("EFSM-fast", MethodPlan::Fsm(self.efsm_fast)),
        ]
    }
}

/// The capture of `method`'s patterns through `transport` by `sensor`.
pub fn capture_of(
    method: &MethodPlan,
    transport: &Arc<LightTransport>,
    system: &System,
    sensor: Sensor,
    seed: u64,
) -> Result<Capture> {
    Capture::new(transport.clone(), method.patterns(), system, sensor, seed).map_err(Error::from)
}

/// The paper's Fig. 9 figures of a scan `with` the mirror against one `without`, over the
/// pixels of `truth` (the scene with the mirror) away from edges: interreflection pixels, the
/// diffuse surface lit directly.
pub fn figures(with: &Surface, without: &Surface, truth: &[PixelTruth]) -> Comparison {
    let direct_column: Vec<f64> = truth.iter().map(|t| t.direct_column).collect();
    let interreflection: Vec<bool> = truth
        .iter()
        .map(|t| t.is_interreflection() && !t.edge)
        .collect();
    let surface: Vec<bool> = truth
        .iter()
        .map(|t| t.class == SurfaceClass::Diffuse && !t.edge && t.direct_column.is_finite())
        .collect();
    let truth = Truth {
        direct_column: &direct_column,
        interreflection: &interreflection,
        surface: &surface,
    };
    compare(with, without, &truth)
}

/// Runs the comparison on the bench `system` and writes each scan's outputs under `out` (a
/// folder that exists): `<method>/<scene>/` as `fsm scan` writes them,
/// `<method>/column_error.png` and `interreflection.png`. `progress` gets one line per method.
pub fn run(system: &System, seed: u64, out: &Path, progress: impl Fn(&str)) -> Result<Report> {
    let (w, h) = (system.width() as usize, system.height() as usize);
    let transport = |name: &str| -> Result<Arc<LightTransport>> {
        let scene = Scene::by_name(name).map_err(Error::from)?;
        LightTransport::compute(&scene, system, &TransportSettings::default())
            .map(Arc::new)
            .map_err(Error::from)
    };
    let [mirror, covered, sphere, glossy] = SCENES;
    let scenes = [(mirror, transport(mirror)?), (covered, transport(covered)?)];
    let sphere = transport(sphere)?;
    let glossy = transport(glossy)?;
    let plans = Plans::paper();
    let params = SelectionParams::for_calibration(&system.calibration);
    let mut truth_pixels: Vec<PixelTruth> = Vec::new();
    let mut reports = Vec::new();
    for (name, method) in plans.methods() {
        let started = Instant::now();
        let mut surfaces = Vec::new();
        for (scene, t) in &scenes {
            let (scanned, _) = scan_and_write(&method, name, scene, t, system, &params, seed, out)?;
            if truth_pixels.is_empty() {
                truth_pixels = scanned.truth;
            }
            surfaces.push(scanned.surface);
        }
        let figures = figures(&surfaces[0], &surfaces[1], &truth_pixels);
        let direct_column: Vec<f64> = truth_pixels.iter().map(|t| t.direct_column).collect();
        let (truth_mm, lit) = truth_points(&truth_pixels);
        let points = point_errors(&surfaces[0].point_mm, &truth_mm, &lit, WRONG_BEYOND_MM);
        write_column_error(
            &out.join(format!("{}/column_error.png", name.to_lowercase())),
            w,
            h,
            &surfaces[0],
            &direct_column,
        )?;
        let sphere = sphere_figures(&method, &sphere, system, &params, seed, out, name)?;
        let glossy = glossy_figures(&method, &glossy, system, &params, seed)?;
        let seconds = started.elapsed().as_secs_f64();
        progress(&format!(
            "{name}: {:.2}% of interreflection pixels within 0.5 column, Ed {:.4} mm, EnoI {:.4} mm, EwiI {:.4} mm ({seconds:.1} s)",
            100.0 * figures.interreflection.within_half_column,
            figures.e_d_mm,
            figures.e_no_i_mm,
            figures.e_wi_i_mm
        ));
        reports.push(MethodReport {
            method: name,
            patterns: method.patterns().pattern_count(),
            figures,
            points,
            e_d_percent_of_standoff: 100.0 * figures.e_d_mm / STANDOFF_MM,
            e_no_i_percent_of_standoff: 100.0 * figures.e_no_i_mm / STANDOFF_MM,
            e_wi_i_percent_of_standoff: 100.0 * figures.e_wi_i_mm / STANDOFF_MM,
            sphere,
            glossy,
            seconds,
        });
    }
    let interreflection: Vec<u8> = truth_pixels
        .iter()
        .map(|t| if t.is_interreflection() { 255 } else { 0 })
        .collect();
    let path = out.join("interreflection.png");
    let mut bytes = Vec::new();
    write_png_gray8(&mut bytes, w as u32, h as u32, &interreflection).map_err(|e| {
        Error::Encode {
            path: path.clone(),
            message: e.0,
        }
    })?;
    write_file(&path, &bytes)?;
    Ok(Report {
        camera: [w as u32, h as u32],
        standoff_mm: STANDOFF_MM,
        seed,
        interreflection_pixels: truth_pixels
            .iter()
            .filter(|t| t.is_interreflection())
            .count(),
        methods: reports,
    })
}

/// Captures `scene` (its `transport`) with `method` (named `name`), scans it and writes the
/// scan's outputs into `out/<name>/<scene>/` as `fsm scan` does.
#[allow(clippy::too_many_arguments)]
fn scan_and_write(
    method: &MethodPlan,
    name: &str,
    scene: &str,
    transport: &Arc<LightTransport>,
    system: &System,
    params: &SelectionParams,
    seed: u64,
    out: &Path,
) -> Result<(Scanned, ScanSummary)> {
    let capture = capture_of(method, transport, system, Sensor::default(), seed)?;
    let scanned = scan_capture(&capture, method, system, params)?;
    let dir = out.join(format!("{}/{scene}", name.to_lowercase()));
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    let summary = ScanSummary::new(
        name,
        method.patterns().fingerprint(),
        &scanned.decoded,
        &scanned.surface,
        params,
        &system.calibration,
        scanned.seconds,
    );
    write_scan(&dir, &scanned.surface, &summary)?;
    Ok((scanned, summary))
}

/// Scans `sphere_mirror` with `method`, writes the scan's outputs into
/// `out/<method>/sphere_mirror/`, and scores its points against the truth.
fn sphere_figures(
    method: &MethodPlan,
    transport: &Arc<LightTransport>,
    system: &System,
    params: &SelectionParams,
    seed: u64,
    out: &Path,
    name: &str,
) -> Result<SphereFigures> {
    let (scanned, summary) = scan_and_write(
        method,
        name,
        "sphere_mirror",
        transport,
        system,
        params,
        seed,
        out,
    )?;
    let (truth_mm, lit) = truth_points(&scanned.truth);
    Ok(SphereFigures {
        points: point_errors(&scanned.surface.point_mm, &truth_mm, &lit, WRONG_BEYOND_MM),
        behind_mirror: summary.no_point.behind_mirror,
        mirrors: scanned.surface.mirrors.len(),
    })
}

/// Scans `vgroove_glossy` with `method` and scores it against the truth.
fn glossy_figures(
    method: &MethodPlan,
    transport: &Arc<LightTransport>,
    system: &System,
    params: &SelectionParams,
    seed: u64,
) -> Result<GlossyFigures> {
    let capture = capture_of(method, transport, system, Sensor::default(), seed)?;
    let Scanned {
        surface,
        decoded,
        truth,
        ..
    } = scan_capture(&capture, method, system, params)?;
    let (truth_mm, lit) = truth_points(&truth);
    let all_points = point_errors(&surface.point_mm, &truth_mm, &lit, WRONG_BEYOND_MM);
    let (mut pixels, mut among, mut points, mut right) = (0usize, 0usize, 0usize, 0usize);
    for (i, (_, candidates)) in decoded.candidates.pixels().enumerate() {
        let t = &truth[i];
        if t.class != SurfaceClass::Glossy || t.edge || !t.direct_column.is_finite() {
            continue;
        }
        pixels += 1;
        let near = |c: f32| (c as f64 - t.direct_column).abs() <= 0.5;
        among += candidates.iter().any(|c| near(c.column)) as usize;
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

/// `|decoded − true column|` per pixel, viridis from 0 to 1 column with its colour bar,
/// black where either is missing.
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
    let scale = Scale {
        low: 0.0,
        high: 1.0,
        unit: "column error",
        palette: Palette::Viridis,
    };
    write_map_png(path, &errors, w as u32, h as u32, &scale)
}

/// `report.md`: the tables of `report` and its pictures (paths relative to the output folder).
pub fn markdown(report: &Report) -> String {
    document(report).markdown()
}

/// `report.html`: the same content as [`markdown`], a self-contained HTML5 page (no scripts,
/// no external resources) whose pictures are relative links into the output folder.
pub fn html(report: &Report) -> String {
    document(report).html()
}

/// Where [`write_reports`] put the report in the folder `out`, as `fsm demo` ends: `report in
/// OUT/report.html (and report.md, report.json beside it)`.
pub fn reports_written(out: &Path) -> String {
    let html = out.join("report.html");
    format!(
        "report in {} (and report.md, report.json beside it)",
        html.display()
    )
}

/// Writes the report into `dir` three ways: `report.json` (for programs), `report.md` and
/// `report.html` ([`markdown`], [`html`]), each whole or not at all.
pub fn write_reports(dir: &Path, report: &Report) -> Result<()> {
    let json =
        serde_json::to_vec_pretty(report).map_err(|e| Error::Usage(format!("report.json: {e}")))?;
    write_file(&dir.join("report.json"), &json)?;
    write_file(&dir.join("report.md"), markdown(report).as_bytes())?;
    write_file(&dir.join("report.html"), html(report).as_bytes())
}

/// The columns every table has of a scene's output points against the truth.
const POINTS_OFF: &str = "points > 1 mm off";
const LIT_RIGHT: &str = "directly lit pixels with a right point";

/// A share as a table cell, in percent with two decimals.
fn percent(share: f64) -> Cell {
    Cell::Text(format!("{:.2}%", 100.0 * share))
}

/// The report's content, once for both formats: prose, tables and pictures.
fn document(report: &Report) -> Document {
    let text = Cell::Text;
    let mut blocks = vec![Block::Paragraph(format!(
        "Simulated bench scanner (baseline 200 mm, standoff {} mm, 768-column projector, {}×{} camera, seed {}). \
         The scene `plane_mirror` is a diffuse plane beside a planar mirror: {} camera pixels receive more than 20% \
         of their light through the mirror (white in `interreflection.png`). `plane_mirror_covered` is the same \
         scene with the mirror blackened. Every method goes through the same path: decode, triangulate every \
         candidate, select the direct one semi-globally. BFSM and EFSM decode with the cosine search (the exact \
         inverse of their full band); `-CLEAN` rows decode the same captures with CLEAN on the zero-padded DFT, \
         `EFSM-fast` with the paper's local maxima. PS is phase shift with Gray codes, MPS Micro Phase Shifting \
         (Gupta & Nayar), CE Code Ensemble (Gupta et al.: four binary codes, each bit with its inverse), LS line scanning (one column per pattern, a Gaussian peak detector). Where a pixel's direct and mirrored columns fall within one \
         footprint of each other modulo the block width (2Δc for the DFT searches), EFSM cannot separate them \
         (paper §IV-C): the decoder flags the pixel aliased and it gets no point, which the completeness column \
         shows.",
        report.standoff_mm, report.camera[0], report.camera[1], report.seed, report.interreflection_pixels
    ))];
    blocks.push(Block::Figure(Picture {
        path: "interreflection.png".into(),
        alt: "plane_mirror's camera pixels, white where more than 20% of the light comes through the mirror".into(),
    }));
    let mut main = Table::new(&[
        "method",
        "patterns",
        "interreflection pixels within 0.5 column",
        "column RMS there (covered)",
        "Ed mm (% standoff)",
        "EnoI mm",
        "EwiI mm",
        "completeness",
        POINTS_OFF,
        LIT_RIGHT,
    ]);
    for m in &report.methods {
        let f = &m.figures;
        main.push(vec![
            text(m.method.to_string()),
            text(m.patterns.to_string()),
            text(format!(
                "{:.2}%",
                100.0 * f.interreflection.within_half_column
            )),
            text(format!(
                "{:.4} ({:.4})",
                f.interreflection.rms_columns, f.interreflection_covered.rms_columns
            )),
            text(format!(
                "{:.4} ({:.4}%)",
                f.e_d_mm, m.e_d_percent_of_standoff
            )),
            text(format!("{:.4}", f.e_no_i_mm)),
            text(format!("{:.4}", f.e_wi_i_mm)),
            text(format!("{:.1}%", 100.0 * f.completeness)),
            percent(m.points.wrong_share()),
            percent(m.points.completeness()),
        ]);
    }
    blocks.push(Block::Table(main));
    if let (Some(b), Some(l)) = (
        report.methods.iter().find(|m| m.method == "BFSM"),
        report.methods.iter().find(|m| m.method == "LS"),
    ) {
        blocks.push(Block::Paragraph(format!(
            "BFSM against line scanning with the same number of patterns ({} and {}; paper Fig. 13, where BFSM \
             is about 10 times as accurate): plane-fit RMS without the mirror {:.4} mm against {:.4} mm ({:.1} \
             times), with it {:.4} mm against {:.4} mm.",
            b.patterns,
            l.patterns,
            b.figures.e_no_i_mm,
            l.figures.e_no_i_mm,
            l.figures.e_no_i_mm / b.figures.e_no_i_mm,
            b.figures.e_wi_i_mm,
            l.figures.e_wi_i_mm,
        )));
    }
    blocks.push(Block::Paragraph(
        "Ed: RMS distance between the points of the scans with and without the mirror. EnoI, EwiI: RMS \
         distance to a fitted plane without and with the mirror (paper Fig. 9). Column RMS: of the pixels within \
         0.5 column of the truth. Points > 1 mm off: the share of all output points more than 1 mm from the \
         true surface point of their pixel (a point on a pixel that sees no surface counts as off); directly lit \
         pixels with a right point: of the pixels the projector lights directly (away from edges), the share \
         whose point is within 1 mm."
            .into(),
    ));
    blocks.push(Block::Heading(
        "A mirror that lights a curved surface and shows the wall: `sphere_mirror`".into(),
    ));
    blocks.push(Block::Paragraph(
        "A diffuse sphere (radius 45 mm) before the wall, a plane mirror beside them. The mirror lights the \
         sphere and the wall in the sphere's shadow, and the pixels that see it see the wall in it: their \
         light triangulates to a virtual wall behind the mirror, consistent with camera and projector alike. \
         The scan finds the mirror from the pixels that see, in it, wall the projector lights directly, and \
         removes what the mirror hides (`docs/scan.md`)."
            .into(),
    ));
    let mut sphere = Table::new(&[
        "method",
        "points",
        POINTS_OFF,
        LIT_RIGHT,
        "mirrors found",
        "virtual images removed",
    ]);
    for m in &report.methods {
        let f = &m.sphere;
        sphere.push(vec![
            text(m.method.to_string()),
            text(f.points.points.to_string()),
            percent(f.points.wrong_share()),
            percent(f.points.completeness()),
            text(f.mirrors.to_string()),
            text(f.behind_mirror.to_string()),
        ]);
    }
    blocks.push(Block::Table(sphere));
    blocks.push(Block::Heading(
        "Glossy interreflection: `vgroove_glossy`".into(),
    ));
    blocks.push(Block::Paragraph(
        "Two rough-metal facets (GGX, roughness 0.2) in a V: the light reflected facet to facet is about 13 \
         times the direct light at the median pixel and spreads over tens of projector columns."
            .into(),
    ));
    let mut glossy = Table::new(&[
        "method",
        "facet pixels",
        "direct column among the candidates",
        "with a point",
        "points within 0.5 column",
        POINTS_OFF,
        LIT_RIGHT,
    ]);
    for m in &report.methods {
        let g = &m.glossy;
        glossy.push(vec![
            text(m.method.to_string()),
            text(g.pixels.to_string()),
            text(format!("{:.2}%", 100.0 * g.direct_among_candidates)),
            text(format!("{:.1}%", 100.0 * g.completeness)),
            text(format!("{:.2}%", 100.0 * g.points_within_half_column)),
            percent(g.points.wrong_share()),
            percent(g.points.completeness()),
        ]);
    }
    blocks.push(Block::Table(glossy));
    // The pictures `run` wrote for each method, with what each shows.
    let views = [
        ("depth with the mirror", "plane_mirror/depth.png"),
        ("depth, sphere_mirror", "sphere_mirror/depth.png"),
        ("direct light", "plane_mirror/direct.png"),
        ("indirect light", "plane_mirror/indirect.png"),
        ("column error (0–1 column)", "column_error.png"),
    ];
    let mut header = vec!["method"];
    header.extend(views.iter().map(|(what, _)| *what));
    let mut pictures = Table::new(&header);
    for m in &report.methods {
        let dir = m.method.to_lowercase();
        let mut row = vec![text(m.method.to_string())];
        row.extend(views.iter().map(|(what, file)| {
            Cell::Picture(Picture {
                path: format!("{dir}/{file}"),
                alt: format!("{}: {what}", m.method),
            })
        }));
        pictures.push(row);
    }
    blocks.push(Block::Table(pictures));
    blocks.push(Block::Paragraph(
        "Each scan's points, depth and column maps are in `<method>/<scene>/` (`points.ply` opens in \
         MeshLab, CloudCompare, Open3D)."
            .into(),
    ));
    Document {
        title: format!(
            "fsm demo: a mirror's interreflection, {} methods",
            report.methods.len()
        ),
        blocks,
    }
}
