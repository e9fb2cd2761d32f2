//! The measured surface: one point (or none, with the reason) per pixel after selection and
//! the projector-visibility test, with its column and the direct / indirect illumination
//! images (eqs. 12–13).

use fsm_geometry::Calibration;
use fsm_io::candidate_image::CandidateImage;
use rayon::prelude::*;
use serde::Serialize;

use crate::continuation::{LocalPlane, Window, HALF_WINDOW_PX, SCATTER_FACTOR};
use crate::mirror::{mirror_images, Mirror, MirrorParams};
use crate::ply::PlyPoint;
use crate::selection::{
    distance_mm, neighbours, select, CandidateField, Selection, SelectionParams,
};
use crate::visibility::{fictitious_points, VisibilityParams};

/// Why a pixel has no point: every pixel without one has a reason on record.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NoPoint {
    /// The capture held no valid samples of it: its row was corrupt or missing in the dump
    /// and skipped on request ([`fsm_core::PixelFlags::NO_DATA`]).
    NoData,
    /// The decoder found no light on it.
    NoLight,
    /// EFSM: lights of two blocks alias ([`fsm_core::PixelFlags::ALIASED`]).
    Aliased,
    /// Two touching lights the decoder could not split ([`fsm_core::PixelFlags::UNRESOLVED`]).
    Unresolved,
    /// Every candidate triangulates outside the measurement volume (or the pixel has no ray).
    OutsideVolume,
    /// The chosen point has chosen neighbours, none of them on its surface.
    Isolated,
    /// The chosen light's quality is below [`SelectionParams::min_quality`].
    LowQuality,
    /// The projector cannot light the chosen point directly ([`crate::visibility`]).
    Fictitious,
    /// A plane mirror hides the chosen point from the camera or the projector: it is a
    /// virtual image ([`crate::mirror`]).
    BehindMirror,
    /// The pixel straddles a depth edge: a neighbour chose a point on another surface, the
    /// pixel holds that surface's light too and the neighbour not the pixel's, so its
    /// footprint sees both sides and its point may belong to either. Or its point continues
    /// none of its neighbours' surfaces ([`Surface::drop_unconfirmed`]): it straddles a crease, and
    /// its light's centroid lies on neither side.
    Edge,
    /// No side of its neighbourhood holds a surface measured finely enough to confirm its
    /// point ([`Surface::drop_unconfirmed`]): fewer than
    /// [`MIN_NEIGHBOURS`](crate::continuation::MIN_NEIGHBOURS) points on every
    /// side, or too scattered to tell surfaces `ε` apart. A speck, a strip one or two pixels
    /// wide, or a patch too noisy to vouch for itself.
    Unconfirmed,
}

impl NoPoint {
    /// Every reason, in the order of their codes (1, 2, …; [`NoPoint::code`]).
    pub const ALL: [NoPoint; 11] = [
        NoPoint::NoData,
        NoPoint::NoLight,
        NoPoint::Aliased,
        NoPoint::Unresolved,
        NoPoint::OutsideVolume,
        NoPoint::Isolated,
        NoPoint::LowQuality,
        NoPoint::Fictitious,
        NoPoint::BehindMirror,
        NoPoint::Edge,
        NoPoint::Unconfirmed,
    ];

    /// The reason's code in `no_point.tiff`: its place in [`NoPoint::ALL`] plus one (0 is a
    /// pixel with a point).
    pub fn code(self) -> u8 {
        1 + NoPoint::ALL
            .iter()
            .position(|&r| r == self)
            .expect("listed") as u8
    }

    /// The reason's name, its key in `summary.json`'s `no_point`.
    pub fn name(self) -> &'static str {
        match self {
            NoPoint::NoData => "no_data",
            NoPoint::NoLight => "no_light",
            NoPoint::Aliased => "aliased",
            NoPoint::Unresolved => "unresolved",
            NoPoint::OutsideVolume => "outside_volume",
            NoPoint::Isolated => "isolated",
            NoPoint::LowQuality => "low_quality",
            NoPoint::Fictitious => "fictitious",
            NoPoint::BehindMirror => "behind_mirror",
            NoPoint::Edge => "edge",
            NoPoint::Unconfirmed => "unconfirmed",
        }
    }
}

