//! Rough metal: the Cook–Torrance microfacet BRDF with the GGX (Trowbridge–Reitz) normal
//! distribution, height-correlated Smith masking–shadowing and Schlick's Fresnel term,
//!
//! `f_r(l, v) = F(l·h) · D(n·h) · G₂(l, v) / (4 (n·l)(n·v))`, `h = (l + v)/|l + v|`,
//!
//! - `D(θ_h) = α² / (π ((n·h)²(α² − 1) + 1)²)` (normalised: `∫ D (n·h) dω_h = 1`),
//! - `G₂ = 1 / (1 + Λ(l) + Λ(v))`, `Λ(ω) = (√(1 + α² tan²θ_ω) − 1)/2` (Heitz 2014),
//! - `F(c) = F₀ + (1 − F₀)(1 − c)⁵`, `F₀` the metal's reflectance at normal incidence.
//!
//! All three are symmetric in `l` and `v`, so the BRDF is reciprocal. It scatters once off the
//! microfacets: the light that would bounce again between them is lost (5% of F₀ seen from the
//! normal at α = 0.2, mostly GGX's long tail of half vectors beyond 45°, which reflect below
//! the horizon), so its directional albedo stays below the Fresnel term.
//!
//! The simulator works in reference whites (a white Lambertian surface facing the projector on
//! its axis at the reference distance), so a material enters a signal as `π·f_r`, the BRDF
//! relative to a white Lambertian surface ([`super::Material::relative_brdf`]): the albedo of a
//! diffuse surface, `π·f_r` of a glossy one.

use std::f64::consts::PI;

use nalgebra::Vector3;

use super::Material;

/// The Cook–Torrance GGX BRDF of a rough metal (see the module's docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CookTorrance {
    /// Reflectance at normal incidence (Schlick's `F₀`): 0.91 for aluminium, 0.56 for iron.
    pub f0: f64,
    /// GGX roughness `α` (the slope spread of the microfacets; `α = r²` for the perceptual
    /// roughness `r` of many renderers).
    pub alpha: f64,
}

impl CookTorrance {
    /// `D`, the density of microfacet normals at `cos θ_h = n·h`, 1/sr.
    pub fn distribution(&self, cos_h: f64) -> f64 {
        let a2 = self.alpha * self.alpha;
        let d = cos_h * cos_h * (a2 - 1.0) + 1.0;
        a2 / (PI * d * d)
    }

