//! Projector visibility: a chosen point is kept only where the projector's light can reach it
//! directly.
//!
//! The selection (eqs. 10–11) only chooses among a pixel's candidates. A pixel that receives no
//! direct light — a wall in an object's shadow lit only through a mirror, a pixel that sees the
//! mirror itself — has only indirect candidates, and one of them wins: a point on a surface
//! that does not exist. The paper's reasoning cannot see it; the projector's can. Direct light
//! travels along a projector ray to the *first* surface on it, so two chosen points on one
//! projector ray at different depths cannot both be lit directly: one of them is fictitious.
//!
//! The chosen points are joined into surfaces (neighbouring pixels whose points are within
//! `2ε`, the selection's own notion of one surface), each surface is rendered into the
//! projector's image as triangles (a depth buffer over column × row, the rows from the
//! calibration), and every point is looked up in the other surfaces' renderings:
//!
//! - *occluded*: another surface is nearer to the projector on its ray;
//! - *occluding*: it would hide another surface that the projector lights further along the ray.
//!
//! A surface that the projector sees from behind (its normal, estimated from neighbouring
//! points and turned towards the camera, points away from the projector) cannot be lit by it:
//! such a point is fictitious, and so is a surface of which more than half is. The
//! fictitious surface that a mirror's light makes on a wall in an object's shadow is of this
//! kind: it stands alone (no direct light there to conflict with), but leans away from the
//! projector.
//!
//! A fictitious surface conflicts almost wherever it stands (the projector lights some real
//! surface along nearly every one of its rays), a real one only where a fictitious one overlaps
//! it. So surfaces are trusted in order of their share of conflicting points, least first; a
//! surface of which more than [`VisibilityParams::max_conflict_share`] conflicts with the
//! surfaces trusted before it is fictitious as a whole. Of the trusted surfaces, a point that
//! another trusted surface occludes is dropped. A point the projector's image does not contain
//! (its projector row outside the calibrated rows) is fictitious too.
//!
//! What it cannot see: a virtual image in a plane mirror, at the pixels that see the mirror,
//! is consistent with camera and projector alike (unfold the two reflections and it is a
//! real surface lit directly); it is caught only where the projector also lights a measured
//! surface on its rays. [`crate::mirror`] finds the mirror and removes the rest.

use fsm_geometry::Calibration;
use nalgebra::Point3;
use rayon::prelude::*;

use crate::selection::distance_mm;

/// Parameters of the visibility test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VisibilityParams {
    /// Depth difference along a projector ray (mm, projector frame) beyond which two points are
    /// on different surfaces; the selection's `ε`.
    pub tolerance_mm: f32,
    /// Neighbouring points closer than this (mm) belong to one surface; the selection's `2ε`.
    pub reach_mm: f32,
    /// A surface is fictitious when more than this share of its points conflicts with the
    /// surfaces trusted before it.
    pub max_conflict_share: f32,
}

impl VisibilityParams {
    /// The test at the selection's scale `ε`.
    pub fn for_epsilon(epsilon_mm: f32) -> Self {
        VisibilityParams {
            tolerance_mm: epsilon_mm,
            reach_mm: 2.0 * epsilon_mm,
            max_conflict_share: 0.2,
        }
    }
}

/// One projector pixel a surface's triangle covers: the depth range of the triangle over it.
#[derive(Clone, Copy, Debug)]
struct Fragment {
    pixel: u32,
    surface: u32,
    near_mm: f32,
    far_mm: f32,
}

/// A chosen point in the projector's view.
#[derive(Clone, Copy, Debug)]
struct ProjectedPoint {
    /// Projector pixel `(column, row)`, continuous.
    uv: [f32; 2],
    /// Depth in the projector frame, mm.
    depth_mm: f32,
}

/// How a point conflicts with another surface on its projector ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Conflict {
    /// The other surface is nearer to the projector.
    Occluded,
    /// The point is nearer and would hide the other surface.
    Occluding,
}

