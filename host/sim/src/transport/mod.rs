//! Light transport of a scene: for every camera pixel, the projector columns whose light
//! reaches it, with their weights, plus pattern-independent ambient light.
//!
//! Patterns vary along projector columns only (SPEC §1), so whatever the light does between the
//! projector and a pixel — direct, through mirrors, between diffuse or glossy facets — the
//! pixel's signal under any frame is `ambient + Σ_j w_j·P(j)` with `P(j)` the emitted value of
//! column `j`. The weights are computed once per scene:
//!
//! - **direct and mirrored light** over the pixel's footprint: `s × s` rays per pixel
//!   (multi-jittered over the pixel square, a pattern of its own in every pixel, point-symmetric
//!   about its centre: [`footprint`]), each followed through camera-side mirrors to a diffuse or
//!   glossy point, where the projector's light arrives directly and through each mirror and is
//!   reflected by the point's BRDF ([`paths`]); each arrival is spread over the columns by the
//!   projector blur ([`BlurKernel`]);
//! - **interreflection** from the scene's diffuse or glossy emitters ([`gather`]), integrated
//!   once per pixel and surface at the footprint's sample nearest the pixel centre.
//!
//! Rendering a frame is then a sparse dot product per pixel ([`crate::capture`]).

pub mod footprint;
pub mod gather;
pub mod paths;

use std::ops::Range;

use fsm_io::progress::Progress;
use nalgebra::{Point2, Point3};
use rayon::prelude::*;

use crate::radiometry::BlurKernel;
use crate::scene::brdf::AmbientReflectance;
use crate::scene::{Material, Scene};
use crate::system::System;
use crate::truth::{GroundTruth, PixelTruth, SurfaceClass};
use crate::SimError;

use gather::{Emitter, GatherSettings};
use paths::{arrivals, trace_to_diffuse, Arrival};

/// How a pixel's light got there.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PathKind {
    /// Projector → the surface the pixel sees → camera.
    Direct,
    /// Through at least one mirror (on the projector's side, the camera's side, or both).
    Specular,
    /// Through one bounce on another diffuse or glossy surface (one of the scene's emitters:
    /// [`gather`]).
    Diffuse,
}

impl PathKind {
    const ALL: [PathKind; 3] = [PathKind::Direct, PathKind::Specular, PathKind::Diffuse];

    fn index(self) -> usize {
        self as usize
    }
}

/// Resolution of the transport computation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransportSettings {
    /// Rays per pixel along each axis (`s × s` per pixel, placed by [`footprint::offsets`]).
    pub supersampling: u32,
    /// Most mirror reflections followed from the camera.
    pub max_mirror_bounces: u32,
    /// Interreflection integration.
    pub gather: GatherSettings,
}

impl Default for TransportSettings {
    fn default() -> Self {
        TransportSettings {
            supersampling: 4,
            max_mirror_bounces: 4,
            gather: GatherSettings::default(),
        }
    }
}

/// A run of consecutive columns with weights.
#[derive(Clone, Copy, Debug)]
struct Span {
    kind: PathKind,
    first_column: u32,
    offset: u32,
    len: u32,
}

/// Transport of one camera row.
#[derive(Clone, Debug, Default)]
struct RowTransport {
    ambient: Vec<f32>,
    /// Spans of pixel `x`: `spans[pixel_start[x]..pixel_start[x + 1]]`.
    pixel_start: Vec<u32>,
    spans: Vec<Span>,
    weights: Vec<f32>,
}

/// One span of a pixel's light, for inspection.
#[derive(Clone, Copy, Debug)]
pub struct SpanView<'a> {
    /// How the light got there.
    pub kind: PathKind,
    /// Column of `weights[0]`.
    pub first_column: u32,
    /// Reference-white signal per column under a full-on frame.
    pub weights: &'a [f32],
}

impl SpanView<'_> {
    /// Sum of the weights.
    pub fn total(&self) -> f64 {
        self.weights.iter().map(|&w| w as f64).sum()
    }

    /// Light-weighted column.
    pub fn centroid(&self) -> f64 {
        let (s, m) = self
            .weights
            .iter()
            .enumerate()
            .fold((0.0, 0.0), |(s, m), (i, &w)| {
                (
                    s + w as f64,
                    m + w as f64 * (self.first_column as f64 + i as f64),
                )
            });
        m / s
    }
}

