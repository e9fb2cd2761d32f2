//! The preset scenes, built for the bench system of [`crate::System::bench`] (camera at the
//! origin, projector 200 mm to its right, both aimed at a point 500 mm in front of the camera).
//!
//! | name | what | why |
//! |---|---|---|
//! | `plane` | a diffuse plane (albedo 0.8) at 500 mm, facing the camera | accuracy without interreflection |
//! | `plane_mirror` | the plane and a mirror (reflectance 0.9) standing beside it | strong indirect light: the plane receives the projector's light directly and via the mirror |
//! | `plane_mirror_covered` | the same with the mirror black | the reference without interreflection (paper's Ed) |
//! | `vgroove` | two diffuse facets (albedo 0.8) at 90°, the groove's axis vertical | one-bounce diffuse interreflection, concave corner |
//! | `sphere_mirror` | a diffuse sphere (r 45 mm) before a diffuse wall, a mirror beside | a curved surface lit directly and via the mirror |
//! | `vgroove_glossy` | two rough-metal facets (iron, GGX α 0.2) at 90°, the groove's axis vertical, its bisector aimed at the middle of the baseline | glossy interreflection: indirect light 13× the direct light (median; 10%–90%: 5.6–20), spread over 46 columns per pixel (18–67) |
//!
//! The mirror of `plane_mirror` is a 90 mm × 120 mm rectangle in the plane `x = −60 mm`, its
//! reflecting face towards `+x` (the projector's side), spanning depths 380–470 mm: it stands
//! 30 mm off the plane, so the direct and the mirrored column of every plane point it lights
//! are more than 60 columns apart (well above BFSM's separation limit `2Δc`, paper §IV-C).
//! The camera sees the plane around the mirror, the strip of plane it lights, and the mirror's
//! face (whose pixels see the plane through the mirror: no direct light there).

use nalgebra::{Point3, Vector3};

use super::{Material, Scene, Shape, Surface};

/// Names of the preset scenes.
pub const NAMES: [&str; 6] = [
    "plane",
    "plane_mirror",
    "plane_mirror_covered",
    "vgroove",
    "sphere_mirror",
    "vgroove_glossy",
];

/// Ambient light of every preset: 2% of the reference white.
const AMBIENT: f64 = 0.02;

fn rectangle(
    name: &str,
    centre: [f64; 3],
    half_u: [f64; 3],
    half_v: [f64; 3],
    material: Material,
) -> Surface {
    Surface {
        name: name.into(),
        shape: Shape::Rectangle {
            centre: Point3::from(centre),
            half_u: Vector3::from(half_u),
            half_v: Vector3::from(half_v),
        },
        material,
    }
}

/// The diffuse plane at 500 mm, 800 mm square (it fills the camera's view).
fn plane(z: f64, albedo: f64) -> Surface {
    // Front normal half_u × half_v = (0, 0, −1): towards the camera.
    rectangle(
        "plane",
        [0.0, 0.0, z],
        [0.0, 400.0, 0.0],
        [400.0, 0.0, 0.0],
        Material::Diffuse { albedo },
    )
}

/// A mirror in the plane `x = x_mm`, reflecting towards `+x`, over depths `z0..z1`, heights
/// `±half_height`.
fn mirror(x_mm: f64, z0: f64, z1: f64, half_height: f64, material: Material) -> Surface {
    // Front normal half_u × half_v = (0, 0, h)×(0, h', 0)… choose half_u along y, half_v along
    // z: (0, a, 0) × (0, 0, b) = (a·b, 0, 0), +x for a, b > 0.
    rectangle(
        "mirror",
        [x_mm, 0.0, 0.5 * (z0 + z1)],
        [0.0, half_height, 0.0],
        [0.0, 0.0, 0.5 * (z1 - z0)],
        material,
    )
}

const MIRROR: Material = Material::Mirror { reflectance: 0.9 };

/// Rough iron: `F₀` 0.56 (iron's 0.56–0.58 in linear RGB), GGX `α` 0.2.
pub const GLOSSY_IRON: Material = Material::Glossy {
    f0: 0.56,
    roughness: 0.2,
};

/// The corner line of `vgroove_glossy`: vertical through this point, mm.
pub const GLOSSY_CORNER_MM: [f64; 3] = [0.0, 0.0, 560.0];