/// The chosen points (`points[y·width + x]`, camera frame, mm) that the projector cannot light
/// directly: `true` where the point is fictitious. Pixels without a point are `false`.
pub fn fictitious_points(
    calibration: &Calibration,
    width: usize,
    height: usize,
    points: &[Option<[f32; 3]>],
    params: &VisibilityParams,
) -> Vec<bool> {
    assert_eq!(points.len(), width * height, "one entry per pixel");
    let (columns, rows) = (
        calibration.projector.width_px(),
        calibration.projector.height_px(),
    );
    // Every point in the projector's view; outside its image, no direct light reaches it.
    let projected: Vec<Option<ProjectedPoint>> = points
        .par_iter()
        .map(|p| {
            let p = (*p)?;
            let camera = Point3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            let in_projector = calibration.pose.to_projector(&camera);
            let uv = calibration.projector.project(&in_projector)?;
            calibration.projector.contains(uv).then(|| ProjectedPoint {
                uv: [uv.x as f32, uv.y as f32],
                depth_mm: in_projector.z as f32,
            })
        })
        .collect();
    let mut fictitious: Vec<bool> = points
        .iter()
        .zip(&projected)
        .map(|(p, q)| p.is_some() && q.is_none())
        .collect();

    let (surface_of, surfaces) = surfaces(width, height, points, &projected, params.reach_mm);
    // Rendered a row of camera cells at a time; the rows' fragments in order, so that the
    // fragments are the same for any number of threads.
    let fragments: Vec<Fragment> = (0..height.saturating_sub(1))
        .into_par_iter()
        .flat_map_iter(|y| {
            let mut row = Vec::new();
            for_each_triangle(width, y, points, &surface_of, params.reach_mm, |t| {
                let [a, b, c] = t.map(|i| projected[i].expect("triangles join projected points"));
                rasterise(a, b, c, surface_of[t[0]], columns, rows, &mut row);
            });
            row
        })
        .collect();
    let lookup = FragmentLookup::new(fragments, columns, rows, params.tolerance_mm);
    let clashes = Clashes::find(&lookup, &projected, &surface_of, surfaces);
    // Each surface's share of points that conflict with any other surface.
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); surfaces];
    for (i, s) in surface_of.iter().enumerate() {
        if *s != NONE {
            members[*s as usize].push(i);
        }
    }
    let share: Vec<f32> = members
        .iter()
        .enumerate()
        .map(|(s, m)| clashes.conflicts(s, |_| true).count() as f32 / m.len().max(1) as f32)
        .collect();
    // A surface the projector sees from behind cannot be lit by it.
    let back_facing = back_facing(calibration, width, height, points, &surface_of);
    let mut rejected = vec![false; surfaces];
    for (s, m) in members.iter().enumerate() {
        let back = m.iter().filter(|&&i| back_facing[i]).count();
        if back as f32 > 0.5 * m.len() as f32 {
            rejected[s] = true;
        }
    }
    let mut order: Vec<usize> = (0..surfaces).filter(|&s| !rejected[s]).collect();
    order.sort_by(|&a, &b| {
        share[a]
            .total_cmp(&share[b])
            .then(members[b].len().cmp(&members[a].len()))
            .then(a.cmp(&b))
    });
    let mut trusted = vec![false; surfaces];
    for (s, m) in members.iter().enumerate() {
        for &i in m {
            fictitious[i] |= rejected[s] || back_facing[i];
        }
    }
    for &s in &order {
        let conflicting = clashes.conflicts(s, |o| trusted[o as usize]).count();
        if conflicting as f32 > params.max_conflict_share * members[s].len() as f32 {
            for &i in &members[s] {
                fictitious[i] = true;
            }
        } else {
            trusted[s] = true;
        }
    }
    // Within the trusted surfaces, what another trusted surface occludes.
    for s in (0..surfaces).filter(|&s| trusted[s]) {
        for (i, conflict) in clashes.conflicts(s, |o| trusted[o as usize]) {
            if conflict == Conflict::Occluded {
                fictitious[i] = true;
            }
        }
    }
    fictitious
}