/// The light transport of a scene seen by a system, for a band of camera rows, and its ground
/// truth.
#[derive(Clone, Debug)]
pub struct LightTransport {
    width: u32,
    height: u32,
    columns: u32,
    first_row: u32,
    rows: Vec<RowTransport>,
    truth: GroundTruth,
}

/// Gap (zero columns) that splits a kind's light into separate spans.
const SPAN_GAP_COLUMNS: usize = 8;

impl LightTransport {
    /// Computes the transport of every camera row.
    pub fn compute(
        scene: &Scene,
        system: &System,
        settings: &TransportSettings,
    ) -> Result<LightTransport, SimError> {
        Self::compute_rows(scene, system, settings, 0..system.height())
    }

    /// Computes the transport of the camera rows `rows` only (quick checks on a band).
    pub fn compute_rows(
        scene: &Scene,
        system: &System,
        settings: &TransportSettings,
        rows: Range<u32>,
    ) -> Result<LightTransport, SimError> {
        Self::compute_rows_reporting(scene, system, settings, rows, &Progress::hidden())
    }

    /// [`LightTransport::compute_rows`], reporting each row done to `progress` (a stage
    /// "light transport" of one step per row): at a few megapixels this takes minutes.
    pub fn compute_rows_reporting(
        scene: &Scene,
        system: &System,
        settings: &TransportSettings,
        rows: Range<u32>,
        progress: &Progress,
    ) -> Result<LightTransport, SimError> {
        system.validate().map_err(SimError::System)?;
        if rows.is_empty() || rows.end > system.height() {
            return Err(SimError::Rows {
                rows,
                height: system.height(),
            });
        }
        if settings.supersampling == 0 || settings.supersampling > 64 {
            return Err(SimError::Settings(format!(
                "supersampling = {}: must be in 1..=64",
                settings.supersampling
            )));
        }
        for &e in &scene.diffuse_emitters {
            if e >= scene.surfaces.len() {
                return Err(SimError::Settings(format!(
                    "scene {}: diffuse emitter {e} is not a surface",
                    scene.name
                )));
            }
        }
        let cal = &system.calibration;
        let emitters: Vec<Emitter> = scene
            .diffuse_emitters
            .iter()
            .filter_map(|&i| {
                Emitter::build(
                    scene,
                    i,
                    cal,
                    system.reference_distance_mm,
                    &settings.gather,
                )
            })
            .collect();
        let ctx = Context {
            scene,
            system,
            settings,
            blur: BlurKernel::new(system.blur_sigma_columns),
            emitters,
            ambient_reflectance: scene
                .surfaces
                .iter()
                .map(|s| AmbientReflectance::of(&s.material))
                .collect(),
        };
        progress.start(rows.len() as u64, "light transport");
        let computed: Vec<(RowTransport, Vec<PixelTruth>)> = rows
            .clone()
            .into_par_iter()
            .map(|y| {
                let row = ctx.row(y);
                progress.advance(1);
                row
            })
            .collect();
        progress.finish();
        let mut truth = Vec::with_capacity(computed.len() * system.width() as usize);
        let mut out = Vec::with_capacity(computed.len());
        for (row, t) in computed {
            out.push(row);
            truth.extend(t);
        }
        Ok(LightTransport {
            width: system.width(),
            height: system.height(),
            columns: system.projector_columns(),
            first_row: rows.start,
            rows: out,
            truth: GroundTruth {
                width: system.width(),
                first_row: rows.start,
                pixels: truth,
            },
        })
    }

    /// Camera image width.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Camera image height (of the whole image, whatever rows were computed).
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Projector columns.
    pub fn columns(&self) -> u32 {
        self.columns
    }

    /// The camera rows this transport covers.
    pub fn rows(&self) -> Range<u32> {
        self.first_row..self.first_row + self.rows.len() as u32
    }

    /// Ground truth of the covered rows.
    pub fn ground_truth(&self) -> &GroundTruth {
        &self.truth
    }

    fn row(&self, y: u32) -> Option<&RowTransport> {
        y.checked_sub(self.first_row)
            .and_then(|i| self.rows.get(i as usize))
    }