/// Pixels without a point, by reason (`summary.json`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct NoPointCounts {
    /// See [`NoPoint::NoData`].
    pub no_data: usize,
    /// See [`NoPoint::NoLight`].
    pub no_light: usize,
    /// See [`NoPoint::Aliased`].
    pub aliased: usize,
    /// See [`NoPoint::Unresolved`].
    pub unresolved: usize,
    /// See [`NoPoint::OutsideVolume`].
    pub outside_volume: usize,
    /// See [`NoPoint::Isolated`].
    pub isolated: usize,
    /// See [`NoPoint::LowQuality`].
    pub low_quality: usize,
    /// See [`NoPoint::Fictitious`].
    pub fictitious: usize,
    /// See [`NoPoint::BehindMirror`].
    pub behind_mirror: usize,
    /// See [`NoPoint::Edge`].
    pub edge: usize,
    /// See [`NoPoint::Unconfirmed`].
    pub unconfirmed: usize,
}

/// What the points around a pixel say of its point ([`Surface::drop_unconfirmed`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Support {
    /// It lies on the plane of a side that discriminates.
    Continues,
    /// Every side that discriminates predicts another depth.
    Straddles,
    /// No side discriminates: too few points there, or too scattered.
    Unconfirmed,
}

/// The result of a scan.
#[derive(Clone, Debug, PartialEq)]
pub struct Surface {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// The chosen point of every pixel, camera frame, mm.
    pub point_mm: Vec<Option<[f32; 3]>>,
    /// The chosen candidate's projector column.
    pub column: Vec<Option<f32>>,
    /// Why a pixel has no point; `None` where it has one.
    pub no_point: Vec<Option<NoPoint>>,
    /// The quality of every point: its light's amplitude over the noise RMS of a dark pixel's
    /// amplitude ([`fsm_io::plan_file::MethodPlan::dark_amplitude_noise_dn`]), a
    /// signal-to-noise ratio. `NaN` where there is no point.
    pub quality: Vec<f32>,
    /// `I_d` (eq. 12), sensor DN.
    pub direct: Vec<f32>,
    /// `I_id` (eq. 13), sensor DN.
    pub indirect: Vec<f32>,
    /// Candidates that triangulated inside the measurement volume.
    pub candidates: usize,
    /// The plane mirrors found ([`crate::mirror`]).
    pub mirrors: Vec<Mirror>,
}

impl Surface {
    /// Selects the direct candidate of every pixel of `field` and gathers its point;
    /// `before[i]` is why pixel `i` has no candidate in `field`, if it has none.
    pub fn select(
        field: &CandidateField,
        before: &[Option<NoPoint>],
        params: &SelectionParams,
    ) -> Surface {
        let selection: Selection = select(field, params);
        let pixels = field.width() * field.height();
        assert_eq!(before.len(), pixels, "one reason slot per pixel");
        let mut surface = Surface {
            width: field.width(),
            height: field.height(),
            point_mm: vec![None; pixels],
            column: vec![None; pixels],
            no_point: before.to_vec(),
            quality: vec![f32::NAN; pixels],
            direct: selection.direct,
            indirect: selection.indirect,
            candidates: field.len(),
            mirrors: Vec::new(),
        };
        for (i, choice) in selection.choice.iter().enumerate() {
            let labels = field.labels(i % field.width(), i / field.width());
            match choice {
                Some(c) => {
                    let label = labels[*c as usize];
                    surface.point_mm[i] = Some(label.point_mm);
                    surface.column[i] = Some(label.column);
                }
                None if !labels.is_empty() => surface.no_point[i] = Some(NoPoint::Isolated),
                None => {
                    surface.no_point[i].get_or_insert(NoPoint::NoLight);
                }
            }
        }
        surface
    }

    /// Removes the points of the pixels that `edges` ([`Surface::edges`]) marks as straddling
    /// a depth edge ([`NoPoint::Edge`]). The marks are made on the selection's choices, before
    /// any is dropped: a neighbour whose point later goes (a virtual image, a fictitious
    /// surface) still received the other side's light, so the pixel beside it still
    /// straddles.
    pub fn drop_edges(&mut self, edges: &[bool]) {
        for (i, e) in edges.iter().enumerate() {
            if *e && self.point_mm[i].is_some() {
                self.drop_point(i, NoPoint::Edge);
            }
        }
    }