const NONE: u32 = u32::MAX;

/// The points whose surface, its normal estimated from the neighbouring points of the same
/// surface and turned towards the camera, faces away from the projector by more than 3°.
fn back_facing(
    calibration: &Calibration,
    width: usize,
    height: usize,
    points: &[Option<[f32; 3]>],
    surface_of: &[u32],
) -> Vec<bool> {
    let o = calibration.projector_centre_mm();
    let projector = [o.x as f32, o.y as f32, o.z as f32];
    let same = |i: usize, j: usize| surface_of[i] != NONE && surface_of[i] == surface_of[j];
    (0..points.len())
        .into_par_iter()
        .map(|i| {
            let Some(p) = points[i] else { return false };
            if surface_of[i] == NONE {
                return false;
            }
            let (x, y) = (i % width, i / width);
            // The difference across the pixel, from neighbours on its surface.
            let across = |before: Option<usize>, after: Option<usize>| {
                let before = before.filter(|&j| same(i, j)).unwrap_or(i);
                let after = after.filter(|&j| same(i, j)).unwrap_or(i);
                (before != after).then(|| {
                    let (a, b) = (
                        points[before].expect("on a surface"),
                        points[after].expect("on a surface"),
                    );
                    [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
                })
            };
            let (Some(du), Some(dv)) = (
                across(
                    x.checked_sub(1).map(|_| i - 1),
                    (x + 1 < width).then(|| i + 1),
                ),
                across(
                    y.checked_sub(1).map(|_| i - width),
                    (y + 1 < height).then(|| i + width),
                ),
            ) else {
                return false;
            };
            let mut n = [
                du[1] * dv[2] - du[2] * dv[1],
                du[2] * dv[0] - du[0] * dv[2],
                du[0] * dv[1] - du[1] * dv[0],
            ];
            let norm = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if norm == 0.0 {
                return false;
            }
            // Towards the camera (the origin).
            if n[0] * p[0] + n[1] * p[1] + n[2] * p[2] > 0.0 {
                n = [-n[0], -n[1], -n[2]];
            }
            let to_projector = [
                projector[0] - p[0],
                projector[1] - p[1],
                projector[2] - p[2],
            ];
            let distance = distance_mm(&projector, &p);
            let cosine = (n[0] * to_projector[0] + n[1] * to_projector[1] + n[2] * to_projector[2])
                / (norm * distance);
            cosine < -0.05
        })
        .collect()
}

/// Connected surfaces of the projected points: 4-neighbours within `reach_mm` are joined.
/// Returns each pixel's surface (or [`NONE`]) and the number of surfaces.
fn surfaces(
    width: usize,
    height: usize,
    points: &[Option<[f32; 3]>],
    projected: &[Option<ProjectedPoint>],
    reach_mm: f32,
) -> (Vec<u32>, usize) {
    let mut parent: Vec<u32> = (0..points.len() as u32).collect();
    fn root(parent: &mut [u32], mut i: u32) -> u32 {
        while parent[i as usize] != i {
            parent[i as usize] = parent[parent[i as usize] as usize];
            i = parent[i as usize];
        }
        i
    }
    let joined = |i: usize, j: usize| match (points[i], points[j], projected[i], projected[j]) {
        (Some(p), Some(q), Some(_), Some(_)) => distance_mm(&p, &q) <= reach_mm,
        _ => false,
    };
    // Whether each pixel is joined to its right (bit 0) and lower (bit 1) neighbour, in
    // parallel; the joining itself in raster order.
    let links: Vec<u8> = (0..points.len())
        .into_par_iter()
        .map(|i| {
            let right = i % width + 1 < width && joined(i, i + 1);
            let below = i / width + 1 < height && joined(i, i + width);
            right as u8 | (below as u8) << 1
        })
        .collect();
    for (i, &link) in links.iter().enumerate() {
        for (bit, j) in [(1, i + 1), (2, i + width)] {
            if link & bit != 0 {
                let (a, b) = (root(&mut parent, i as u32), root(&mut parent, j as u32));
                parent[a.max(b) as usize] = a.min(b);
            }
        }
    }
    let mut label = vec![NONE; points.len()];
    let mut surface_of = vec![NONE; points.len()];
    let mut count = 0u32;
    for i in 0..points.len() {
        if projected[i].is_none() {
            continue;
        }
        let r = root(&mut parent, i as u32) as usize;
        if label[r] == NONE {
            label[r] = count;
            count += 1;
        }
        surface_of[i] = label[r];
    }
    (surface_of, count as usize)
}

/// The triangles of the camera grid's row `y` of cells (between pixel rows `y` and `y + 1`)
/// whose three points are on one surface and pairwise within `1.5 × reach_mm` (the diagonal
/// of a cell): two per 2 × 2 cell.
fn for_each_triangle(
    width: usize,
    y: usize,
    points: &[Option<[f32; 3]>],
    surface_of: &[u32],
    reach_mm: f32,
    mut triangle: impl FnMut([usize; 3]),
) {
    let reach = 1.5 * reach_mm;
    let close = |i: usize, j: usize| match (points[i], points[j]) {
        (Some(p), Some(q)) => distance_mm(&p, &q) <= reach,
        _ => false,
    };
    for x in 0..width.saturating_sub(1) {
        let (a, b, c, d) = (
            y * width + x,
            y * width + x + 1,
            (y + 1) * width + x,
            (y + 1) * width + x + 1,
        );
        for t in [[a, b, c], [b, d, c]] {
            let s = surface_of[t[0]];
            if s != NONE
                && surface_of[t[1]] == s
                && surface_of[t[2]] == s
                && close(t[0], t[1])
                && close(t[1], t[2])
                && close(t[0], t[2])
            {
                triangle(t);
            }
        }
    }
}

/// The projector pixels (centres) triangle `abc` covers, with the triangle's depth range over
/// each: its depth at the centre ± the change of depth across half a pixel's diagonal.
fn rasterise(
    a: ProjectedPoint,
    b: ProjectedPoint,
    c: ProjectedPoint,
    surface: u32,
    columns: u32,
    rows: u32,
    out: &mut Vec<Fragment>,
) {
    let min_u = a.uv[0].min(b.uv[0]).min(c.uv[0]).ceil().max(0.0) as u32;
    let max_u = (a.uv[0].max(b.uv[0]).max(c.uv[0]).floor()).min(columns as f32 - 1.0);
    let min_v = a.uv[1].min(b.uv[1]).min(c.uv[1]).ceil().max(0.0) as u32;
    let max_v = (a.uv[1].max(b.uv[1]).max(c.uv[1]).floor()).min(rows as f32 - 1.0);
    // Most triangles of a camera finer than the projector hold no pixel centre: no more work.
    if max_u < 0.0 || max_v < 0.0 || min_u as f32 > max_u || min_v as f32 > max_v {
        return;
    }
    let (ab, ac) = (
        [b.uv[0] - a.uv[0], b.uv[1] - a.uv[1]],
        [c.uv[0] - a.uv[0], c.uv[1] - a.uv[1]],
    );
    let area = ab[0] * ac[1] - ab[1] * ac[0];
    if area.abs() < 1e-6 {
        return;
    }
    // Depth as a plane over the projector image: z = a.z + gu·(u − a.u) + gv·(v − a.v).
    let (dzb, dzc) = (b.depth_mm - a.depth_mm, c.depth_mm - a.depth_mm);
    let gu = (dzb * ac[1] - dzc * ab[1]) / area;
    let gv = (dzc * ab[0] - dzb * ac[0]) / area;
    let slack = 0.5 * (gu.abs() + gv.abs());
    for v in min_v..=max_v as u32 {
        for u in min_u..=max_u as u32 {
            let (pu, pv) = (u as f32 - a.uv[0], v as f32 - a.uv[1]);
            // Barycentric coordinates of the pixel centre.
            let s = (pu * ac[1] - pv * ac[0]) / area;
            let t = (ab[0] * pv - ab[1] * pu) / area;
            const EDGE: f32 = -1e-4;
            if s < EDGE || t < EDGE || s + t > 1.0 - EDGE {
                continue;
            }
            let depth = a.depth_mm + gu * pu + gv * pv;
            out.push(Fragment {
                pixel: v * columns + u,
                surface,
                near_mm: depth - slack,
                far_mm: depth + slack,
            });
        }
    }
}

/// The rendered fragments of every surface, by projector pixel.
struct FragmentLookup {
    /// The fragments of pixel `p` are `fragments[start[p]..start[p + 1]]`.
    start: Vec<u32>,
    fragments: Vec<Fragment>,
    columns: u32,
    rows: u32,
    tolerance_mm: f32,
}

impl FragmentLookup {
    /// Sorts `fragments` by pixel and notes where each pixel's begin.
    fn new(mut fragments: Vec<Fragment>, columns: u32, rows: u32, tolerance_mm: f32) -> Self {
        fragments.sort_unstable_by_key(|f| f.pixel);
        let mut start = vec![0u32; (columns * rows) as usize + 1];
        for f in &fragments {
            start[f.pixel as usize + 1] += 1;
        }
        for p in 0..start.len() - 1 {
            start[p + 1] += start[p];
        }
        FragmentLookup {
            start,
            fragments,
            columns,
            rows,
            tolerance_mm,
        }
    }

    /// The fragments at `point`'s projector pixel that conflict with it: their surface, and
    /// how (being occluded takes precedence).
    fn clashes(&self, point: ProjectedPoint) -> impl Iterator<Item = (u32, Conflict)> + '_ {
        let (u, v) = (point.uv[0].round(), point.uv[1].round());
        let at = if u < 0.0 || v < 0.0 || u >= self.columns as f32 || v >= self.rows as f32 {
            &[][..]
        } else {
            let pixel = (v as u32 * self.columns + u as u32) as usize;
            &self.fragments[self.start[pixel] as usize..self.start[pixel + 1] as usize]
        };
        at.iter().filter_map(move |f| {
            if f.far_mm < point.depth_mm - self.tolerance_mm {
                Some((f.surface, Conflict::Occluded))
            } else if f.near_mm > point.depth_mm + self.tolerance_mm {
                Some((f.surface, Conflict::Occluding))
            } else {
                None
            }
        })
    }
}