/// `vgroove_glossy`'s facets: 60 mm from the corner line to their outer edge, ±110 mm high, at
/// ±45° about the bisector, which points from the corner at the middle of the baseline
/// `(100, 0, 0)`.
///
/// Why this V: two reflections off planes at 90° turn a ray by 180° about the groove's axis, so
/// the light the projector sends into the groove leaves it back towards the projector, 20° from
/// the camera, and the rough lobes (α 0.2) carry a strong share of it to the camera; each
/// facet, though, faces the camera about 45° off the half vector between the projector and the
/// camera (GGX's `D` there: 0.6% of its peak), so the direct light is weak. Both facets are lit
/// and seen whole, and both orders of the bounce reach the camera (an opening of 101° or 79°
/// would send one order straight to the camera and the other 44° away from it). The facets
/// are 60 mm wide so that the lobe's patch on the other facet spans tens of columns, not
/// hundreds.
///
/// Measured over the whole image (`vgroove_glossy_regime_over_the_whole_image`, the 24 296
/// facet pixels off the edges; 10% / median / 90% over the pixels): indirect/direct 5.6 / 12.7
/// / 20.1 (left facet 7.6 / 13.1 / 19.0, right 4.9 / 12.2 / 21.7); the indirect light's spread
/// (columns between its 10% and 90% quantiles) 18 / 46 / 67 (left 14 / 43 / 46, right 21 / 63 /
/// 67); direct light 0.02–0.04 reference white, the brightest pixel 0.65 under a white frame.
fn vgroove_glossy() -> Vec<Surface> {
    let corner = Point3::from(GLOSSY_CORNER_MM);
    let bisector = (100.0 - corner.x).atan2(corner.z);
    let up = Vector3::new(0.0, 110.0, 0.0);
    // Facet at `angle` from −z towards +x; its front normal (half_u × half_v) faces the groove.
    let facet = |name: &str, angle: f64, left: bool| {
        let half_slope = Vector3::new(angle.sin(), 0.0, -angle.cos()) * 30.0;
        let (half_u, half_v) = if left {
            (half_slope, up)
        } else {
            (up, half_slope)
        };
        Surface {
            name: name.into(),
            shape: Shape::Rectangle {
                centre: corner + half_slope,
                half_u,
                half_v,
            },
            material: GLOSSY_IRON,
        }
    };
    let quarter = std::f64::consts::FRAC_PI_4;
    vec![
        facet("facet_left", bisector - quarter, true),
        facet("facet_right", bisector + quarter, false),
    ]
}

impl Scene {
    /// A preset scene by name (see [`NAMES`]).
    pub fn preset(name: &str) -> Option<Scene> {
        let scene = |surfaces, diffuse_emitters| Scene {
            name: name.into(),
            surfaces,
            ambient: AMBIENT,
            diffuse_emitters,
        };
        Some(match name {
            "plane" => scene(vec![plane(500.0, 0.8)], vec![]),
            "plane_mirror" => scene(
                vec![plane(500.0, 0.8), mirror(-60.0, 380.0, 470.0, 60.0, MIRROR)],
                vec![],
            ),
            "plane_mirror_covered" => scene(
                vec![
                    plane(500.0, 0.8),
                    mirror(-60.0, 380.0, 470.0, 60.0, Material::Black),
                ],
                vec![],
            ),
            "vgroove" => {
                // Corner line at x = 0, z = 560; facets rise at 45° to x = ±150, z = 410.
                let a = rectangle(
                    "facet_left",
                    [-75.0, 0.0, 485.0],
                    [-75.0, 0.0, -75.0],
                    [0.0, 110.0, 0.0],
                    Material::Diffuse { albedo: 0.8 },
                );
                let b = rectangle(
                    "facet_right",
                    [75.0, 0.0, 485.0],
                    [0.0, 110.0, 0.0],
                    [75.0, 0.0, -75.0],
                    Material::Diffuse { albedo: 0.8 },
                );
                scene(vec![a, b], vec![0, 1])
            }
            "sphere_mirror" => scene(
                vec![
                    plane(520.0, 0.6),
                    Surface {
                        name: "sphere".into(),
                        shape: Shape::Sphere {
                            centre: Point3::new(20.0, 0.0, 460.0),
                            radius_mm: 45.0,
                        },
                        material: Material::Diffuse { albedo: 0.8 },
                    },
                    mirror(-70.0, 380.0, 500.0, 70.0, MIRROR),
                ],
                vec![],
            ),
            "vgroove_glossy" => scene(vgroove_glossy(), vec![0, 1]),
            _ => return None,
        })
    }
}