    /// The pixels that straddle a depth edge: one of the 8 neighbours chose a point more
    /// than `reach_mm` from the pixel's, the pixel holds a candidate within `reach_mm` of it,
    /// and the neighbour holds none within `reach_mm` of the pixel's point. The last condition
    /// tells an edge from two neighbours that chose differently among the same two lights:
    /// across an edge only the pixel that straddles it holds both.
    pub fn edges(&self, field: &CandidateField, reach_mm: f32) -> Vec<bool> {
        let (w, h) = (self.width, self.height);
        let near = |a: [f32; 3], b: [f32; 3]| distance_mm(&a, &b) <= reach_mm;
        (0..w * h)
            .into_par_iter()
            .map(|i| {
                let Some(own) = self.point_mm[i] else {
                    return false;
                };
                let labels = field.labels(i % w, i / w);
                neighbours(i, w, h).flatten().any(|j| {
                    self.point_mm[j].is_some_and(|other| {
                        !near(own, other)
                            && labels.iter().any(|l| near(l.point_mm, other))
                            && !field
                                .labels(j % w, j / w)
                                .iter()
                                .any(|l| near(l.point_mm, own))
                    })
                })
            })
            .collect()
    }

    /// What the points on each side of pixel `i` (left, right, above, below; [`LocalPlane`])
    /// say of its point, if it has one. Only the sides whose plane discriminates (`epsilon_mm`)
    /// have a say: the point continues one of them, or straddles a crease or an edge the
    /// selection's choices do not show (at the corner of a V-groove a pixel sees both facets,
    /// and its light's centroid lies on neither), or no side vouches for it.
    fn support(&self, i: usize, epsilon_mm: f32) -> Option<Support> {
        let point = self.point_mm[i]?;
        let mut judged = false;
        for side in Window::SIDES {
            let plane = LocalPlane::fit(&self.point_mm, self.width, i, side)
                .filter(|p| p.discriminates(epsilon_mm));
            if let Some(plane) = plane {
                let off_mm = (point[2] as f64 - plane.depth_mm).abs();
                if plane.deviation(point) <= SCATTER_FACTOR || off_mm <= 0.25 * epsilon_mm as f64 {
                    return Some(Support::Continues);
                }
                judged = true;
            }
        }
        Some(if judged {
            Support::Straddles
        } else {
            Support::Unconfirmed
        })
    }

    /// Keeps only the points that continue the surface of their neighbourhood: each must lie
    /// on the plane of one side of it (left, right, above, below) that discriminates
    /// ([`LocalPlane::discriminates`]). A point that continues no such side straddles a
    /// crease ([`NoPoint::Edge`]); one that no side can judge is [`NoPoint::Unconfirmed`]: a
    /// point is right or absent, and a point nothing around it measures could be either (a
    /// strip one pixel wide along a groove's corner, its neighbours on both sides dropped as
    /// fictitious, has no side with six points).
    ///
    /// Judged again near the points dropped until none goes: every point left is confirmed
    /// by the points left. Each pass judges every open pixel before dropping any, so the
    /// result is the same on any number of threads.
    pub fn drop_unconfirmed(&mut self, epsilon_mm: f32) {
        let (w, h) = (self.width, self.height);
        let mut open: Vec<usize> = (0..w * h).filter(|&i| self.point_mm[i].is_some()).collect();
        while !open.is_empty() {
            let verdicts: Vec<(usize, NoPoint)> = open
                .par_iter()
                .filter_map(|&i| match self.support(i, epsilon_mm)? {
                    Support::Continues => None,
                    Support::Straddles => Some((i, NoPoint::Edge)),
                    Support::Unconfirmed => Some((i, NoPoint::Unconfirmed)),
                })
                .collect();
            let mut near = vec![false; w * h];
            let r = HALF_WINDOW_PX;
            for &(i, reason) in &verdicts {
                self.drop_point(i, reason);
                let (x, y) = (i % w, i / w);
                for ny in y.saturating_sub(r)..(y + r + 1).min(h) {
                    for nx in x.saturating_sub(r)..(x + r + 1).min(w) {
                        near[ny * w + nx] = true;
                    }
                }
            }
            open = (0..w * h)
                .filter(|&i| near[i] && self.point_mm[i].is_some())
                .collect();
        }
    }

