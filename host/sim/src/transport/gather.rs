//! One-bounce interreflection: the projector's light that a diffuse or glossy rectangle (an
//! emitter, e.g. a facet of the V-groove) reflects onto another diffuse or glossy point,
//! integrated numerically over the emitter.
//!
//! A point `Y` of the emitter lit directly with irradiance `E(Y)` (reference whites) has
//! radiance `g_Y·E(Y)·E_ref/π` towards `X`, with `g_Y = π·f_r` its BRDF relative to a white
//! Lambertian surface ([`Material::relative_brdf`]) from the projector to `X`; the receiver
//! point `X` then sends the camera
//! `π ∫ f_X(X→Y, X→camera) · g_Y(Y→O, Y→X) · E(Y) · cos θ_X cos θ_Y / r² dA` reference whites,
//! and that light carries the column `u(Y)` of each emitting point. For two Lambertian surfaces
//! this is `(ρ_X/π) ∫ ρ_Y E(Y) cos θ_X cos θ_Y / r² dA`; a glossy end weights the integral by
//! its lobe, evaluated per cell at both ends of the bounce.
//!
//! The emitter is cut into cells one projector column wide across its columns and `cell_mm`
//! long along them; cells are merged pairwise along the columns into a hierarchy, and a
//! receiver point uses the coarsest cells whose length is below `ratio ×` their distance
//! (midpoint rule; cells too close to the receiver — near a concave corner, where the kernel is
//! singular — are subdivided on the fly). `ratio` is `distance_ratio` between Lambertian
//! surfaces, whose kernel varies with the distance only; with a glossy end it is at most
//! `lobe_ratio × α`, so that a cell spans a fraction of the lobe's angular width (`≈ α` rad in
//! the half vector) wherever it lies. Each cell's light goes to its flux-weighted column with
//! linear interpolation between the two nearest columns before the projector blur is applied,
//! which widens the blur of this light by at most a sixth of a column² in variance.

use std::f64::consts::PI;

use fsm_geometry::Calibration;
use nalgebra::{Point3, Vector3};

use super::paths::DiffusePoint;
use crate::radiometry::lambertian_signal;
use crate::scene::{Material, Scene, Shape};

/// Default [`GatherSettings::lobe_ratio`]: cells of a tenth of the distance at α = 0.2.
const LOBE_RATIO: f64 = 0.5;

/// Resolution of the interreflection integration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GatherSettings {
    /// Width of the finest cells across the projector columns, columns.
    pub cell_columns: f64,
    /// Length of the finest cells along the columns, mm.
    pub cell_mm: f64,
    /// A cell is used whole when its size is below this fraction of its distance.
    pub distance_ratio: f64,
    /// With a glossy end of roughness `α`, a cell is used whole when its size is below
    /// `lobe_ratio · α ×` its distance (and below `distance_ratio ×`).
    pub lobe_ratio: f64,
}

