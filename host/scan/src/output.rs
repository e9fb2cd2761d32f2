//! What `fsm scan` writes: `points.ply` (binary little-endian: x y z mm, intensity, quality,
//! pixel x y), `depth.tiff`, `column.tiff` and `quality.tiff` (32-bit float, NaN where none),
//! `direct.png` and `indirect.png` (eqs. 12–13, one shared scale), `depth.png` (coloured
//! preview), each picture with a colour bar labelled in its unit (`fsm_io::map_picture`),
//! `no_point.tiff` (8-bit: 0 where a pixel has a point, else its reason's
//! [`NoPoint::code`]) with `no_point.png` (the same in colours, with a legend), and
//! `summary.json` (counts, pixels without a point by reason, timings, parameters).

use std::path::Path;

use fsm_io::image_files::{write_tiff_f32, write_tiff_gray8};
use fsm_io::map_picture::{write_category_png, write_map_png, Category, Palette, Scale};
use fsm_io::outputs::{write_file, StagedFile};
use fsm_io::{Error, Result};
use serde::Serialize;

use crate::ply::write_ply;
use crate::surface::{NoPoint, NoPointCounts, Surface};

/// The contents of `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct ScanSummary {
    /// `BFSM`, `EFSM` or `PS`.
    pub method: String,
    /// Fingerprint of the plan, hexadecimal.
    pub plan_fingerprint: String,
    /// Image size.
    pub width: usize,
    /// Image size.
    pub height: usize,
    /// Candidates the decoder reported.
    pub candidates: u64,
    /// EFSM pixels the decoder flagged aliased (two lights unresolved modulo the block width).
    pub aliased_pixels: u64,
    /// Pixels the decoder flagged unresolved (two touching lights it could not split).
    pub unresolved_pixels: u64,
    /// Candidates that triangulated inside the measurement volume.
    pub candidates_in_volume: usize,
    /// Pixels with a point.
    pub points: usize,
    /// Pixels without a point, by reason.
    pub no_point: NoPointCounts,
    /// The plane mirrors found, whose virtual images were removed (`no_point.behind_mirror`).
    pub mirrors: Vec<crate::mirror::Mirror>,
    /// Rows the capture held no valid samples for (dump records skipped with
    /// `--skip-bad-rows`): their pixels count as `no_point.no_data`.
    pub rows_without_data: Vec<u32>,
    /// The dump records skipped, each as its error (file, record, offset, row).
    pub bad_records: Vec<String>,
    /// Seconds spent decoding.
    pub decode_seconds: f64,
    /// Seconds spent triangulating.
    pub triangulate_seconds: f64,
    /// Seconds spent selecting.
    pub select_seconds: f64,
    /// The selection's parameters.
    pub selection: SelectionSummary,
    /// CRC-32 checksum of the calibration used (`fsm_geometry` file checksum).
    pub calibration_checksum: String,
    /// The points against a known truth (`fsm scan --truth`), when one was given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth: Option<TruthSummary>,
}

/// How long each stage of a scan took, seconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct StageSeconds {
    /// Decoding.
    pub decode: f64,
    /// Triangulating every candidate.
    pub triangulate: f64,
    /// Selecting.
    pub select: f64,
}

impl ScanSummary {
    /// The summary of a scan of `decoded` into `surface` with `params` and `calibration`, the
    /// decoder's counts taken from its pixels: `method` names the plan (`BFSM`, `EFSM`, `PS`,
    /// or a comparison's label). No rows without data, no bad records, no truth: a caller that
    /// has them sets them.
    pub fn new(
        method: &str,
        plan_fingerprint: u64,
        decoded: &crate::decoded::DecodedImage,
        surface: &Surface,
        params: &crate::SelectionParams,
        calibration: &fsm_geometry::Calibration,
        seconds: StageSeconds,
    ) -> ScanSummary {
        let pixels = &decoded.candidates;
        let flagged = |flag| pixels.count_flagged(flag) as u64;
        ScanSummary {
            method: method.to_string(),
            plan_fingerprint: format!("{plan_fingerprint:016x}"),
            width: surface.width,
            height: surface.height,
            candidates: pixels.candidate_count() as u64,
            aliased_pixels: flagged(fsm_core::PixelFlags::ALIASED),
            unresolved_pixels: flagged(fsm_core::PixelFlags::UNRESOLVED),
            candidates_in_volume: surface.candidates,
            points: surface.points(),
            no_point: surface.no_point_counts(),
            mirrors: surface.mirrors.clone(),
            rows_without_data: Vec::new(),
            bad_records: Vec::new(),
            decode_seconds: seconds.decode,
            triangulate_seconds: seconds.triangulate,
            select_seconds: seconds.select,
            selection: SelectionSummary::of(params),
            calibration_checksum: format!("{:08x}", calibration.checksum()),
            truth: None,
        }
    }
}

/// The points against the truth of a simulated capture, as written to `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct TruthSummary {
    /// The truth folder.
    pub folder: String,
    /// The counts.
    #[serde(flatten)]
    pub errors: crate::metrics::PointErrors,
    /// `wrong / points`.
    pub wrong_share: f64,
    /// `lit_right / lit`: the directly lit pixels that kept a right point.
    pub completeness: f64,
}