    /// Gives every point its quality: its light's amplitude over `amplitude_noise_dn`.
    pub fn rate(&mut self, amplitude_noise_dn: f32) {
        for (i, q) in self.quality.iter_mut().enumerate() {
            *q = match self.point_mm[i] {
                Some(_) if amplitude_noise_dn > 0.0 => self.direct[i] / amplitude_noise_dn,
                _ => f32::NAN,
            };
        }
    }

    /// Removes the points whose quality is known and below `min_quality`.
    pub fn drop_below(&mut self, min_quality: f32) {
        for i in 0..self.quality.len() {
            if self.quality[i] < min_quality {
                self.drop_point(i, NoPoint::LowQuality);
            }
        }
    }

    /// Takes pixel `i`'s point away for `reason`; its light counts as indirect (eq. 13).
    fn drop_point(&mut self, i: usize, reason: NoPoint) {
        self.point_mm[i] = None;
        self.column[i] = None;
        self.quality[i] = f32::NAN;
        self.no_point[i] = Some(reason);
        self.indirect[i] += self.direct[i];
        self.direct[i] = 0.0;
    }

    /// Removes the points the projector cannot light directly ([`crate::visibility`]).
    pub fn drop_fictitious(&mut self, calibration: &Calibration, params: &VisibilityParams) {
        let fictitious =
            fictitious_points(calibration, self.width, self.height, &self.point_mm, params);
        for (i, f) in fictitious.iter().enumerate() {
            if *f {
                self.drop_point(i, NoPoint::Fictitious);
            }
        }
    }

    /// Removes the points a plane mirror hides from the camera or the projector
    /// ([`crate::mirror`]), and records the mirrors found.
    pub fn drop_mirror_images(
        &mut self,
        calibration: &Calibration,
        candidates: &CandidateImage,
        params: &MirrorParams,
    ) {
        let (mirrors, fictitious) = mirror_images(
            calibration,
            candidates,
            &self.point_mm,
            &self.column,
            params,
        );
        for (i, f) in fictitious.iter().enumerate() {
            if *f {
                self.drop_point(i, NoPoint::BehindMirror);
            }
        }
        self.mirrors = mirrors;
    }

    /// Pixels with a point.
    pub fn points(&self) -> usize {
        self.point_mm.iter().filter(|p| p.is_some()).count()
    }

    /// Pixels without a point, by reason.
    pub fn no_point_counts(&self) -> NoPointCounts {
        let mut counts = NoPointCounts::default();
        for reason in self.no_point.iter().flatten() {
            *match reason {
                NoPoint::NoData => &mut counts.no_data,
                NoPoint::NoLight => &mut counts.no_light,
                NoPoint::Aliased => &mut counts.aliased,
                NoPoint::Unresolved => &mut counts.unresolved,
                NoPoint::OutsideVolume => &mut counts.outside_volume,
                NoPoint::Isolated => &mut counts.isolated,
                NoPoint::LowQuality => &mut counts.low_quality,
                NoPoint::Fictitious => &mut counts.fictitious,
                NoPoint::BehindMirror => &mut counts.behind_mirror,
                NoPoint::Edge => &mut counts.edge,
                NoPoint::Unconfirmed => &mut counts.unconfirmed,
            } += 1;
        }
        counts
    }

    /// Every pixel's [`NoPoint::code`], 0 where it has a point: the record of why each
    /// pixel without a point has none (`no_point.tiff`).
    pub fn no_point_codes(&self) -> Vec<u8> {
        self.no_point
            .iter()
            .map(|r| r.map_or(0, NoPoint::code))
            .collect()
    }

    /// Depth (camera `z`, mm) per pixel, `NaN` where none.
    pub fn depth_mm(&self) -> Vec<f32> {
        self.point_mm
            .iter()
            .map(|p| p.map_or(f32::NAN, |p| p[2]))
            .collect()
    }

    /// The points as PLY vertices.
    pub fn ply_points(&self) -> Vec<PlyPoint> {
        self.point_mm
            .iter()
            .enumerate()
            .filter_map(|(i, p)| {
                p.map(|p| PlyPoint {
                    point_mm: p,
                    intensity: self.direct[i],
                    quality: self.quality[i],
                    pixel: [(i % self.width) as u16, (i / self.width) as u16],
                })
            })
            .collect()
    }
}

