//! Light paths of one camera ray: specular bounces on the camera side, then at the first diffuse
//! or glossy point the projector's light arriving directly and through each mirror (the exact
//! virtual-projector construction), reflected towards the camera by the point's BRDF.

use fsm_geometry::Calibration;
use nalgebra::{Point3, Unit, Vector3};

use crate::radiometry::lambertian_signal;
use crate::scene::{Material, Scene};

/// Where a camera ray ends on a surface that scatters light (diffuse or glossy).
#[derive(Clone, Copy, Debug)]
pub struct DiffusePoint {
    /// The point, camera frame, mm.
    pub point: Point3<f64>,
    /// Unit normal on the side the ray arrived from.
    pub normal: Unit<Vector3<f64>>,
    /// Unit direction back along the ray (to the camera, or to the last mirror on the way):
    /// where a glossy point's BRDF sends the light.
    pub view: Unit<Vector3<f64>>,
    /// The surface's material ([`Material::scatters`]).
    pub material: Material,
    /// Product of the mirror reflectances on the way from the camera.
    pub throughput: f64,
    /// Surface index.
    pub surface: usize,
    /// Mirror bounces between the camera and the point.
    pub bounces: u32,
}

/// Light of the projector reaching a diffuse or glossy point along one path: the projector
/// coordinate `(u, v)` it left from and its signal in reference whites.
#[derive(Clone, Copy, Debug)]
pub struct Arrival {
    /// Projector column coordinate.
    pub column: f64,
    /// Reference-white signal (BRDF, throughput and geometry included).
    pub signal: f64,
    /// Whether it came through a mirror.
    pub via_mirror: bool,
}

/// Follows a camera ray through mirrors to its first diffuse or glossy surface.
pub fn trace_to_diffuse(
    scene: &Scene,
    origin: Point3<f64>,
    dir: Vector3<f64>,
    max_bounces: u32,
) -> Option<DiffusePoint> {
    let mut origin = origin;
    let mut dir = dir;
    let mut throughput = 1.0;
    let mut skip = None;
    for bounces in 0..=max_bounces {
        let hit = scene.nearest_hit(&origin, &dir, f64::INFINITY, skip)?;
        let front = hit.normal.dot(&dir) < 0.0;
        match scene.surfaces[hit.surface].material {
            material if material.scatters() => {
                let normal = if front { hit.normal } else { -hit.normal };
                return Some(DiffusePoint {
                    point: hit.point,
                    normal,
                    view: Unit::new_normalize(-dir),
                    material,
                    throughput,
                    surface: hit.surface,
                    bounces,
                });
            }
            Material::Mirror { reflectance } if front && reflectance > 0.0 => {
                let n = hit.normal.into_inner();
                dir -= 2.0 * dir.dot(&n) * n;
                origin = hit.point;
                throughput *= reflectance;
                // A planar mirror cannot see itself; a sphere is never a mirror here.
                skip = Some(hit.surface);
            }
            _ => return None,
        }
    }
    None
}

/// The projector image point of a camera-frame point if the projector lights it (row on the
/// image, column within reach of the blur).
fn projector_coordinate(cal: &Calibration, p: &Point3<f64>, reach: f64) -> Option<(f64, f64)> {
    let pp = cal.pose.to_projector(p);
    let img = cal.projector.project(&pp)?;
    let rows = cal.projector.height_px() as f64;
    let cols = cal.projector.width_px() as f64;
    let inside_rows = img.y >= -0.5 && img.y <= rows - 0.5;
    let inside_columns = img.x >= -0.5 - reach && img.x <= cols - 0.5 + reach;
    (inside_rows && inside_columns).then_some((img.x, pp.z))
}

/// Every path by which the projector lights `at`: directly and through each mirror (one
/// reflection, the virtual projector `O'` = the projector centre mirrored in the mirror's
/// plane; the light leaves the projector at the column of the mirrored point `X'`, and only if
/// the segment `O → X'` crosses the mirror inside its extent). The light arrives from `O` (or
/// `O'`) and leaves towards `at.view`, weighted by [`Material::relative_brdf`].
pub fn arrivals(
    scene: &Scene,
    cal: &Calibration,
    reference_distance_mm: f64,
    reach: f64,
    at: &DiffusePoint,
    out: &mut Vec<Arrival>,
) {
    out.clear();
    let o = cal.projector_centre_mm();
    let x = at.point;
    let n = at.normal.into_inner();
    let view = at.view.into_inner();
    let scale = at.throughput;
    // Direct.
    if n.dot(&(o - x)) > 0.0 && !scene.occluded(&x, &o, Some(at.surface), None) {
        if let Some((column, depth)) = projector_coordinate(cal, &x, reach) {
            let brdf = at.material.relative_brdf(&n, &(o - x).normalize(), &view);
            let signal = scale * lambertian_signal(brdf, &x, &n, &o, depth, reference_distance_mm);
            if signal > 0.0 {
                out.push(Arrival {
                    column,
                    signal,
                    via_mirror: false,
                });
            }
        }
    }
    // Through each mirror.
    for (index, mirror, reflectance) in scene.mirrors() {
        if index == at.surface {
            continue;
        }
        let Some((p0, nm)) = mirror.shape.plane() else {
            continue;
        };
        let nm = nm.into_inner();
        let height_x = nm.dot(&(x - p0));
        let height_o = nm.dot(&(o - p0));
        if height_x <= 0.0 || height_o <= 0.0 {
            continue;
        }
        let x_mirrored = x - 2.0 * height_x * nm;
        let o_mirrored = o - 2.0 * height_o * nm;
        let m = o + (x_mirrored - o) * (height_o / (height_o + height_x));
        if !mirror.shape.rectangle_contains(&m) {
            continue;
        }
        if n.dot(&(m - x)) <= 0.0 {
            continue;
        }
        if scene.occluded(&o, &m, Some(index), None)
            || scene.occluded(&m, &x, Some(index), Some(at.surface))
        {
            continue;
        }
        if let Some((column, depth)) = projector_coordinate(cal, &x_mirrored, reach) {
            let brdf = at.material.relative_brdf(&n, &(m - x).normalize(), &view);
            let signal = scale
                * reflectance
                * lambertian_signal(brdf, &x, &n, &o_mirrored, depth, reference_distance_mm);
            if signal > 0.0 {
                out.push(Arrival {
                    column,
                    signal,
                    via_mirror: true,
                });
            }
        }
    }
}