    /// Smith's `Λ` of a direction at `cos θ = n·ω` from the normal.
    fn lambda(&self, cos: f64) -> f64 {
        let c2 = cos * cos;
        let tan2 = (1.0 - c2).max(0.0) / c2;
        0.5 * ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0)
    }

    /// `G₂`, the fraction of microfacets both lit and seen (height-correlated Smith).
    pub fn masking_shadowing(&self, cos_l: f64, cos_v: f64) -> f64 {
        1.0 / (1.0 + self.lambda(cos_l) + self.lambda(cos_v))
    }

    /// Schlick's Fresnel reflectance at `cos = l·h`.
    pub fn fresnel(&self, cos: f64) -> f64 {
        let m = (1.0 - cos).clamp(0.0, 1.0);
        let m2 = m * m;
        self.f0 + (1.0 - self.f0) * m2 * m2 * m
    }

    /// `f_r` for unit directions to the light `l` and to the viewer `v` about the unit normal
    /// `n`, 1/sr; 0 when either is below the surface.
    pub fn value(&self, n: &Vector3<f64>, l: &Vector3<f64>, v: &Vector3<f64>) -> f64 {
        let cos_l = n.dot(l);
        let cos_v = n.dot(v);
        if cos_l <= 0.0 || cos_v <= 0.0 {
            return 0.0;
        }
        let h = l + v;
        let h_norm = h.norm();
        let cos_h = n.dot(&h) / h_norm;
        let cos_d = l.dot(&h) / h_norm;
        self.fresnel(cos_d) * self.distribution(cos_h) * self.masking_shadowing(cos_l, cos_v)
            / (4.0 * cos_l * cos_v)
    }

    /// Directional albedo `R(v) = ∫ f_r(l, v) (n·l) dω_l` of a viewer at `cos θ_v` from the
    /// normal: the fraction of uniform light the viewer sees reflected. Integrated over the
    /// half vectors, `R = ∫ F·G₂·(v·h)/((n·v)(n·h)) · D (n·h) dω_h`, on a midpoint grid of
    /// `steps × 2·steps` cells in `(ξ, φ)`, `ξ` the share of `D (n·h) dω_h` below `θ_h` (GGX's
    /// inverse CDF), so the narrow lobe of a low roughness costs no more than a wide one. The
    /// grid is `ξ = 1 − (1 − t)²` for uniform `t`: finer towards the tail, where half vectors
    /// reflect the viewer below the horizon.
    pub fn directional_albedo(&self, cos_v: f64, steps: usize) -> f64 {
        let cos_v = cos_v.clamp(1e-6, 1.0);
        let v = Vector3::new((1.0 - cos_v * cos_v).sqrt(), 0.0, cos_v);
        let a2 = self.alpha * self.alpha;
        let mut sum = 0.0;
        for i in 0..steps {
            let rest = 1.0 - (i as f64 + 0.5) / steps as f64;
            let xi = 1.0 - rest * rest;
            let mut ring = 0.0;
            // tan²θ_h = α² ξ / (1 − ξ).
            let cos_h = ((1.0 - xi) / (1.0 + (a2 - 1.0) * xi)).sqrt();
            let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
            for k in 0..2 * steps {
                let phi = PI * (k as f64 + 0.5) / steps as f64;
                let h = Vector3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
                let vh = v.dot(&h);
                if vh <= 0.0 {
                    continue;
                }
                let cos_l = 2.0 * vh * cos_h - cos_v;
                if cos_l <= 0.0 {
                    continue;
                }
                ring +=
                    self.fresnel(vh) * self.masking_shadowing(cos_l, cos_v) * vh / (cos_v * cos_h);
            }
            // dξ/dt = 2(1 − t).
            sum += 2.0 * rest * ring;
        }
        sum / (2 * steps * steps) as f64
    }
}

/// Entries of the directional-albedo table of a glossy material.
const ALBEDO_TABLE_STEPS: usize = 64;
/// [`CookTorrance::directional_albedo`]'s steps for the table (0.1% from a converged integral).
const ALBEDO_STEPS: usize = 48;

/// How much of a uniform (ambient) light a material sends a viewer, by `cos θ_v`: the albedo of
/// a diffuse surface, the tabulated directional albedo of a glossy one.
#[derive(Clone, Debug)]
pub enum AmbientReflectance {
    /// The same for every viewer.
    Constant(f64),
    /// `R` at `cos θ_v = (i + ½)/len`, interpolated linearly.
    Table(Vec<f64>),
}

impl AmbientReflectance {
    /// The ambient reflectance of `material` (0 for mirrors and black surfaces, which the
    /// camera never measures).
    pub fn of(material: &Material) -> Self {
        if let Some(brdf) = material.cook_torrance() {
            return AmbientReflectance::Table(
                (0..ALBEDO_TABLE_STEPS)
                    .map(|i| {
                        let cos_v = (i as f64 + 0.5) / ALBEDO_TABLE_STEPS as f64;
                        brdf.directional_albedo(cos_v, ALBEDO_STEPS)
                    })
                    .collect(),
            );
        }
        match *material {
            Material::Diffuse { albedo } => AmbientReflectance::Constant(albedo),
            _ => AmbientReflectance::Constant(0.0),
        }
    }

    /// The reflectance seen from `cos θ_v`.
    pub fn at(&self, cos_v: f64) -> f64 {
        match self {
            AmbientReflectance::Constant(r) => *r,
            AmbientReflectance::Table(t) => {
                let x = (cos_v * t.len() as f64 - 0.5).clamp(0.0, (t.len() - 1) as f64);
                let i = (x as usize).min(t.len() - 2);
                let f = x - i as f64;
                t[i] * (1.0 - f) + t[i + 1] * f
            }
        }
    }
}