impl Surface {
    /// Gives the pixels whose choice the projector cannot light ([`NoPoint::Fictitious`])
    /// another of their candidates where it continues their neighbours' surface; returns them.
    ///
    /// Grown outwards from the points kept, breadth first: a candidate continues the surface
    /// when it lies within [`SCATTER_FACTOR`] scatters of the plane of the points around it
    /// ([`LocalPlane`]), and only where that tolerance is below `ε/4`, so that the light of
    /// another surface (`ε` or more away, the selection's discrimination distance) cannot pass
    /// for it. (Up to `ε/2`, the glossy V gained 17 wrong points on one seed; up to `ε/4`, none
    /// on three.) A wall beside an object's shadow, where a mirror's light continued the
    /// fictitious surface of the shadow and won the selection, gets its direct light back
    /// (`sphere_mirror`, EFSM: 94.9% of the directly lit pixels with a right point, 97.1%
    /// after); the shadow itself, which holds no light on the wall, does not.
    fn regrow_fictitious(&mut self, field: &CandidateField, epsilon_mm: f32) -> Vec<usize> {
        let (w, h) = (self.width, self.height);
        let mut open: Vec<bool> = self
            .no_point
            .iter()
            .map(|r| *r == Some(NoPoint::Fictitious))
            .collect();
        let touches = |s: &Surface, i: usize| {
            neighbours(i, w, h)
                .flatten()
                .any(|j| s.point_mm[j].is_some())
        };
        let mut queue: std::collections::VecDeque<usize> = (0..w * h)
            .filter(|&i| open[i] && touches(self, i))
            .collect();
        let mut taken = Vec::new();
        while let Some(i) = queue.pop_front() {
            if !open[i] {
                continue;
            }
            let Some(plane) = LocalPlane::fit(&self.point_mm, w, i, Window::Around)
                .filter(|p| p.discriminates(epsilon_mm))
            else {
                continue;
            };
            let best = field
                .labels(i % w, i / w)
                .iter()
                .map(|l| (plane.deviation(l.point_mm), *l))
                .filter(|(d, _)| *d <= SCATTER_FACTOR)
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let Some((_, label)) = best else { continue };
            open[i] = false;
            taken.push(i);
            // The dropped choice's light went to the indirect image; it is all there now.
            self.point_mm[i] = Some(label.point_mm);
            self.column[i] = Some(label.column);
            self.no_point[i] = None;
            self.direct[i] = label.amplitude;
            self.indirect[i] -= label.amplitude;
            queue.extend(neighbours(i, w, h).flatten().filter(|&j| open[j]));
        }
        taken
    }

    /// The regrown pixels' points face the visibility test and the mirrors found, as the
    /// selection's choices did; a regrown point that fails either goes, for that reason.
    fn retest(&mut self, calibration: &Calibration, regrown: &[usize], params: &SelectionParams) {
        let fictitious = fictitious_points(
            calibration,
            self.width,
            self.height,
            &self.point_mm,
            &VisibilityParams::for_epsilon(params.epsilon_mm),
        );
        let behind_mm = MirrorParams::for_epsilon(params.epsilon_mm).behind_mm;
        for &i in regrown {
            let point = self.point_mm[i].expect("regrown");
            if fictitious[i] {
                self.drop_point(i, NoPoint::Fictitious);
            } else if self
                .mirrors
                .iter()
                .any(|m| m.hides_from(calibration, point, behind_mm))
            {
                self.drop_point(i, NoPoint::BehindMirror);
            }
        }
    }
}

impl SelectionParams {
    /// Defaults for a calibrated system: the pixel footprint at the middle of the measurement
    /// volume, depth over the camera's focal length.
    pub fn for_calibration(calibration: &Calibration) -> Self {
        let depth = 0.5 * (calibration.volume.near_mm() + calibration.volume.far_mm());
        let focal = calibration
            .camera
            .intrinsics()
            .fx_px
            .max(calibration.camera.intrinsics().fy_px);
        SelectionParams::for_footprint((depth / focal) as f32)
    }
}