    /// Ambient signal of pixel `(x, y)`, reference whites.
    pub fn ambient(&self, x: u32, y: u32) -> Option<f32> {
        self.row(y)?.ambient.get(x as usize).copied()
    }

    /// The spans of light of pixel `(x, y)`.
    pub fn spans(&self, x: u32, y: u32) -> impl Iterator<Item = SpanView<'_>> + '_ {
        let row = self.row(y).filter(|_| x < self.width);
        let range = row.map_or(0..0, |r| {
            r.pixel_start[x as usize] as usize..r.pixel_start[x as usize + 1] as usize
        });
        range.map(move |i| {
            let r = row.expect("non-empty range has a row");
            let s = r.spans[i];
            SpanView {
                kind: s.kind,
                first_column: s.first_column,
                weights: &r.weights[s.offset as usize..(s.offset + s.len) as usize],
            }
        })
    }

    /// Signal of every pixel of row `y` under a frame whose emitted column values are
    /// `emitted` (length `cmax`), reference whites, into `out` (length `W`).
    pub(crate) fn shade_row(&self, y: u32, emitted: &[f32], out: &mut [f32]) {
        let row = self.row(y).expect("caller checked the row");
        for (x, o) in out.iter_mut().enumerate() {
            let mut v = row.ambient[x];
            for s in &row.spans[row.pixel_start[x] as usize..row.pixel_start[x + 1] as usize] {
                let w = &row.weights[s.offset as usize..(s.offset + s.len) as usize];
                let e = &emitted[s.first_column as usize..s.first_column as usize + w.len()];
                v += dot(w, e);
            }
            *o = v;
        }
    }

    /// Number of stored (column, weight) pairs, for reports.
    pub fn weight_count(&self) -> usize {
        self.rows.iter().map(|r| r.weights.len()).sum()
    }
}

/// `Σ a_i·b_i` in 8 lanes (vectorises; the order is fixed, so results are reproducible).
fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut lanes = [0.0f32; 8];
    let ca = a.chunks_exact(8);
    let cb = b.chunks_exact(8);
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            lanes[k] += x[k] * y[k];
        }
    }
    let mut tail = 0.0;
    for (x, y) in ra.iter().zip(rb) {
        tail += x * y;
    }
    lanes.iter().sum::<f32>() + tail
}

struct Context<'a> {
    scene: &'a Scene,
    system: &'a System,
    settings: &'a TransportSettings,
    blur: BlurKernel,
    emitters: Vec<Emitter>,
    /// Per surface: how much of the ambient light it sends the camera.
    ambient_reflectance: Vec<AmbientReflectance>,
}

/// Per-kind dense accumulators over the projector columns, reused from pixel to pixel.
struct Accumulators {
    acc: [Vec<f32>; 3],
    touched: [Option<(usize, usize)>; 3],
    profile: Vec<f64>,
    arrivals: Vec<Arrival>,
}

impl Accumulators {
    fn new(columns: usize) -> Self {
        Accumulators {
            acc: [vec![0.0; columns], vec![0.0; columns], vec![0.0; columns]],
            touched: [None; 3],
            profile: vec![0.0; columns],
            arrivals: Vec::new(),
        }
    }

    fn touch(&mut self, kind: PathKind, range: Option<(usize, usize)>) {
        let Some((lo, hi)) = range else { return };
        let t = &mut self.touched[kind.index()];
        *t = Some(match *t {
            Some((a, b)) => (a.min(lo), b.max(hi)),
            None => (lo, hi),
        });
    }

    /// Moves the accumulated light of the pixel into `row` as spans; returns the totals.
    fn flush(&mut self, row: &mut RowTransport) -> [f64; 3] {
        let mut totals = [0.0; 3];
        for kind in PathKind::ALL {
            let k = kind.index();
            let Some((lo, hi)) = self.touched[k].take() else {
                continue;
            };
            let acc = &mut self.acc[k];
            let mut j = lo;
            while j <= hi {
                if acc[j] == 0.0 {
                    j += 1;
                    continue;
                }
                // A span runs until SPAN_GAP_COLUMNS zeros in a row.
                let start = j;
                let mut end = j;
                let mut zeros = 0;
                while j <= hi && zeros < SPAN_GAP_COLUMNS {
                    if acc[j] == 0.0 {
                        zeros += 1;
                    } else {
                        zeros = 0;
                        end = j;
                    }
                    j += 1;
                }
                let offset = row.weights.len() as u32;
                row.weights.extend_from_slice(&acc[start..=end]);
                totals[k] += acc[start..=end].iter().map(|&w| w as f64).sum::<f64>();
                row.spans.push(Span {
                    kind,
                    first_column: start as u32,
                    offset,
                    len: (end - start + 1) as u32,
                });
            }
            acc[lo..=hi].fill(0.0);
        }
        totals
    }
}