/// A fragment of another surface on a point's projector ray that conflicts with it.
#[derive(Clone, Copy, Debug)]
struct Clash {
    point: u32,
    /// The fragment's surface.
    surface: u32,
    conflict: Conflict,
}

/// Every point's clashes, looked up once and grouped by the point's surface: the surfaces are
/// then trusted one by one, and only the few points with a clash are looked at again.
struct Clashes {
    /// Surface `s`'s clashes are `clashes[start[s]..start[s + 1]]`, by point.
    start: Vec<u32>,
    clashes: Vec<Clash>,
}

impl Clashes {
    /// The clashes of every point on one of the `surfaces` with the others' fragments.
    fn find(
        lookup: &FragmentLookup,
        projected: &[Option<ProjectedPoint>],
        surface_of: &[u32],
        surfaces: usize,
    ) -> Clashes {
        let mut clashes: Vec<Clash> = (0..projected.len())
            .into_par_iter()
            .flat_map_iter(|i| {
                let own = surface_of[i];
                projected[i]
                    .filter(|_| own != NONE)
                    .into_iter()
                    .flat_map(move |p| lookup.clashes(p))
                    .filter(move |&(s, _)| s != own)
                    .map(move |(surface, conflict)| Clash {
                        point: i as u32,
                        surface,
                        conflict,
                    })
            })
            .collect();
        // Stable: by point within a surface.
        clashes.sort_by_key(|c| surface_of[c.point as usize]);
        let mut start = vec![0u32; surfaces + 1];
        for c in &clashes {
            start[surface_of[c.point as usize] as usize + 1] += 1;
        }
        for s in 0..surfaces {
            start[s + 1] += start[s];
        }
        Clashes { start, clashes }
    }