impl Default for GatherSettings {
    fn default() -> Self {
        GatherSettings {
            cell_columns: 1.0,
            cell_mm: 2.0,
            distance_ratio: 0.5,
            lobe_ratio: LOBE_RATIO,
        }
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct Cell {
    /// Flux-weighted centre (geometric centre when unlit).
    point: Point3<f64>,
    /// `Σ E(Y)·area`, reference white · mm², times the albedo of a diffuse emitter.
    flux: f64,
    /// Flux-weighted column.
    column: f64,
    /// Length along the columns, mm (the larger extent).
    size_mm: f64,
}

/// An emitter cut into cells: `levels[0]` the finest, each next level halves the cells along
/// the columns. Cells are stored strip by strip: `levels[l][i·along_l + j]`.
#[derive(Clone, Debug)]
pub struct Emitter {
    surface: usize,
    /// Unit normal of the side the projector lights.
    lit_normal: Vector3<f64>,
    /// The projector centre, where a glossy emitter's light comes from.
    projector_mm: Point3<f64>,
    /// Diffuse (its albedo is in the cells' flux) or glossy (its BRDF is evaluated per cell and
    /// receiver).
    material: Material,
    across: usize,
    levels: Vec<Vec<Cell>>,
    /// Half extents of a finest cell (across, along), for near-field subdivision.
    half_across: Vector3<f64>,
    half_along: Vector3<f64>,
}

impl Emitter {
    /// Cells of a diffuse or glossy rectangle lit by the projector; `None` for other surfaces.
    pub fn build(
        scene: &Scene,
        surface: usize,
        cal: &Calibration,
        reference_distance_mm: f64,
        settings: &GatherSettings,
    ) -> Option<Emitter> {
        let s = scene.surfaces.get(surface)?;
        let albedo = match s.material {
            Material::Diffuse { albedo } => albedo,
            Material::Glossy { .. } => 1.0,
            _ => return None,
        };
        let Shape::Rectangle {
            centre,
            half_u,
            half_v,
        } = s.shape
        else {
            return None;
        };
        let o = cal.projector_centre_mm();
        let normal = half_u.cross(&half_v).normalize();
        let lit_normal = if normal.dot(&(o - centre)) >= 0.0 {
            normal
        } else {
            -normal
        };
        // The axis along which the projector column changes is "across".
        let column_change = |h: &Vector3<f64>| {
            let a = cal.projector_column_of(&(centre + h));
            let b = cal.projector_column_of(&(centre - h));
            match (a, b) {
                (Some(a), Some(b)) => (a - b).abs(),
                _ => h.norm(),
            }
        };
        let (across_h, along_h) = if column_change(&half_u) >= column_change(&half_v) {
            (half_u, half_v)
        } else {
            (half_v, half_u)
        };
        let across_columns = column_change(&across_h).max(across_h.norm() / 1e3);
        let across = ((across_columns / settings.cell_columns).ceil() as usize).max(1);
        let along_min = (2.0 * along_h.norm() / settings.cell_mm).ceil().max(1.0) as usize;
        let along = along_min.next_power_of_two();
        let half_across = across_h / across as f64;
        let half_along = along_h / along as f64;
        let area = 4.0 * half_across.norm() * half_along.norm();
        let rows = cal.projector.height_px() as f64;
        let columns = cal.projector.width_px() as f64;
        let mut finest = Vec::with_capacity(across * along);
        for i in 0..across {
            for j in 0..along {
                let a = -1.0 + (2 * i + 1) as f64 / across as f64;
                let b = -1.0 + (2 * j + 1) as f64 / along as f64;
                let y = centre + across_h * a + along_h * b;
                let mut cell = Cell {
                    point: y,
                    flux: 0.0,
                    column: 0.0,
                    size_mm: 2.0 * half_along.norm().max(half_across.norm()),
                };
                let pp = cal.pose.to_projector(&y);
                if let Some(img) = cal.projector.project(&pp) {
                    let lit = img.y >= -0.5
                        && img.y <= rows - 0.5
                        && img.x >= -0.5
                        && img.x <= columns - 0.5
                        && !scene.occluded(&y, &o, Some(surface), None);
                    if lit {
                        let s = lambertian_signal(
                            albedo,
                            &y,
                            &lit_normal,
                            &o,
                            pp.z,
                            reference_distance_mm,
                        );
                        cell.flux = s * area;
                        cell.column = img.x;
                    }
                }
                finest.push(cell);
            }
        }
        let mut levels = vec![finest];
        let mut len = along;
        while len > 1 {
            let prev = levels.last().expect("at least one level");
            let half = len / 2;
            let mut next = Vec::with_capacity(across * half);
            for i in 0..across {
                for j in 0..half {
                    let a = prev[i * len + 2 * j];
                    let b = prev[i * len + 2 * j + 1];
                    let flux = a.flux + b.flux;
                    let (point, column) = if flux > 0.0 {
                        (
                            Point3::from(
                                (a.point.coords * a.flux + b.point.coords * b.flux) / flux,
                            ),
                            (a.column * a.flux + b.column * b.flux) / flux,
                        )
                    } else {
                        (Point3::from((a.point.coords + b.point.coords) / 2.0), 0.0)
                    };
                    next.push(Cell {
                        point,
                        flux,
                        column,
                        size_mm: 2.0 * a.size_mm.max(half_across.norm()),
                    });
                }
            }
            levels.push(next);
            len = half;
        }
        Some(Emitter {
            surface,
            lit_normal,
            projector_mm: o,
            material: s.material,
            across,
            levels,
            half_across,
            half_along,
        })
    }

    /// The emitter's surface index.
    pub fn surface(&self) -> usize {
        self.surface
    }

    /// Adds to `profile[j]` (columns, before blur) the light this emitter sends to the camera
    /// through the receiver point `at`, scaled by `weight`; returns its total.
    pub fn gather(
        &self,
        scene: &Scene,
        at: &DiffusePoint,
        weight: f64,
        settings: &GatherSettings,
        profile: &mut [f64],
    ) -> f64 {
        if at.surface == self.surface {
            return 0.0;
        }
        let ratio = [at.material, self.material]
            .iter()
            .filter_map(Material::cook_torrance)
            .fold(settings.distance_ratio, |r, b| {
                r.min(settings.lobe_ratio * b.alpha)
            });
        let mut total = 0.0;
        let top = self.levels.len() - 1;
        let mut stack: Vec<(usize, usize)> = Vec::with_capacity(64);
        for i in 0..self.across {
            stack.clear();
            let top_len = self.levels[top].len() / self.across;
            for j in 0..top_len {
                stack.push((top, j));
            }
            while let Some((level, j)) = stack.pop() {
                let len = self.levels[level].len() / self.across;
                let cell = self.levels[level][i * len + j];
                if cell.flux <= 0.0 {
                    continue;
                }
                let max_size_mm = ratio * (cell.point - at.point).norm();
                if cell.size_mm > max_size_mm && level > 0 {
                    stack.push((level - 1, 2 * j));
                    stack.push((level - 1, 2 * j + 1));
                    continue;
                }
                let e = if cell.size_mm > max_size_mm {
                    self.near_field(scene, at, &cell, max_size_mm)
                } else {
                    self.kernel(scene, at, &cell.point) * cell.flux
                };
                if e > 0.0 {
                    let c = e * weight;
                    total += c;
                    deposit_linear(profile, cell.column, c);
                }
            }
        }
        total
    }

    /// `f_X · g_Y · cos θ_X cos θ_Y / r²` with visibility, for the emitting point `y` (`g_Y`
    /// is 1 for a diffuse emitter, whose albedo is in the flux).
    fn kernel(&self, scene: &Scene, at: &DiffusePoint, y: &Point3<f64>) -> f64 {
        let r = y - at.point;
        let r2 = r.norm_squared();
        if r2 == 0.0 {
            return 0.0;
        }
        let dir = r / r2.sqrt();
        let cos_x = at.normal.dot(&dir);
        let cos_y = -self.lit_normal.dot(&dir);
        if cos_x <= 0.0 || cos_y <= 0.0 {
            return 0.0;
        }
        if scene.surfaces.len() > 2
            && scene.occluded(&at.point, y, Some(at.surface), Some(self.surface))
        {
            return 0.0;
        }
        let f_x = at.material.relative_brdf(&at.normal, &dir, &at.view) / PI;
        let g_y = match self.material {
            Material::Glossy { .. } => self.material.relative_brdf(
                &self.lit_normal,
                &(self.projector_mm - y).normalize(),
                &-dir,
            ),
            _ => 1.0,
        };
        f_x * g_y * cos_x * cos_y / r2
    }

    /// A finest cell larger than `max_size_mm` (too close to the receiver), split into `m × m`
    /// parts of equal flux.
    fn near_field(&self, scene: &Scene, at: &DiffusePoint, cell: &Cell, max_size_mm: f64) -> f64 {
        let m = ((cell.size_mm / max_size_mm.max(1e-9)).ceil() as usize).clamp(1, 32);
        let mut sum = 0.0;
        for a in 0..m {
            for b in 0..m {
                let fa = -1.0 + (2 * a + 1) as f64 / m as f64;
                let fb = -1.0 + (2 * b + 1) as f64 / m as f64;
                let y = cell.point + self.half_across * fa + self.half_along * fb;
                sum += self.kernel(scene, at, &y);
            }
        }
        sum * cell.flux / (m * m) as f64
    }
}

/// Splits `value` between the two columns around `column` (tent interpolation).
fn deposit_linear(profile: &mut [f64], column: f64, value: f64) {
    let last = profile.len() as f64 - 1.0;
    let c = column.clamp(0.0, last);
    let j = c.floor();
    let f = c - j;
    let j = j as usize;
    profile[j] += value * (1.0 - f);
    if f > 0.0 {
        profile[j + 1] += value * f;
    }
}
