//! Light from a pinhole projector: irradiance on a surface and the projector's blurred column
//! profile.
//!
//! A pinhole projector whose pixels all emit the same flux `Φ` sends, through the pixel at
//! off-axis angle `α`, flux into a solid angle `cos³α / f²`; a surface at distance `d` with
//! incidence `θ` receives the irradiance `E = Φ f² cos θ / (d² cos³α) = Φ f² (n·(O − X)) / z³`
//! where `z` is the point's depth in the projector frame and `O` the projector centre. The
//! simulator works in units of the *reference white* irradiance `Φ f² / d_ref²` (an albedo-1
//! surface facing the projector on its axis at `d_ref`), so a Lambertian point of albedo `ρ`
//! sends the camera `ρ · (n·(O − X)) · d_ref² / z³` reference whites. The projector's distortion
//! moves where a column lands but its effect on the pixel's solid angle (a few per cent at the
//! image corners) is not modelled, nor is the camera's `cos⁴` fall-off.
//!
//! A mirror makes a virtual projector (the real one reflected in the mirror's plane): the same
//! formula with the reflected centre `O'`, the depth of the reflected point `X'` in the real
//! projector, and the mirror's reflectance — exact for a planar mirror.

use nalgebra::{Point3, Vector3};

/// `ρ · (n·(O − X)) · d_ref² / z³`: the reference-white signal of a Lambertian point of albedo
/// `albedo` with unit normal `normal` (oriented towards the light), lit by a (virtual) projector
/// centre `source` that sees the point at depth `depth_mm`. 0 when the light comes from behind.
pub fn lambertian_signal(
    albedo: f64,
    point: &Point3<f64>,
    normal: &Vector3<f64>,
    source: &Point3<f64>,
    depth_mm: f64,
    reference_distance_mm: f64,
) -> f64 {
    let facing = normal.dot(&(source - point));
    if facing <= 0.0 || depth_mm <= 0.0 {
        return 0.0;
    }
    albedo * facing * reference_distance_mm * reference_distance_mm
        / (depth_mm * depth_mm * depth_mm)
}

/// Samples per column of [`BlurKernel`]'s table.
const TABLE_STEPS_PER_COLUMN: usize = 256;
/// The kernel is cut where the Gaussian has fallen to `erfc(5/√2) ≈ 6e-7` of its mass.
const REACH_SIGMAS: f64 = 5.0;

/// The light of projector column `j` at projector coordinate `u` (in columns): a unit-width box
/// centred on `j` (the column's extent, SPEC §1, §7) convolved with the optics' Gaussian blur,
/// `B(d) = ½[erf((d + ½)/(σ√2)) − erf((d − ½)/(σ√2))]` with `d = u − j`. For every `u`,
/// `Σ_j B(u − j) = 1`: blur moves light between columns, it never creates or removes any.
#[derive(Clone, Debug)]
pub struct BlurKernel {
    sigma: f64,
    /// `B(d)` at `d = −reach + i/steps`, for linear interpolation.
    table: Vec<f64>,
    reach: f64,
}

impl BlurKernel {
    /// The kernel for blur std `sigma` columns (`0` = sharp box).
    pub fn new(sigma: f64) -> Self {
        if sigma <= 0.0 {
            return BlurKernel {
                sigma: 0.0,
                table: Vec::new(),
                reach: 0.5,
            };
        }
        let reach = 0.5 + REACH_SIGMAS * sigma;
        let n = (2.0 * reach * TABLE_STEPS_PER_COLUMN as f64).ceil() as usize + 2;
        let k = 1.0 / (sigma * std::f64::consts::SQRT_2);
        let table = (0..n)
            .map(|i| {
                let d = -reach + i as f64 / TABLE_STEPS_PER_COLUMN as f64;
                0.5 * (libm::erf((d + 0.5) * k) - libm::erf((d - 0.5) * k))
            })
            .collect();
        BlurKernel {
            sigma,
            table,
            reach,
        }
    }

    /// Blur std, columns.
    pub fn sigma(&self) -> f64 {
        self.sigma
    }

    /// Columns beyond this distance from `u` receive no light.
    pub fn reach(&self) -> f64 {
        self.reach
    }

    /// `B(d)`.
    pub fn value(&self, d: f64) -> f64 {
        if self.sigma == 0.0 {
            // A sharp projector: the column whose box holds u (its left edge belongs to it).
            return if (-0.5..0.5).contains(&d) { 1.0 } else { 0.0 };
        }
        let x = (d + self.reach) * TABLE_STEPS_PER_COLUMN as f64;
        if x.is_nan() || x < 0.0 {
            return 0.0;
        }
        let i = x as usize;
        if i + 1 >= self.table.len() {
            return 0.0;
        }
        let f = x - i as f64;
        self.table[i] * (1.0 - f) + self.table[i + 1] * f
    }

    /// Adds `weight · B(u − j)` to `acc[j]` for every column `j` of `acc` within reach of `u`;
    /// returns the columns touched (inclusive) or `None`.
    pub fn deposit(&self, acc: &mut [f32], u: f64, weight: f64) -> Option<(usize, usize)> {
        if weight == 0.0 || !u.is_finite() {
            return None;
        }
        let last = acc.len() as f64 - 1.0;
        if self.sigma == 0.0 {
            let j = (u + 0.5).floor();
            if j < 0.0 || j > last {
                return None;
            }
            acc[j as usize] += weight as f32;
            return Some((j as usize, j as usize));
        }
        let lo = (u - self.reach).ceil().max(0.0);
        let hi = (u + self.reach).floor().min(last);
        if lo > hi {
            return None;
        }
        let (lo, hi) = (lo as usize, hi as usize);
        for (j, a) in acc.iter_mut().enumerate().take(hi + 1).skip(lo) {
            *a += (weight * self.value(u - j as f64)) as f32;
        }
        Some((lo, hi))
    }
}