/// Seconds spent in each stage after decoding.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StageTimes {
    /// Triangulating every candidate.
    pub triangulate_seconds: f64,
    /// Selecting the direct candidates and testing their visibility from the projector.
    pub select_seconds: f64,
}

impl Surface {
    /// Triangulates every candidate of `decoded` and selects the direct ones.
    pub fn reconstruct(
        decoded: &crate::decoded::DecodedImage,
        calibration: &Calibration,
        params: &SelectionParams,
    ) -> (Surface, StageTimes) {
        let started = std::time::Instant::now();
        let (field, before) = crate::triangulate::candidate_field(
            calibration,
            &decoded.candidates,
            params.drop_aliased,
        );
        let triangulated = std::time::Instant::now();
        let mut surface = Surface::select(&field, &before, params);
        // Judged on the selection's choices, before any is dropped: a pixel beside one whose
        // virtual point goes is still at the edge.
        let edges = params
            .drop_edges
            .then(|| surface.edges(&field, 2.0 * params.epsilon_mm));
        surface.rate(decoded.amplitude_noise_dn);
        surface.drop_below(params.min_quality);
        if params.drop_fictitious {
            surface.drop_fictitious(
                calibration,
                &VisibilityParams::for_epsilon(params.epsilon_mm),
            );
            surface.drop_mirror_images(
                calibration,
                &decoded.candidates,
                &MirrorParams::for_epsilon(params.epsilon_mm),
            );
            let regrown = surface.regrow_fictitious(&field, params.epsilon_mm);
            surface.retest(calibration, &regrown, params);
            // The regrown points are rated and filtered like the rest.
            surface.rate(decoded.amplitude_noise_dn);
            surface.drop_below(params.min_quality);
        }
        if let Some(edges) = edges {
            surface.drop_edges(&edges);
            // Only where the decoder measured each light (FSM, line scanning): the codes of
            // phase shift, Micro Phase Shifting and Code Ensemble name columns with unwrapping
            // and quantisation errors, for which the comparison reports every point they decode.
            if decoded.measured_lights {
                surface.drop_unconfirmed(params.epsilon_mm);
            }
        }
        let times = StageTimes {
            triangulate_seconds: (triangulated - started).as_secs_f64(),
            select_seconds: triangulated.elapsed().as_secs_f64(),
        };
        (surface, times)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::selection::Label;

    #[test]
    fn a_point_below_the_least_quality_loses_it_with_its_reason_and_keeps_its_light() {
        let label = |amplitude: f32| Label {
            point_mm: [0.0, 0.0, 500.0],
            amplitude,
            column: 10.0,
        };
        // Three pixels far apart (no neighbours): lights of 5, 50 and 500 DN.
        let field = CandidateField::from_fn(5, 1, |x, _| match x {
            0 => vec![label(5.0)],
            2 => vec![label(50.0)],
            4 => vec![label(500.0)],
            _ => vec![],
        });
        let before = [
            None,
            Some(NoPoint::NoLight),
            None,
            Some(NoPoint::NoLight),
            None,
        ];
        let mut s = Surface::select(&field, &before, &SelectionParams::for_footprint(0.5));
        s.rate(2.0);
        assert_eq!(s.quality[4], 250.0);
        s.drop_below(20.0);
        assert_eq!(s.point_mm[0], None);
        assert_eq!(s.no_point[0], Some(NoPoint::LowQuality));
        assert_eq!((s.direct[0], s.indirect[0]), (0.0, 5.0));
        assert_eq!(s.quality[2], 25.0);
        assert!(s.point_mm[2].is_some() && s.point_mm[4].is_some());
        assert_eq!(s.no_point_counts().low_quality, 1);
        assert_eq!(s.points() + 3, 5);
        // A scale of 0 (no sensor gives one: code rounding alone is 0.29 DN) rates nothing.
        let mut unrated = Surface::select(&field, &before, &SelectionParams::for_footprint(0.5));
        unrated.rate(0.0);
        unrated.drop_below(20.0);
        assert_eq!(unrated.points(), 3);
    }

    /// A row of six pixels 1 mm apart with the given labels (`(x offset, depth)` each), the
    /// first label chosen; the edges at a reach of 2 mm.
    fn edges_of(pixels: [&[(f32, f32)]; 6]) -> Vec<bool> {
        let label = |x: usize, (dx, z): (f32, f32)| Label {
            point_mm: [x as f32 + dx, 0.0, z],
            amplitude: 100.0,
            column: z,
        };
        let field =
            CandidateField::from_fn(6, 1, |x, _| pixels[x].iter().map(move |&l| label(x, l)));
        let mut s = Surface::select(&field, &[None; 6], &SelectionParams::for_footprint(0.5));
        for (x, p) in pixels.iter().enumerate() {
            s.point_mm[x] = Some(label(x, p[0]).point_mm);
        }
        s.edges(&field, 2.0)
    }

    #[test]
    fn the_pixel_that_holds_the_light_of_both_sides_of_a_depth_edge_is_the_edge() {
        // A surface at 400 mm, another at 500 mm; pixel 2 straddles: it chose the near side
        // and also holds the far side's light.
        let near: &[(f32, f32)] = &[(0.0, 400.0)];
        let far: &[(f32, f32)] = &[(0.0, 500.0)];
        let straddling: &[(f32, f32)] = &[(0.0, 400.0), (0.9, 500.0)];
        assert_eq!(
            edges_of([near, near, straddling, far, far, far]),
            [false, false, true, false, false, false]
        );
        // Without the far side's light it is no edge, only a jump.
        assert_eq!(edges_of([near, near, near, far, far, far]), [false; 6]);
        // Every pixel holds both lights and neighbours chose differently (as under glossy
        // interreflection): no pixel holds what the others do not.
        let a: &[(f32, f32)] = &[(0.0, 400.0), (0.0, 450.0)];
        let b: &[(f32, f32)] = &[(0.0, 450.0), (0.0, 400.0)];
        assert_eq!(edges_of([a, a, a, b, b, b]), [false; 6]);
    }

    #[test]
    fn a_choice_the_projector_cannot_light_gives_way_to_the_light_that_continues_the_wall() {
        // A 7 × 7 wall at 500 mm (with a scatter of a few µm); pixels 24 and 40 also hold a
        // mirror's light that triangulates 30 mm nearer, 40 nothing else (its wall is in a
        // shadow).
        let wall = |x: usize, y: usize| 500.0 + 0.004 * ((x * 7 + y * 3) % 5) as f32;
        let label = |x: usize, y: usize, z: f32, amplitude: f32| Label {
            point_mm: [x as f32, y as f32, z],
            amplitude,
            column: z,
        };
        let field = CandidateField::from_fn(7, 7, |x, y| {
            let mirror = label(x, y, 470.0, 300.0);
            match y * 7 + x {
                24 => vec![mirror, label(x, y, wall(x, y), 100.0)],
                40 => vec![mirror],
                _ => vec![label(x, y, wall(x, y), 100.0)],
            }
        });
        let params = SelectionParams::for_footprint(0.5);
        let mut s = Surface::select(&field, &[None; 49], &params);
        // Both chose the mirror's light, and the visibility test took it.
        for i in [24, 40] {
            s.point_mm[i] = Some(label(i % 7, i / 7, 470.0, 300.0).point_mm);
            s.column[i] = Some(470.0);
            s.direct[i] = 300.0;
            s.indirect[i] = if i == 24 { 100.0 } else { 0.0 };
            s.drop_point(i, NoPoint::Fictitious);
        }
        assert_eq!(s.regrow_fictitious(&field, params.epsilon_mm), vec![24]);
        assert_eq!(s.point_mm[24], Some([3.0, 3.0, wall(3, 3)]));
        assert_eq!(
            (s.no_point[24], s.direct[24], s.indirect[24]),
            (None, 100.0, 300.0)
        );
        assert_eq!(
            (s.point_mm[40], s.no_point[40]),
            (None, Some(NoPoint::Fictitious))
        );
    }

    #[test]
    fn the_pixel_at_a_grooves_corner_whose_light_lies_on_neither_facet_straddles_it() {
        // A 9 × 9 V-groove: facets falling 1 mm a pixel towards the corner at column 4 (with a
        // scatter of a few µm). The corner's pixels measured the centroid of both facets'
        // light, 1.5 mm off the corner, except in row 2, where it is right.
        let depth = |x: usize, y: usize| {
            let corner = if x == 4 && y != 2 { 1.5 } else { 0.0 };
            500.0 - (x as f32 - 4.0).abs() + 0.004 * ((x * 7 + y * 3) % 5) as f32 + corner
        };
        // ε is 2 mm here: a point 0.5 mm (ε/4) or more off every facet's plane is on neither.
        let params = SelectionParams::for_footprint(0.5);
        assert_eq!(params.epsilon_mm, 2.0);
        let mut s = surface_of(9, 9, |x, y| Some(depth(x, y)));
        s.drop_unconfirmed(params.epsilon_mm);
        let dropped: Vec<(usize, usize, Option<NoPoint>)> = (0..81)
            .filter(|&i| s.point_mm[i].is_none())
            .map(|i| (i % 9, i / 9, s.no_point[i]))
            .collect();
        assert_eq!(
            dropped,
            [0, 1, 3, 4, 5, 6, 7, 8].map(|y| (4, y, Some(NoPoint::Edge)))
        );
    }

    /// A `w × h` surface whose pixel `(x, y)` has the point `(x, y, depth(x, y))` mm, or none.
    fn surface_of(w: usize, h: usize, depth: impl Fn(usize, usize) -> Option<f32>) -> Surface {
        let field = CandidateField::from_fn(w, h, |x, y| {
            depth(x, y).map(|z| Label {
                point_mm: [x as f32, y as f32, z],
                amplitude: 100.0,
                column: x as f32,
            })
        });
        let before: Vec<Option<NoPoint>> = (0..w * h)
            .map(|i| depth(i % w, i / w).is_none().then_some(NoPoint::NoLight))
            .collect();
        let mut s = Surface::select(&field, &before, &SelectionParams::for_footprint(0.5));
        // The choices as given, whatever the selection's isolated-choice pass made of them.
        for i in 0..w * h {
            s.point_mm[i] = depth(i % w, i / w).map(|z| [(i % w) as f32, (i / w) as f32, z]);
        }
        s
    }

    #[test]
    fn a_speck_and_a_strip_two_pixels_wide_are_unconfirmed_and_a_wall_keeps_every_point() {
        let wall =
            |x: usize, y: usize| 500.0 + 0.3 * x as f32 + 0.004 * ((x * 7 + y * 3) % 5) as f32;
        // A 14 × 10 image: a tilted wall over columns 0..6, and apart from it and from each
        // other a strip over columns 8..10 and a 2 × 2 speck.
        let depth = |x: usize, y: usize| match (x, y) {
            (0..6, _) => Some(wall(x, y)),
            (8..10, 0..8) => Some(450.0 + 0.004 * ((x + y) % 3) as f32),
            (12..14, 8..10) => Some(480.0),
            _ => None,
        };
        let mut s = surface_of(14, 10, depth);
        s.drop_unconfirmed(2.0);
        for i in 0..140 {
            let (x, y) = (i % 14, i / 14);
            let expected = match depth(x, y) {
                None => Some(NoPoint::NoLight),
                Some(_) if x < 6 => None,
                Some(_) => Some(NoPoint::Unconfirmed),
            };
            assert_eq!(s.no_point[i], expected, "pixel ({x}, {y})");
            assert_eq!(
                s.point_mm[i].is_some(),
                expected.is_none(),
                "pixel ({x}, {y})"
            );
        }
        assert_eq!(s.no_point_counts().unconfirmed, 16 + 4);
    }

    #[test]
    fn every_reason_has_its_code_and_its_summary_key() {
        let mut s = surface_of(3, 4, |_, _| Some(500.0));
        for (i, reason) in NoPoint::ALL.into_iter().enumerate() {
            assert_eq!(reason.code() as usize, i + 1);
            s.no_point[i] = Some(reason);
            s.point_mm[i] = None;
        }
        let codes = s.no_point_codes();
        assert_eq!(&codes[..11], &(1..=11).collect::<Vec<u8>>()[..]);
        assert_eq!(codes[11], 0, "the pixel with a point");
        // Each name is the key its count has in summary.json, and every key is a name.
        let json = serde_json::to_value(s.no_point_counts()).unwrap();
        assert_eq!(json.as_object().unwrap().len(), NoPoint::ALL.len());
        for reason in NoPoint::ALL {
            assert_eq!(json[reason.name()], 1, "{}", reason.name());
        }
    }
}