    /// The points of surface `s` that conflict with the other surfaces `consider` accepts, and
    /// how; being occluded takes precedence.
    fn conflicts<'a>(
        &'a self,
        s: usize,
        consider: impl Fn(u32) -> bool + 'a,
    ) -> impl Iterator<Item = (usize, Conflict)> + 'a {
        self.clashes[self.start[s] as usize..self.start[s + 1] as usize]
            .chunk_by(|a, b| a.point == b.point)
            .filter_map(move |of_point| {
                let mut found = None;
                for c in of_point.iter().filter(|c| consider(c.surface)) {
                    if c.conflict == Conflict::Occluded {
                        found = Some(Conflict::Occluded);
                        break;
                    }
                    found = Some(Conflict::Occluding);
                }
                found.map(|f| (of_point[0].point as usize, f))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fsm_geometry::{BrownConrady, Intrinsics, MeasurementVolume, Pinhole, Pose};
    use nalgebra::Vector3;

    /// A camera at the origin and a projector 200 mm to its right, both aimed at (0, 0, 500).
    fn calibration() -> Calibration {
        let pinhole = |name: &'static str, w: u32, h: u32, f: f64| {
            Pinhole::new(
                name,
                w,
                h,
                Intrinsics {
                    fx_px: f,
                    fy_px: f,
                    cx_px: (w as f64 - 1.0) / 2.0,
                    cy_px: (h as f64 - 1.0) / 2.0,
                },
                BrownConrady::NONE,
            )
            .expect("valid pinhole")
        };
        Calibration {
            camera: pinhole("camera", 64, 48, 128.0),
            projector: pinhole("projector", 256, 256, 400.0),
            pose: Pose::looking_at(
                Point3::new(200.0, 0.0, 0.0),
                Point3::new(0.0, 0.0, 500.0),
                Vector3::y(),
            )
            .expect("valid pose"),
            volume: MeasurementVolume::new(300.0, 800.0).expect("valid volume"),
        }
    }

    /// The point pixel `(x, y)` sees on the plane `z = depth`.
    fn on_plane(calibration: &Calibration, x: usize, y: usize, depth_mm: f64) -> [f32; 3] {
        let ray = calibration
            .camera
            .ray(nalgebra::Point2::new(x as f64, y as f64))
            .expect("ray");
        let p = ray * (depth_mm / ray.z);
        [p.x as f32, p.y as f32, p.z as f32]
    }

    #[test]
    fn a_patch_in_front_of_a_wall_on_the_same_projector_rays_is_fictitious() {
        let c = calibration();
        let (w, h) = (64, 48);
        // A wall at 500 mm seen by every pixel, except a patch of pixels that chose a point
        // 60 mm nearer: on projector rays that also light the wall, in front of it.
        let patch = |x: usize, y: usize| (20..30).contains(&x) && (15..25).contains(&y);
        let points: Vec<Option<[f32; 3]>> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                Some(on_plane(&c, x, y, if patch(x, y) { 440.0 } else { 500.0 }))
            })
            .collect();
        let fictitious = fictitious_points(&c, w, h, &points, &VisibilityParams::for_epsilon(4.0));
        let flagged_patch = (0..w * h)
            .filter(|&i| patch(i % w, i / w) && fictitious[i])
            .count();
        let flagged_wall = (0..w * h)
            .filter(|&i| !patch(i % w, i / w) && fictitious[i])
            .count();
        assert_eq!(flagged_patch, 100, "the whole patch is fictitious");
        assert_eq!(flagged_wall, 0, "the wall is real");
    }

    #[test]
    fn a_consistent_scene_keeps_every_point() {
        let c = calibration();
        let (w, h) = (64, 48);
        // A box in front of a wall, with the wall in the box's projector shadow left empty:
        // every point is the first surface on its projector ray.
        let boxed = |x: usize, y: usize| (20..30).contains(&x) && (15..25).contains(&y);
        let wall: Vec<Option<[f32; 3]>> = (0..w * h)
            .map(|i| Some(on_plane(&c, i % w, i / w, 500.0)))
            .collect();
        let box_front: Vec<Option<[f32; 3]>> = (0..w * h)
            .map(|i| Some(on_plane(&c, i % w, i / w, 440.0)))
            .collect();
        let in_shadow = |p: &[f32; 3]| {
            // Wall points whose projector ray passes through the box's front face.
            let pp = c
                .projector_point_of(&Point3::new(p[0] as f64, p[1] as f64, p[2] as f64))
                .expect("projects");
            (0..w * h).any(|i| {
                boxed(i % w, i / w) && {
                    let q = box_front[i].expect("point");
                    let pq = c
                        .projector_point_of(&Point3::new(q[0] as f64, q[1] as f64, q[2] as f64))
                        .expect("projects");
                    (pq - pp).norm() < 1.5
                }
            })
        };
        let points: Vec<Option<[f32; 3]>> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if boxed(x, y) {
                    box_front[i]
                } else if in_shadow(&wall[i].expect("point")) {
                    None
                } else {
                    wall[i]
                }
            })
            .collect();
        let fictitious = fictitious_points(&c, w, h, &points, &VisibilityParams::for_epsilon(4.0));
        assert_eq!(fictitious.iter().filter(|&&f| f).count(), 0);
    }

    #[test]
    fn the_test_gives_the_same_points_on_one_thread_and_on_two() {
        let c = calibration();
        let (w, h) = (64, 48);
        // A wall with a patch in front of it, a patch behind it, a patch that leans away from
        // the projector and pixels without a point: surfaces of every kind, in conflict.
        let points: Vec<Option<[f32; 3]>> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                match (x, y) {
                    (20..30, 15..25) => Some(on_plane(&c, x, y, 440.0)),
                    (40..50, 10..20) => Some(on_plane(&c, x, y, 560.0)),
                    (5..15, 30..40) => Some(on_plane(&c, x, y, 480.0 - 6.0 * x as f64)),
                    (_, 44..) => None,
                    _ => Some(on_plane(&c, x, y, 500.0)),
                }
            })
            .collect();
        let on = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a pool")
                .install(|| {
                    fictitious_points(&c, w, h, &points, &VisibilityParams::for_epsilon(4.0))
                })
        };
        let one = on(1);
        assert!(one.iter().any(|&f| f) && one.iter().any(|&f| !f));
        assert_eq!(one, on(2));
    }

    #[test]
    fn a_point_occluded_by_a_surface_considered_conflicts_as_occluded() {
        let clash = |point: u32, surface: u32, conflict: Conflict| Clash {
            point,
            surface,
            conflict,
        };
        // Surface 0's point 3 is in front of surface 1 and behind surface 2; point 7 is behind
        // surface 2. Surface 1 has no clash.
        let clashes = Clashes {
            start: vec![0, 3, 3],
            clashes: vec![
                clash(3, 1, Conflict::Occluding),
                clash(3, 2, Conflict::Occluded),
                clash(7, 2, Conflict::Occluded),
            ],
        };
        let of = |s: usize, consider: &dyn Fn(u32) -> bool| -> Vec<(usize, Conflict)> {
            clashes.conflicts(s, consider).collect()
        };
        assert_eq!(
            of(0, &|_| true),
            [(3, Conflict::Occluded), (7, Conflict::Occluded)]
        );
        assert_eq!(of(0, &|o| o == 1), [(3, Conflict::Occluding)]);
        assert_eq!(of(0, &|_| false), []);
        assert_eq!(of(1, &|_| true), []);
    }

    #[test]
    fn a_point_outside_the_projectors_image_is_fictitious() {
        let c = calibration();
        // Far to the left and below, where no projector ray goes.
        let points = vec![Some([-900.0, 900.0, 500.0]), None];
        let fictitious = fictitious_points(&c, 2, 1, &points, &VisibilityParams::for_epsilon(4.0));
        assert_eq!(fictitious, vec![true, false]);
    }
}