/// The selection parameters as written to `summary.json`.
#[derive(Clone, Debug, Serialize)]
pub struct SelectionSummary {
    /// 8 or 16.
    pub paths: u8,
    /// `ε`, mm.
    pub epsilon_mm: f32,
    /// `β`, per mm.
    pub beta_per_mm: f32,
    /// Whether aliased and unresolved pixels were given no point.
    pub drop_aliased: bool,
    /// Whether the points the projector cannot light directly were dropped.
    pub drop_fictitious: bool,
    /// Whether the points of pixels that straddle a depth edge were dropped.
    pub drop_edges: bool,
    /// The least quality a point was given (signal-to-noise ratio).
    pub min_quality: f32,
}

impl SelectionSummary {
    /// The parameters `params` as written to `summary.json`.
    pub fn of(params: &crate::SelectionParams) -> SelectionSummary {
        SelectionSummary {
            paths: params.paths.count(),
            epsilon_mm: params.epsilon_mm,
            beta_per_mm: params.beta_per_mm,
            drop_aliased: params.drop_aliased,
            drop_fictitious: params.drop_fictitious,
            drop_edges: params.drop_edges,
            min_quality: params.min_quality,
        }
    }
}

/// Writes every output of a scan into the folder `dir` (a staging folder: the caller commits
/// it whole).
pub fn write_scan(dir: &Path, surface: &Surface, summary: &ScanSummary) -> Result<()> {
    let (w, h) = (surface.width as u32, surface.height as u32);
    let encode = |path: &Path| {
        let path = path.to_path_buf();
        move |e: fsm_io::image_files::ImageError| Error::Encode {
            path: path.clone(),
            message: e.0,
        }
    };
    let ply = dir.join("points.ply");
    let mut file = StagedFile::create(&ply)?;
    write_ply(file.writer(), &surface.ply_points()).map_err(|e| Error::io(&ply, e))?;
    file.commit()?;
    let depth = surface.depth_mm();
    let column: Vec<f32> = surface
        .column
        .iter()
        .map(|c| c.unwrap_or(f32::NAN))
        .collect();
    for (name, values) in [
        ("depth.tiff", &depth),
        ("column.tiff", &column),
        ("quality.tiff", &surface.quality),
    ] {
        let path = dir.join(name);
        let mut bytes = Vec::new();
        write_tiff_f32(&mut std::io::Cursor::new(&mut bytes), w, h, values)
            .map_err(encode(&path))?;
        write_file(&path, &bytes)?;
    }
    // Direct and indirect light on one scale (the 99.5th percentile of the direct light).
    let scale = percentile(&surface.direct, 0.995).max(f32::MIN_POSITIVE);
    for (name, values) in [
        ("direct.png", &surface.direct),
        ("indirect.png", &surface.indirect),
    ] {
        let light = Scale {
            low: 0.0,
            high: scale,
            unit: "DN",
            palette: Palette::Grey,
        };
        write_map_png(&dir.join(name), values, w, h, &light)?;
    }
    // Depth over the surface's 1st to 99th percentile: a few outliers do not flatten it.
    let (near, far) = (percentile(&depth, 0.01), percentile(&depth, 0.99));
    let depth_scale = Scale {
        low: near,
        high: far.max(near + 1e-3),
        unit: "depth, mm",
        palette: Palette::Viridis,
    };
    write_map_png(&dir.join("depth.png"), &depth, w, h, &depth_scale)?;
    // Why each pixel has no point: codes for programs, colours for people.
    let codes = surface.no_point_codes();
    let path = dir.join("no_point.tiff");
    let mut bytes = Vec::new();
    write_tiff_gray8(&mut std::io::Cursor::new(&mut bytes), w, h, &codes).map_err(encode(&path))?;
    write_file(&path, &bytes)?;
    write_category_png(
        &dir.join("no_point.png"),
        &codes,
        w,
        h,
        &no_point_legend(&codes),
    )?;
    let json = serde_json::to_vec_pretty(summary)
        .map_err(|e| Error::Usage(format!("summary.json: {e}")))?;
    write_file(&dir.join("summary.json"), &json)
}

/// The colour of a pixel with a point, then of each reason ([`NoPoint::ALL`]) in
/// `no_point.png`.
const NO_POINT_COLOURS: [[u8; 3]; 12] = [
    [190, 190, 190],
    [0, 0, 0],
    [70, 70, 70],
    [255, 127, 14],
    [188, 189, 34],
    [140, 86, 75],
    [227, 119, 194],
    [148, 103, 189],
    [214, 39, 40],
    [31, 119, 180],
    [44, 160, 44],
    [23, 190, 207],
];

/// The legend of `no_point.png` for the pixels' `codes` ([`Surface::no_point_codes`]): the
/// pixels with a point, then each reason, with its count.
fn no_point_legend(codes: &[u8]) -> Vec<Category> {
    let mut counts = [0usize; 12];
    for &code in codes {
        counts[code as usize] += 1;
    }
    let names = std::iter::once("point").chain(NoPoint::ALL.iter().map(|r| r.name()));
    names
        .zip(NO_POINT_COLOURS)
        .zip(counts)
        .map(|((name, colour), count)| Category {
            label: format!("{name} {count}"),
            colour,
        })
        .collect()
}

/// The `q` quantile of the finite values (0 if there are none).
pub fn percentile(values: &[f32], q: f64) -> f32 {
    let mut finite: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return 0.0;
    }
    let k = ((finite.len() - 1) as f64 * q).round() as usize;
    let (_, v, _) = finite.select_nth_unstable_by(k, f32::total_cmp);
    *v
}
