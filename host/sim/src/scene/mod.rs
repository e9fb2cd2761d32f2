//! Scenes: surfaces in the camera frame (mm), ambient light, and which diffuse or glossy
//! surfaces exchange light. Materials' reflection: [`brdf`]; presets: [`presets`].

pub mod brdf;
pub mod presets;
pub mod shape;

use nalgebra::{Point3, Vector3};

pub use shape::{checker_colour, Hit, Material, Shape, Surface};

/// A scene to render: surfaces in the camera frame (the camera at the origin looking along `+z`,
/// image `x` along `+x`, image `y` along `+y`, i.e. downwards), mm.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// Preset name or a caller's label.
    pub name: String,
    /// What is there.
    pub surfaces: Vec<Surface>,
    /// Uniform ambient irradiance as a fraction of the reference white irradiance (see
    /// [`crate::System::reference_distance_mm`]); it adds `albedo · ambient` to every diffuse
    /// point and `R · ambient` to a glossy one (`R` its directional albedo towards the camera),
    /// pattern-independent.
    pub ambient: f64,
    /// Diffuse or glossy rectangles whose light (from the projector, one bounce) reaches the
    /// other diffuse or glossy surfaces: the interreflection integrated numerically by the
    /// simulator. Indices into `surfaces`.
    pub diffuse_emitters: Vec<usize>,
}

impl Scene {
    /// The nearest surface a ray meets before `t_max`, skipping surface `skip`.
    pub fn nearest_hit(
        &self,
        origin: &Point3<f64>,
        dir: &Vector3<f64>,
        t_max: f64,
        skip: Option<usize>,
    ) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        for (i, s) in self.surfaces.iter().enumerate() {
            if Some(i) == skip {
                continue;
            }
            let limit = best.map_or(t_max, |b| b.t);
            if let Some((t, point, normal)) = s.shape.intersect(origin, dir, limit) {
                best = Some(Hit {
                    t,
                    point,
                    normal,
                    surface: i,
                });
            }
        }
        best
    }

    /// Whether anything but surfaces `skip_a`, `skip_b` lies strictly between `a` and `b`.
    pub fn occluded(
        &self,
        a: &Point3<f64>,
        b: &Point3<f64>,
        skip_a: Option<usize>,
        skip_b: Option<usize>,
    ) -> bool {
        let dir = b - a;
        // Stop just short of b so that b's own surface never occludes it.
        let t_max = 1.0 - shape::RAY_EPSILON_MM / dir.norm().max(1e-300);
        self.surfaces.iter().enumerate().any(|(i, s)| {
            Some(i) != skip_a && Some(i) != skip_b && s.shape.intersect(a, &dir, t_max).is_some()
        })
    }

    /// Indices of the mirrors (front-side reflectors with non-zero reflectance).
    pub fn mirrors(&self) -> impl Iterator<Item = (usize, &Surface, f64)> + '_ {
        self.surfaces
            .iter()
            .enumerate()
            .filter_map(|(i, s)| match s.material {
                Material::Mirror { reflectance } if reflectance > 0.0 => Some((i, s, reflectance)),
                _ => None,
            })
    }
}