/// A footprint sample's diffuse or glossy point, grouped by surface for the gather.
struct GatherGroup {
    surface: usize,
    bounces: u32,
    count: u32,
    /// Where the group's gather is integrated: (distance² to the pixel centre, point).
    nearest: (f64, paths::DiffusePoint),
}

impl Context<'_> {
    fn row(&self, y: u32) -> (RowTransport, Vec<PixelTruth>) {
        let system = self.system;
        let width = system.width() as usize;
        let columns = system.projector_columns() as usize;
        let mut acc = Accumulators::new(columns);
        let mut row = RowTransport {
            ambient: Vec::with_capacity(width),
            pixel_start: Vec::with_capacity(width + 1),
            ..RowTransport::default()
        };
        let mut truth = Vec::with_capacity(width);
        row.pixel_start.push(0);
        for x in 0..width {
            let t = self.pixel(x as u32, y, &mut acc, &mut row);
            truth.push(t);
            row.pixel_start.push(row.spans.len() as u32);
        }
        (row, truth)
    }

    fn pixel(&self, x: u32, y: u32, acc: &mut Accumulators, row: &mut RowTransport) -> PixelTruth {
        let cal = &self.system.calibration;
        let s = self.settings.supersampling;
        let sample_weight = 1.0 / (s * s) as f64;
        let origin = Point3::origin();
        let reach = self.blur.reach();
        let mut ambient = 0.0;
        let mut groups: Vec<GatherGroup> = Vec::new();
        // Edge detection: what the samples saw first and whether they were lit directly.
        let mut first_surfaces: Vec<Option<usize>> = Vec::with_capacity((s * s) as usize);
        let mut lit_directly = (false, false);
        // The gather of the surface seen at the pixel centre is integrated at the
        // centre's point; other surfaces of the footprint at their sample nearest the centre.
        if !self.emitters.is_empty() {
            if let Ok(dir) = cal.camera.ray(Point2::new(x as f64, y as f64)) {
                if let Some(at) =
                    trace_to_diffuse(self.scene, origin, dir, self.settings.max_mirror_bounces)
                {
                    groups.push(GatherGroup {
                        surface: at.surface,
                        bounces: at.bounces,
                        count: 0,
                        nearest: (-1.0, at),
                    });
                }
            }
        }
        for (dx, dy) in footprint::offsets(x, y, s) {
            let pixel = Point2::new(x as f64 + dx, y as f64 + dy);
            let Ok(dir) = cal.camera.ray(pixel) else {
                first_surfaces.push(None);
                continue;
            };
            let Some(at) =
                trace_to_diffuse(self.scene, origin, dir, self.settings.max_mirror_bounces)
            else {
                first_surfaces.push(None);
                continue;
            };
            first_surfaces.push(Some(at.surface + 1000 * at.bounces as usize));
            let reflectance = self.ambient_reflectance[at.surface].at(at.normal.dot(&at.view));
            ambient += sample_weight * at.throughput * reflectance * self.scene.ambient;
            arrivals(
                self.scene,
                cal,
                self.system.reference_distance_mm,
                reach,
                &at,
                &mut acc.arrivals,
            );
            let mut direct = false;
            for k in 0..acc.arrivals.len() {
                let a = acc.arrivals[k];
                let kind = if a.via_mirror || at.bounces > 0 {
                    PathKind::Specular
                } else {
                    direct = true;
                    PathKind::Direct
                };
                let r = self.blur.deposit(
                    &mut acc.acc[kind.index()],
                    a.column,
                    a.signal * sample_weight,
                );
                acc.touch(kind, r);
            }
            if at.bounces == 0 {
                if direct {
                    lit_directly.0 = true;
                } else {
                    lit_directly.1 = true;
                }
            }
            if !self.emitters.is_empty() {
                let d2 = dx * dx + dy * dy;
                match groups
                    .iter_mut()
                    .find(|g| g.surface == at.surface && g.bounces == at.bounces)
                {
                    Some(g) => {
                        g.count += 1;
                        if d2 < g.nearest.0 {
                            g.nearest = (d2, at);
                        }
                    }
                    None => groups.push(GatherGroup {
                        surface: at.surface,
                        bounces: at.bounces,
                        count: 1,
                        nearest: (d2, at),
                    }),
                }
            }
        }
        if !groups.is_empty() {
            self.gather(&groups, sample_weight, acc);
        }
        let totals = acc.flush(row);
        row.ambient.push(ambient as f32);
        let mut truth = self.centre_truth(x, y);
        truth.direct = totals[PathKind::Direct.index()] as f32;
        truth.indirect =
            (totals[PathKind::Specular.index()] + totals[PathKind::Diffuse.index()]) as f32;
        let first = first_surfaces.first().copied().flatten();
        truth.edge =
            first_surfaces.iter().any(|&f| f != first) || (lit_directly.0 && lit_directly.1);
        truth
    }

    /// Interreflected light from every emitter, once per (surface, bounces) group of the
    /// footprint.
    fn gather(&self, groups: &[GatherGroup], sample_weight: f64, acc: &mut Accumulators) {
        let columns = acc.profile.len();
        let mut any = false;
        for g in groups {
            let at = &g.nearest.1;
            for e in &self.emitters {
                let total = e.gather(
                    self.scene,
                    at,
                    at.throughput * sample_weight * g.count as f64,
                    &self.settings.gather,
                    &mut acc.profile,
                );
                any |= total > 0.0;
            }
        }
        if !any {
            acc.profile.fill(0.0);
            return;
        }
        // Blur the gathered column profile with the projector's optics.
        let k = PathKind::Diffuse.index();
        for c in 0..columns {
            let v = acc.profile[c];
            if v == 0.0 {
                continue;
            }
            let r = self.blur.deposit(&mut acc.acc[k], c as f64, v);
            acc.touch(PathKind::Diffuse, r);
        }
        acc.profile.fill(0.0);
    }

    /// Truth at the pixel centre (the light totals are filled in by the caller).
    fn centre_truth(&self, x: u32, y: u32) -> PixelTruth {
        let cal = &self.system.calibration;
        let mut t = PixelTruth {
            point_mm: [f64::NAN; 3],
            surface: None,
            class: SurfaceClass::Background,
            direct_column: f64::NAN,
            direct: 0.0,
            indirect: 0.0,
            edge: false,
        };
        let Ok(dir) = cal.camera.ray(Point2::new(x as f64, y as f64)) else {
            return t;
        };
        let origin = Point3::origin();
        let Some(hit) = self.scene.nearest_hit(&origin, &dir, f64::INFINITY, None) else {
            return t;
        };
        t.point_mm = [hit.point.x, hit.point.y, hit.point.z];
        t.surface = Some(hit.surface as u16);
        let front = hit.normal.dot(&dir) < 0.0;
        t.class = match self.scene.surfaces[hit.surface].material {
            Material::Diffuse { .. } => SurfaceClass::Diffuse,
            Material::Glossy { .. } => SurfaceClass::Glossy,
            Material::Mirror { reflectance } if front && reflectance > 0.0 => SurfaceClass::Mirror,
            _ => SurfaceClass::Black,
        };
        if matches!(t.class, SurfaceClass::Diffuse | SurfaceClass::Glossy) {
            // Lit directly at the centre point? Then its projector column is the truth.
            if let Some(at) = trace_to_diffuse(self.scene, origin, dir, 0) {
                let mut arr = Vec::new();
                arrivals(
                    self.scene,
                    cal,
                    self.system.reference_distance_mm,
                    0.0,
                    &at,
                    &mut arr,
                );
                if let Some(a) = arr.iter().find(|a| !a.via_mirror) {
                    t.direct_column = a.column;
                }
            }
        }
        t
    }
}
