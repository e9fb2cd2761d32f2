//! One-bounce diffuse interreflection: the projector's light that a diffuse rectangle (an
//! emitter, e.g. a facet of the V-groove) reflects onto another diffuse point, integrated
//! numerically over the emitter.
//!
//! A point `Y` of the emitter lit directly with reference-white signal `s(Y)` (albedo
//! included) has radiance `s(Y)·E_ref/π`; a receiver point `X` of albedo `ρ` then sends the
//! camera `(ρ/π) ∫ s(Y) cos θ_X cos θ_Y / r² dA` reference whites, and that light carries the
//! column `u(Y)` of each emitting point. The emitter is cut into cells one projector column
//! wide across its columns and `cell_mm` long along them; cells are merged pairwise along the
//! columns into a hierarchy, and a receiver point uses the coarsest cells whose length is below
//! `distance_ratio ×` their distance (midpoint rule; cells too close to the receiver — near a
//! concave corner, where the kernel is singular — are subdivided on the fly). Each cell's light
//! goes to its flux-weighted column with linear interpolation between the two nearest columns
//! before the projector blur is applied, which widens the blur of this diffuse light by at
//! most a sixth of a column² in variance.

use fsm_geometry::Calibration;
use nalgebra::{Point3, Unit, Vector3};

use crate::radiometry::lambertian_signal;
use crate::scene::{Material, Scene, Shape};

/// Resolution of the diffuse integration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GatherSettings {
    /// Width of the finest cells across the projector columns, columns.
    pub cell_columns: f64,
    /// Length of the finest cells along the columns, mm.
    pub cell_mm: f64,
    /// A cell is used whole when its size is below this fraction of its distance.
    pub distance_ratio: f64,
}

impl Default for GatherSettings {
    fn default() -> Self {
        GatherSettings {
            cell_columns: 1.0,
            cell_mm: 2.0,
            distance_ratio: 0.5,
        }
    }
}

#[derive(Clone, Copy, Debug, Default)]
struct Cell {
    /// Flux-weighted centre (geometric centre when unlit).
    point: Point3<f64>,
    /// `Σ s(Y)·area`, reference white · mm².
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
    across: usize,
    levels: Vec<Vec<Cell>>,
    /// Half extents of a finest cell (across, along), for near-field subdivision.
    half_across: Vector3<f64>,
    half_along: Vector3<f64>,
}

impl Emitter {
    /// Cells of a diffuse rectangle lit by the projector; `None` for other surfaces.
    pub fn build(
        scene: &Scene,
        surface: usize,
        cal: &Calibration,
        reference_distance_mm: f64,
        settings: &GatherSettings,
    ) -> Option<Emitter> {
        let s = scene.surfaces.get(surface)?;
        let Material::Diffuse { albedo } = s.material else {
            return None;
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

    /// Adds to `profile[j]` (columns, before blur) the light this emitter sends to the
    /// receiver `(x, n_x)` of albedo `albedo`, scaled by `weight`.
    #[allow(clippy::too_many_arguments)]
    pub fn gather(
        &self,
        scene: &Scene,
        receiver: usize,
        x: &Point3<f64>,
        n_x: &Unit<Vector3<f64>>,
        albedo: f64,
        weight: f64,
        settings: &GatherSettings,
        profile: &mut [f64],
    ) -> f64 {
        if receiver == self.surface {
            return 0.0;
        }
        let scale = weight * albedo / std::f64::consts::PI;
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
                let distance = (cell.point - x).norm();
                if cell.size_mm > settings.distance_ratio * distance && level > 0 {
                    stack.push((level - 1, 2 * j));
                    stack.push((level - 1, 2 * j + 1));
                    continue;
                }
                let e = if level == 0 && cell.size_mm > settings.distance_ratio * distance {
                    self.near_field(scene, receiver, x, n_x, &cell, distance, settings)
                } else {
                    self.kernel(scene, receiver, x, n_x, &cell.point) * cell.flux
                };
                if e > 0.0 {
                    let c = e * scale;
                    total += c;
                    deposit_linear(profile, cell.column, c);
                }
            }
        }
        total
    }

    /// `cos θ_X cos θ_Y / r²` with visibility.
    fn kernel(
        &self,
        scene: &Scene,
        receiver: usize,
        x: &Point3<f64>,
        n_x: &Unit<Vector3<f64>>,
        y: &Point3<f64>,
    ) -> f64 {
        let r = y - x;
        let r2 = r.norm_squared();
        if r2 == 0.0 {
            return 0.0;
        }
        let cos_x = n_x.dot(&r);
        let cos_y = -self.lit_normal.dot(&r);
        if cos_x <= 0.0 || cos_y <= 0.0 {
            return 0.0;
        }
        if scene.surfaces.len() > 2 && scene.occluded(x, y, Some(receiver), Some(self.surface)) {
            return 0.0;
        }
        cos_x * cos_y / (r2 * r2)
    }

    /// A finest cell too close to the receiver, split into `m × m` parts of equal flux.
    #[allow(clippy::too_many_arguments)]
    fn near_field(
        &self,
        scene: &Scene,
        receiver: usize,
        x: &Point3<f64>,
        n_x: &Unit<Vector3<f64>>,
        cell: &Cell,
        distance: f64,
        settings: &GatherSettings,
    ) -> f64 {
        let m = ((cell.size_mm / (settings.distance_ratio * distance.max(1e-9))).ceil() as usize)
            .clamp(1, 32);
        let mut sum = 0.0;
        for a in 0..m {
            for b in 0..m {
                let fa = -1.0 + (2 * a + 1) as f64 / m as f64;
                let fb = -1.0 + (2 * b + 1) as f64 / m as f64;
                let y = cell.point + self.half_across * fa + self.half_along * fb;
                sum += self.kernel(scene, receiver, x, n_x, &y);
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
