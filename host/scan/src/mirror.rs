//! Plane mirrors: found from the virtual images they make, and what they hide removed.
//!
//! A pixel `q` that sees a plane mirror receives the light of the points the mirror shows it.
//! Where the projector lights such a point `W` through the mirror, `q`'s light of that path
//! triangulates to `X`, the mirror image of `W`: unfold both reflections and it is a surface
//! lit directly, consistent with camera and projector alike ([`crate::visibility`] cannot see
//! it). But where the projector also lights `W` directly, `q` receives that light too, and the
//! pixel `p` that sees `W` directly receives `W`'s mirrored light. So `q` and `p` hold the same
//! two projector columns in opposite roles: `q` chose the column of `X` and holds the one `p`
//! chose; `p` chose the column of `W` and holds the one `q` chose. The mirror is the plane
//! that bisects `X` and `W`, with the camera and the projector on `W`'s side.
//!
//! 1. *Vote*: every such pair votes for its bisecting plane (cells of 2° and `ε` in normal and
//!    offset). Columns do not fix a pixel's row, so each `q` votes with every `p` along the
//!    column's line: a real mirror collects one right vote per `q` on one plane, wrong partners
//!    spread. About 320 × 240 pixels of a grid vote, whatever the image's size.
//! 2. *Verify* the planes of most votes against the scan: reflect every chosen point in the
//!    plane and look for a measured point where the reflection lands whose pixel holds the
//!    two columns the other way round. The plane is refitted to the pairs that verify it
//!    (`fit_plane`), with a narrower search each time.
//! 3. *Judge*: a real mirror hides little besides virtual images that verify it. A plane that
//!    pairs of real points happen to bisect (mutual interreflection, or two points lit by each
//!    other's columns through a mirror) would hide real surface, of which few points verify
//!    it. A plane is a mirror when at least [`MirrorParams::min_share`] of the points it hides
//!    that hold two lights or more verify it. Its outline is the convex hull of where the
//!    verifying camera and projector rays cross it.
//! 4. *Remove*: a chosen point more than [`MirrorParams::behind_mm`] beyond a mirror whose
//!    segment to the camera or to the projector crosses the mirror inside its outline cannot be
//!    seen or lit directly: it is fictitious. This also takes the virtual images whose real
//!    counterpart the projector does not light directly (they verify nothing).
//!
//! What it cannot see: a mirror whose virtual images have no directly lit counterpart in the
//! image (nothing verifies it), and curved mirrors.

use fsm_geometry::Calibration;
use fsm_io::candidate_image::CandidateImage;
use nalgebra::{Matrix3, Point3, Vector3};
use rayon::prelude::*;

/// Parameters of the mirror search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MirrorParams {
    /// Columns within this of each other are the same light.
    pub column_tolerance: f32,
    /// Distance (mm) within which planes' offsets agree, a reflection lands on a measured
    /// point (twice this), and a point counts as on a plane when verifying it; pairs closer
    /// than four times this do not vote.
    pub tolerance_mm: f32,
    /// A point more than this (mm) beyond a mirror's plane, seen or lit through the mirror,
    /// is hidden by it; nearer, it may be a surface the mirror touches.
    pub behind_mm: f32,
    /// Angle (degrees) within which two planes' normals agree.
    pub angle_deg: f32,
    /// Pixels that must agree on a plane for it to be a mirror.
    pub min_pixels: usize,
    /// A mirror must be verified by at least this share of the points it hides that hold two
    /// lights or more (those that could verify it).
    pub min_share: f32,
    /// Mirrors looked for at most.
    pub max_mirrors: usize,
    /// Planes of most votes checked against the scan.
    pub hypotheses: usize,
}

impl MirrorParams {
    /// The search at the selection's scale `ε`.
    pub fn for_epsilon(epsilon_mm: f32) -> Self {
        MirrorParams {
            column_tolerance: 0.75,
            tolerance_mm: epsilon_mm,
            behind_mm: 1.0,
            angle_deg: 2.0,
            min_pixels: 50,
            min_share: 0.3,
            max_mirrors: 4,
            hypotheses: 32,
        }
    }
}

/// A mirror found: its plane `normal·Y = offset` (unit normal, towards the virtual images)
/// and its outline in the plane.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Mirror {
    /// Unit normal, camera frame; the camera and the projector are on its negative side.
    pub normal: [f32; 3],
    /// `normal · Y` of the plane's points, mm.
    pub offset_mm: f32,
    /// Pixels that verify it (or a piece of it: a plane fitted to part of it).
    pub pixels: usize,
    /// Convex outline in the plane's coordinates (along `axes`), mm.
    #[serde(skip)]
    outline: Vec<[f32; 2]>,
    /// Two unit vectors along the plane.
    #[serde(skip)]
    axes: [Vec3; 2],
}

/// A point or direction, camera frame, mm.
type Vec3 = Vector3<f32>;

/// Where the segment `from → to` crosses the plane `normal·Y = offset`, if it does.
fn crossing(from: Vec3, to: Vec3, normal: &Vec3, offset: f32) -> Option<Vec3> {
    let (a, b) = (normal.dot(&from) - offset, normal.dot(&to) - offset);
    if a * b >= 0.0 {
        return None;
    }
    Some(from + (to - from) * (a / (a - b)))
}

/// The plane bisecting `X` (pixel `q`'s chosen point) and `W` (pixel `p`'s), when the camera
/// and the projector are both on `W`'s side and their segments to `X` cross it: the unit
/// normal (towards `X`), the offset, and where the camera's and the projector's segments to `X`
/// cross it.
#[derive(Clone, Copy, Debug)]
struct Bisector {
    normal: Vec3,
    offset_mm: f32,
    /// `(X + W) / 2`, on the plane.
    midpoint: Vec3,
    /// `|X − W|`.
    length_mm: f32,
    camera_crossing: Vec3,
    projector_crossing: Vec3,
}

impl Bisector {
    fn of(x: Vec3, w: Vec3, projector: Vec3, min_mm: f32) -> Option<Bisector> {
        let d = x - w;
        let length = d.norm();
        if length < min_mm {
            return None;
        }
        let normal = d / length;
        let midpoint = (x + w) * 0.5;
        let offset_mm = normal.dot(&midpoint);
        // The camera is at the origin.
        if -offset_mm >= 0.0 || normal.dot(&projector) - offset_mm >= 0.0 {
            return None;
        }
        Some(Bisector {
            normal,
            offset_mm,
            midpoint,
            length_mm: length,
            camera_crossing: crossing(Vec3::zeros(), x, &normal, offset_mm)?,
            projector_crossing: crossing(projector, x, &normal, offset_mm)?,
        })
    }

    /// Its cell in the vote: normal's azimuth and elevation in steps of `angle_deg`, offset in
    /// steps of `offset_mm`.
    fn cell(&self, angle_deg: f32, offset_mm: f32) -> [i32; 3] {
        let n = self.normal;
        [
            ((n.y.atan2(n.x).to_degrees() / angle_deg).floor() as i32)
                .rem_euclid(azimuth_cells(angle_deg)),
            (n.z.clamp(-1.0, 1.0).asin().to_degrees() / angle_deg).floor() as i32,
            (self.offset_mm / offset_mm).floor() as i32,
        ]
    }
}

/// Cells of azimuth around the circle.
fn azimuth_cells(angle_deg: f32) -> i32 {
    (360.0 / angle_deg).round() as i32
}

/// The votes of a cell of plane space and the sums of their planes, in fixed point: integer
/// sums do not depend on the order of the votes, so the vote is the same on any number of
/// threads.
#[derive(Clone, Copy, Debug, Default)]
struct CellSum {
    /// `Σ normal · 2^24`.
    normal: [i64; 3],
    /// `Σ offset · 2^12`, mm.
    offset: i64,
    votes: u32,
}

impl CellSum {
    const NORMAL_ONE: f32 = (1 << 24) as f32;
    const MM_ONE: f32 = (1 << 12) as f32;

    fn add(&mut self, b: &Bisector) {
        for k in 0..3 {
            self.normal[k] += (b.normal[k] * Self::NORMAL_ONE).round() as i64;
        }
        self.offset += (b.offset_mm * Self::MM_ONE).round() as i64;
        self.votes += 1;
    }

    fn merge(&mut self, other: &CellSum) {
        for k in 0..3 {
            self.normal[k] += other.normal[k];
        }
        self.offset += other.offset;
        self.votes += other.votes;
    }

    /// The mean plane of the votes: unit normal and offset, mm.
    fn plane(&self) -> (Vec3, f32) {
        let n = Vec3::from(self.normal.map(|v| v as f32 / Self::NORMAL_ONE));
        let votes = self.votes.max(1) as f32;
        (n.normalize(), self.offset as f32 / Self::MM_ONE / votes)
    }
}

/// A multiplicative hash for the vote's cell keys (the standard hasher, built against
/// collision attacks, costs more than the vote's other work).
#[derive(Default)]
struct CellHasher(u64);

impl std::hash::Hasher for CellHasher {
    fn finish(&self) -> u64 {
        self.0
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }

    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x517c_c1b7_2722_0a95);
    }
}

/// Votes by cell key.
type Cells = std::collections::HashMap<u64, CellSum, std::hash::BuildHasherDefault<CellHasher>>;

fn key(cell: [i32; 3]) -> u64 {
    let part = |v: i32| (v as i64 + (1 << 20)) as u64 & ((1 << 21) - 1);
    part(cell[0]) << 42 | part(cell[1]) << 21 | part(cell[2])
}

/// The pixels of a `width × height` image whose coordinates are both multiples of `stride`,
/// row by row.
fn grid(width: usize, height: usize, stride: usize) -> impl Iterator<Item = usize> {
    (0..height)
        .step_by(stride)
        .flat_map(move |y| (0..width).step_by(stride).map(move |x| y * width + x))
}

/// The pixels that verify a plane, each with the pair that does.
type Verified = Vec<(usize, Bisector)>;

/// Every pair of a scan: pixel `q` holds, besides its chosen column `c1`, a column `c2` that
/// pixel `p` chose, and `p` holds `c1`.
struct Pairs<'a> {
    candidates: &'a CandidateImage,
    points: &'a [Option<[f32; 3]>],
    columns: &'a [Option<f32>],
    /// Chosen pixels of the voting grid by column.
    by_column: Vec<(f32, u32)>,
    projector: Vec3,
    params: MirrorParams,
    /// Only pixels whose both coordinates are multiples of this vote, so that the vote's cost
    /// does not grow with the square of the image's pixels.
    stride: usize,
}

impl Pairs<'_> {
    /// The pixels of the grid of `stride`, row by row.
    fn grid(&self, stride: usize) -> impl Iterator<Item = usize> {
        grid(self.candidates.width(), self.candidates.height(), stride)
    }

    /// Whether pixel `i` holds a light within twice the column tolerance of `column`.
    fn holds(&self, i: usize, column: f32) -> bool {
        let tol = 2.0 * self.params.column_tolerance;
        self.candidates
            .candidates(i)
            .iter()
            .any(|c| (c.column - column).abs() <= tol)
    }

    /// Whether `mirror` hides pixel `i`'s chosen point ([`Mirror::hides`]).
    fn hidden(&self, mirror: &Mirror, i: usize) -> bool {
        self.points[i].is_some_and(|p| mirror.hides(p, self.projector, self.params.behind_mm))
    }

    /// Calls `f(bisector)` for every pair of pixel `q` (of the voting grid).
    fn of_pixel(&self, q: usize, mut f: impl FnMut(Bisector)) {
        let tol = self.params.column_tolerance;
        let min_mm = 4.0 * self.params.tolerance_mm;
        let (Some(x), Some(c1)) = (self.points[q], self.columns[q]) else {
            return;
        };
        for other in self.candidates.candidates(q) {
            let c2 = other.column;
            if (c2 - c1).abs() <= 2.0 * tol {
                continue;
            }
            let start = self.by_column.partition_point(|e| e.0 < c2 - tol);
            for &(_, p) in self.by_column[start..]
                .iter()
                .take_while(|e| e.0 <= c2 + tol)
            {
                let p = p as usize;
                if !self.holds(p, c1) {
                    continue;
                }
                let w = Vec3::from(self.points[p].expect("chosen"));
                if let Some(b) = Bisector::of(Vec3::from(x), w, self.projector, min_mm) {
                    f(b);
                }
            }
        }
    }
}

/// The mirrors of a scan and the chosen points they make fictitious: `true` where pixel `i`'s
/// point (`points[i]`, camera frame; its column `columns[i]`) is hidden from the camera or the
/// projector by a mirror.
pub fn mirror_images(
    calibration: &Calibration,
    candidates: &CandidateImage,
    points: &[Option<[f32; 3]>],
    columns: &[Option<f32>],
    params: &MirrorParams,
) -> (Vec<Mirror>, Vec<bool>) {
    assert_eq!(
        points.len(),
        candidates.pixel_count(),
        "one point slot per pixel"
    );
    assert_eq!(columns.len(), points.len(), "one column slot per pixel");
    if points.is_empty() {
        return (Vec::new(), Vec::new());
    }
    let o = calibration.projector_centre_mm();
    // About 320 × 240 pixels vote, whatever the image's size.
    let stride = ((points.len() as f64 / 76_800.0).sqrt().round() as usize).max(1);
    // Tolerances at the grid's scale, so that the search is the same at any resolution: `ε`
    // shrinks with the pixel's footprint, and on a finer image the cells of the vote would
    // split a mirror's votes (EFSM's plane estimates scatter by more than the footprint) while
    // planes that near pairs bisect by chance outvote it (640 × 480 sphere_mirror: no mirror
    // found, 4.3% wrong points).
    let params = &MirrorParams {
        tolerance_mm: params.tolerance_mm * stride as f32,
        ..*params
    };
    let mut by_column: Vec<(f32, u32)> = grid(candidates.width(), candidates.height(), stride)
        .filter_map(|i| points[i].and(columns[i]).map(|c| (c, i as u32)))
        .collect();
    by_column.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let pairs = Pairs {
        candidates,
        points,
        columns,
        by_column,
        projector: Vec3::new(o.x as f32, o.y as f32, o.z as f32),
        params: *params,
        stride,
    };
    let (angle, step) = (params.angle_deg, params.tolerance_mm);
    // The vote: pairs per cell of plane space, with the sums of their planes; rows of the grid
    // in parallel.
    let voters: Vec<usize> = pairs.grid(pairs.stride).collect();
    let sums = voters
        .par_chunks(1024)
        .fold(Cells::default, |mut cells, chunk| {
            for &q in chunk {
                pairs.of_pixel(q, |b| {
                    cells.entry(key(b.cell(angle, step))).or_default().add(&b);
                });
            }
            cells
        })
        .reduce(Cells::default, |mut a, b| {
            for (k, sum) in b {
                a.entry(k).or_default().merge(&sum);
            }
            a
        });
    let mut cells: Vec<(u64, CellSum)> = sums.into_iter().collect();
    cells.sort_unstable_by_key(|c| c.0);
    let unpack = |k: u64| {
        let part = |v: u64| ((v & ((1 << 21) - 1)) as i64 - (1 << 20)) as i32;
        [part(k >> 42), part(k >> 21), part(k)]
    };
    let turns = azimuth_cells(angle);
    // The votes of a cell and its neighbours.
    let around = |cell: [i32; 3]| {
        let mut total = CellSum::default();
        for da in -1..=1 {
            for de in -1..=1 {
                for dof in -1..=1 {
                    let neighbour = [
                        (cell[0] + da).rem_euclid(turns),
                        cell[1] + de,
                        cell[2] + dof,
                    ];
                    if let Ok(i) = cells.binary_search_by_key(&key(neighbour), |c| c.0) {
                        total.merge(&cells[i].1);
                    }
                }
            }
        }
        total
    };
    // Cells by the votes around them, most first.
    let mut peaks: Vec<([i32; 3], CellSum)> = cells
        .iter()
        .map(|&(k, _)| {
            let cell = unpack(k);
            (cell, around(cell))
        })
        .collect();
    peaks.sort_unstable_by(|a, b| b.1.votes.cmp(&a.1.votes).then(a.0.cmp(&b.0)));
    let near = |c: [i32; 3], d: [i32; 3]| {
        let da = (c[0] - d[0]).rem_euclid(turns);
        (da <= 1 || da == turns - 1) && (1..3).all(|k| (c[k] - d[k]).abs() <= 1)
    };
    let mut hypotheses: Vec<([i32; 3], CellSum)> = Vec::new();
    for &(cell, sum) in &peaks {
        if hypotheses.len() >= params.hypotheses || (sum.votes as usize) < params.min_pixels {
            break;
        }
        if !hypotheses.iter().any(|&(h, _)| near(h, cell)) {
            hypotheses.push((cell, sum));
        }
    }
    let verifier = Verifier {
        calibration,
        pairs: &pairs,
    };
    // Each hypothesis starts from the mean plane of the votes around its cell.
    let mut found: Vec<(Verified, Vec3, f32)> = hypotheses
        .par_iter()
        .filter_map(|(_, sum)| {
            let mut plane = sum.plane();
            let mut verified = Vec::new();
            // Coarse on the voting grid, then every pixel, its partner looked for as far
            // around as on the grid (one pixel at 640 × 480 verified a third of the mirror's
            // virtual images, below the share test's 0.3). (A grid of every other pixel at
            // 320 × 240 too verified fewer pieces of the mirror with EFSM: 0.171% wrong points
            // on sphere_mirror instead of 0.121%.)
            let stride = pairs.stride;
            for (window, stride) in [(3, stride), (2, stride), (1, stride), (stride as i64, 1)] {
                verified = verifier.verify(plane.0, plane.1, window, stride);
                if verified.len() * stride * stride < params.min_pixels {
                    return None;
                }
                plane = fit_plane(&verified)?;
                if window == 1 && stride > 1 {
                    // The share test on the grid first, where it is cheap.
                    let mirror = Mirror::new(plane.0, plane.1, &verified);
                    let hidden = pairs.grid(stride).filter(|&i| pairs.hidden(&mirror, i));
                    if !verifier.is_mirror(verified.len(), hidden) {
                        return None;
                    }
                }
            }
            Some((verified, plane.0, plane.1))
        })
        .collect();
    found.sort_by(|a, b| b.0.len().cmp(&a.0.len()).then(a.2.total_cmp(&b.2)));
    let hidden_by = |mirror: &Mirror| -> Vec<bool> {
        (0..points.len()).map(|i| pairs.hidden(mirror, i)).collect()
    };
    // The mirrors found, each with the points it hides.
    let mut accepted: Vec<(Mirror, Vec<bool>)> = Vec::new();
    // Pixels that verified a plane taken already: a plane they verify again adds nothing.
    let mut claimed = vec![false; points.len()];
    for (verified, n, off) in found {
        let fresh = verified.iter().filter(|(q, _)| !claimed[*q]).count();
        if fresh < params.min_pixels {
            continue;
        }
        let mirror = Mirror::new(n, off, &verified);
        let hides = hidden_by(&mirror);
        if !verifier.is_mirror(verified.len(), (0..hides.len()).filter(|&i| hides[i])) {
            continue;
        }
        for (q, _) in &verified {
            claimed[*q] = true;
        }
        // Verified mostly by virtual images a mirror found hides, its normal near that
        // mirror's: the same mirror, its plane fitted to another part of it (EFSM's noisier
        // points give such pieces). What it hides counts; it is not another mirror.
        let same = accepted.iter().position(|(m, h)| {
            let shared = verified.iter().filter(|(q, _)| h[*q]).count();
            2 * shared >= verified.len()
                && Vec3::from(m.normal).dot(&n) >= SAME_MIRROR_DEG.to_radians().cos()
        });
        match same {
            Some(k) => {
                let (m, h) = &mut accepted[k];
                m.pixels += fresh;
                for (a, b) in h.iter_mut().zip(&hides) {
                    *a |= *b;
                }
            }
            None if accepted.len() < params.max_mirrors => accepted.push((mirror, hides)),
            None => {}
        }
    }
    let mut fictitious = vec![false; points.len()];
    for (_, hides) in &accepted {
        for (f, h) in fictitious.iter_mut().zip(hides) {
            *f |= *h;
        }
    }
    (accepted.into_iter().map(|a| a.0).collect(), fictitious)
}

/// Planes within this angle (degrees) of a mirror found, verified mostly by the virtual images
/// it hides, are that mirror.
const SAME_MIRROR_DEG: f32 = 10.0;

/// Checks a mirror plane against the scan: a pixel verifies it when its chosen point,
/// reflected in the plane, lands on the point that another pixel measured, and the two pixels
/// hold each other's chosen columns.
struct Verifier<'a> {
    calibration: &'a Calibration,
    pairs: &'a Pairs<'a>,
}

impl Verifier<'_> {
    /// A real mirror hides little besides virtual images that verify it. A plane that pairs
    /// of real points happen to bisect hides real surface: many points that hold two lights or
    /// more (that could verify it) and do not. `verified` pixels verify the plane; `hidden`
    /// are the pixels (of the same grid) whose points it hides.
    fn is_mirror(&self, verified: usize, hidden: impl Iterator<Item = usize>) -> bool {
        let pairs = self.pairs;
        let could_verify = hidden
            .filter(|&i| pairs.candidates.candidates(i).len() >= 2)
            .count();
        verified as f32 >= pairs.params.min_share * could_verify as f32
    }

    /// The pixels on a grid of `stride` that verify the plane, each with the pair that does,
    /// its partner looked for `window` grid steps around where the reflection lands.
    fn verify(&self, normal: Vec3, offset_mm: f32, window: i64, stride: usize) -> Verified {
        let pairs = self.pairs;
        let params = &pairs.params;
        let (width, height) = (pairs.candidates.width(), pairs.candidates.height());
        let mut verified = Vec::new();
        if normal.dot(&pairs.projector) - offset_mm >= 0.0 || offset_mm <= 0.0 {
            return verified;
        }
        for q in pairs.grid(stride) {
            let (Some(x), Some(c1)) = (pairs.points[q], pairs.columns[q]) else {
                continue;
            };
            if pairs.candidates.candidates(q).len() < 2 {
                continue;
            }
            let x = Vec3::from(x);
            let beyond = normal.dot(&x) - offset_mm;
            if beyond <= params.tolerance_mm {
                continue;
            }
            // The reflection of `X`: where `W` must be.
            let w = x - normal * (2.0 * beyond);
            let Some(pixel) = self
                .calibration
                .camera_pixel_of(&Point3::from(w.map(f64::from)))
            else {
                continue;
            };
            let (px, py) = (
                pixel.x.round() as i64,
                pixel.y.round() as i64 - pairs.candidates.first_row() as i64,
            );
            // `W`: the measured point nearest the reflection, among the pixels around it that
            // hold `c1` and whose chosen column `q` holds. (Taking the best match of columns
            // instead, which does not depend on the plane, verified fewer pixels: on
            // sphere_mirror with EFSM, 0.149% wrong points against 0.121%.)
            let mut best: Option<(f32, Vec3)> = None;
            for dy in -window..=window {
                for dx in -window..=window {
                    let (x_p, y_p) = (px + dx * stride as i64, py + dy * stride as i64);
                    if x_p < 0 || y_p < 0 || x_p >= width as i64 || y_p >= height as i64 {
                        continue;
                    }
                    let p = y_p as usize * width + x_p as usize;
                    let (Some(measured), Some(c2)) = (pairs.points[p], pairs.columns[p]) else {
                        continue;
                    };
                    let measured = Vec3::from(measured);
                    let distance = (measured - w).norm_squared();
                    if best.is_some_and(|b| b.0 <= distance)
                        || distance > (2.0 * params.tolerance_mm).powi(2)
                        || (c2 - c1).abs() <= 2.0 * params.column_tolerance
                        || !pairs.holds(q, c2)
                        || !pairs.holds(p, c1)
                    {
                        continue;
                    }
                    best = Some((distance, measured));
                }
            }
            let Some((_, measured)) = best else { continue };
            if let Some(b) = Bisector::of(x, measured, pairs.projector, 4.0 * params.tolerance_mm) {
                verified.push((q, b));
            }
        }
        verified
    }
}

/// The plane that best bisects the pairs (least squares), its normal towards the pairs'
/// virtual points; `None` for fewer than three pairs or a plane with the camera beyond it.
///
/// Each pair `(X, W)` asks for a plane through its midpoint with its normal along `X − W`. In
/// units of a displacement of `W`, a midpoint `r` off the plane costs `2r` and a normal at
/// angle `θ` to `X − W` costs `|X − W|·sin θ`; the normal minimises the sum of their squares.
/// Both terms are needed: when the mirror stands perpendicular to the surface it reflects,
/// every midpoint lies on one line.
fn fit_plane(pairs: &[(usize, Bisector)]) -> Option<(Vec3, f32)> {
    if pairs.len() < 3 {
        return None;
    }
    let mean = pairs
        .iter()
        .map(|(_, b)| b.midpoint.map(f64::from))
        .sum::<Vector3<f64>>()
        / pairs.len() as f64;
    let mut cost = Matrix3::<f64>::zeros();
    let mut towards = Vector3::<f64>::zeros();
    for (_, b) in pairs {
        let m = b.midpoint.map(f64::from) - mean;
        let d = b.normal.map(f64::from);
        let length = b.length_mm as f64;
        cost +=
            4.0 * m * m.transpose() + length * length * (Matrix3::identity() - d * d.transpose());
        towards += d;
    }
    let eigen = cost.symmetric_eigen();
    let least = eigen.eigenvalues.imin();
    let mut normal = eigen.eigenvectors.column(least).into_owned();
    if normal.dot(&towards) < 0.0 {
        normal = -normal;
    }
    let offset = normal.dot(&mean);
    (offset > 0.0).then(|| (normal.map(|v| v as f32), offset as f32))
}

impl Mirror {
    /// The mirror on the plane `normal·Y = offset` that `verified` pixels verify; its outline
    /// holds where their camera and projector rays cross it.
    fn new(normal: Vec3, offset_mm: f32, verified: &[(usize, Bisector)]) -> Mirror {
        let seed = if normal.x.abs() < 0.9 {
            Vec3::x()
        } else {
            Vec3::y()
        };
        let u = normal.cross(&seed).normalize();
        let v = normal.cross(&u);
        let mut corners: Vec<[f32; 2]> = verified
            .iter()
            .flat_map(|(_, b)| [b.camera_crossing, b.projector_crossing])
            .map(|c| [c.dot(&u), c.dot(&v)])
            .collect();
        Mirror {
            normal: normal.into(),
            offset_mm,
            pixels: verified.len(),
            outline: convex_hull(&mut corners),
            axes: [u, v],
        }
    }

    /// Whether the mirror hides `point` (camera frame, mm) from the camera or the projector
    /// of `calibration` ([`MirrorParams::behind_mm`]: `behind_mm`).
    pub fn hides_from(&self, calibration: &Calibration, point: [f32; 3], behind_mm: f32) -> bool {
        let o = calibration.projector_centre_mm();
        self.hides(
            point,
            Vec3::new(o.x as f32, o.y as f32, o.z as f32),
            behind_mm,
        )
    }

    /// Whether the mirror stands between `point` and the camera (at the origin) or the
    /// projector (at `projector`): the point is more than `behind_mm` off the plane, and one
    /// of the segments crosses the plane inside the outline.
    fn hides(&self, point: [f32; 3], projector: Vec3, behind_mm: f32) -> bool {
        let (normal, point) = (Vec3::from(self.normal), Vec3::from(point));
        if (normal.dot(&point) - self.offset_mm).abs() <= behind_mm {
            return false;
        }
        [Vec3::zeros(), projector].into_iter().any(|from| {
            crossing(from, point, &normal, self.offset_mm)
                .is_some_and(|c| self.contains([c.dot(&self.axes[0]), c.dot(&self.axes[1])]))
        })
    }

    /// Whether a point of the plane (in its axes) is inside the outline.
    fn contains(&self, p: [f32; 2]) -> bool {
        let n = self.outline.len();
        if n < 3 {
            return false;
        }
        (0..n).all(|k| {
            let (a, b) = (self.outline[k], self.outline[(k + 1) % n]);
            (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) >= 0.0
        })
    }
}

/// Convex hull, counter-clockwise (Andrew's monotone chain).
fn convex_hull(points: &mut [[f32; 2]]) -> Vec<[f32; 2]> {
    points.sort_unstable_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    if points.len() < 3 {
        return points.to_vec();
    }
    let turn = |o: [f32; 2], a: [f32; 2], b: [f32; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut hull: Vec<[f32; 2]> = Vec::with_capacity(2 * points.len());
    for &p in points.iter() {
        while hull.len() >= 2 && turn(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    let lower = hull.len() + 1;
    for &p in points.iter().rev().skip(1) {
        while hull.len() >= lower && turn(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0 {
            hull.pop();
        }
        hull.push(p);
    }
    hull.pop();
    hull
}

#[cfg(test)]
mod tests {
    use super::*;
    use fsm_core::{Candidate, Group, GroupSet};
    use fsm_io::candidate_file::HostCandidates;
    use nalgebra::Point2;

    /// The simulator's bench: camera 320 × 240 at the origin, projector 200 mm to its right.
    fn bench() -> Calibration {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../calibration/bench.toml");
        Calibration::read(&path).expect("calibration/bench.toml")
    }

    /// A wall at `z = 520` mm; `mirror`: a mirror in the plane `x = −70` mm facing `+x`, over
    /// depths 380–500 mm and heights ±70 mm (the simulator's `sphere_mirror` without the
    /// sphere).
    const WALL_MM: f64 = 520.0;
    const MIRROR_X_MM: f64 = -70.0;

    /// Where the segment `from → to` meets the mirror, if it does.
    fn through_mirror(from: Vector3<f64>, to: Vector3<f64>) -> Option<Vector3<f64>> {
        let d = to - from;
        if d.x.abs() < 1e-12 {
            return None;
        }
        let t = (MIRROR_X_MM - from.x) / d.x;
        let m = from + t * d;
        ((1e-9..1.0 - 1e-9).contains(&t) && (380.0..=500.0).contains(&m.z) && m.y.abs() <= 70.0)
            .then_some(m)
    }

    fn candidate(column: f64, amplitude: f32) -> Candidate {
        Candidate {
            column: column as f32,
            amplitude,
            groups: GroupSet::only(Group::One),
            group: Group::One,
            peak: 0,
            block: 0,
        }
    }

    /// What the selection would hand the mirror search on the scene: every pixel's chosen
    /// point and column, its candidates, and whether the point is a virtual image.
    struct Scene {
        candidates: CandidateImage,
        points: Vec<Option<[f32; 3]>>,
        columns: Vec<Option<f32>>,
        virtual_image: Vec<bool>,
    }

    /// The scene's pixels. `other_light(W)`, when the scene has no mirror, gives a wall point a
    /// second light: the column of the point it returns, as diffuse interreflection would.
    fn scene(
        calibration: &Calibration,
        mirror: bool,
        other_light: impl Fn(Vector3<f64>) -> Option<Vector3<f64>>,
    ) -> Scene {
        let o = calibration.projector_centre_mm();
        let projector = Vector3::new(o.x, o.y, o.z);
        let column = |p: Vector3<f64>| {
            calibration
                .projector_column_of(&Point3::from(p))
                .filter(|c| (0.0..767.0).contains(c))
        };
        let lit_directly = |p: Vector3<f64>| !mirror || through_mirror(projector, p).is_none();
        let (width, height) = (320, 240);
        let mut s = Scene {
            candidates: CandidateImage::new(width, 0),
            points: Vec::new(),
            columns: Vec::new(),
            virtual_image: Vec::new(),
        };
        for y in 0..height {
            let mut row = vec![HostCandidates::new(); width];
            for (x, pixel) in row.iter_mut().enumerate() {
                let ray = calibration
                    .camera
                    .ray(Point2::new(x as f64, y as f64))
                    .expect("a ray");
                let on_wall = ray * (WALL_MM / ray.z);
                let mut lights: Vec<(f64, Vector3<f64>, bool)> = Vec::new();
                match mirror
                    .then(|| through_mirror(Vector3::zeros(), on_wall))
                    .flatten()
                {
                    Some(_) => {
                        // The wall point the mirror shows, and its image behind the mirror.
                        let w = Vector3::new(2.0 * MIRROR_X_MM - on_wall.x, on_wall.y, on_wall.z);
                        let x_virtual = on_wall;
                        if through_mirror(projector, x_virtual).is_some() {
                            if let Some(c) = column(x_virtual) {
                                lights.push((c, x_virtual, true));
                            }
                        }
                        if lit_directly(w) {
                            if let Some(c) = column(w) {
                                lights.push((c, w, false));
                            }
                        }
                        // Only the virtual image is a point here; the wall's own light
                        // through the mirror is just a candidate.
                        if !lights.iter().any(|l| l.2) {
                            lights.clear();
                        }
                    }
                    None => {
                        if lit_directly(on_wall) {
                            if let Some(c) = column(on_wall) {
                                lights.push((c, on_wall, false));
                            }
                        }
                        let second = if mirror {
                            let image =
                                Vector3::new(2.0 * MIRROR_X_MM - on_wall.x, on_wall.y, on_wall.z);
                            through_mirror(projector, image).map(|_| image)
                        } else {
                            other_light(on_wall)
                        };
                        if let Some(c) = second.and_then(column) {
                            if !lights.is_empty() {
                                lights.push((c, second.expect("lit"), false));
                            }
                        }
                    }
                }
                let chosen = lights.first().copied();
                for (k, l) in lights.iter().enumerate() {
                    pixel
                        .candidates
                        .push(candidate(l.0, 100.0 - k as f32))
                        .expect("capacity");
                }
                s.points
                    .push(chosen.map(|l| [l.1.x as f32, l.1.y as f32, l.1.z as f32]));
                s.columns.push(chosen.map(|l| l.0 as f32));
                s.virtual_image.push(chosen.is_some_and(|l| l.2));
            }
            s.candidates.push_row(&row);
        }
        s
    }

    #[test]
    fn a_plane_mirror_is_found_and_its_virtual_images_removed_and_nothing_else() {
        let calibration = bench();
        let s = scene(&calibration, true, |_| None);
        let virtual_images = s.virtual_image.iter().filter(|v| **v).count();
        let real = s.points.iter().flatten().count() - virtual_images;
        assert!(
            virtual_images > 1000 && real > 40_000,
            "{virtual_images} {real}"
        );
        // Few pixels suffice for a plane to be looked at: whatever planes pairs of real points
        // happen to bisect, only the mirror is one.
        let params = MirrorParams {
            min_pixels: 5,
            ..MirrorParams::for_epsilon(3.28)
        };
        let (mirrors, hidden) =
            mirror_images(&calibration, &s.candidates, &s.points, &s.columns, &params);
        assert_eq!(mirrors.len(), 1, "{mirrors:?}");
        let m = &mirrors[0];
        let angle = (-m.normal[0]).min(1.0).acos().to_degrees();
        assert!(angle < 0.2, "normal {:?}: {angle}°", m.normal);
        assert!((m.offset_mm - 70.0).abs() < 0.2, "offset {}", m.offset_mm);
        let removed = |virtual_image: bool| {
            (0..s.points.len())
                .filter(|&i| s.points[i].is_some() && s.virtual_image[i] == virtual_image)
                .filter(|&i| hidden[i])
                .count()
        };
        assert_eq!(removed(false), 0, "real points removed");
        // The outline is the hull of where verifying rays meet the mirror: the virtual images
        // at its very border may fall outside it.
        assert!(
            removed(true) as f64 >= 0.98 * virtual_images as f64,
            "{} of {virtual_images} virtual images removed",
            removed(true)
        );
    }

    #[test]
    fn two_lights_per_pixel_without_a_mirror_make_no_mirror() {
        let calibration = bench();
        // Every wall point also receives the light of the point 40 mm to its right, and of
        // the point 25 mm above it: pairs of columns galore, no mirror.
        for offset in [Vector3::new(40.0, 0.0, 0.0), Vector3::new(0.0, 25.0, 0.0)] {
            let s = scene(&calibration, false, |w| Some(w + offset));
            let (mirrors, hidden) = mirror_images(
                &calibration,
                &s.candidates,
                &s.points,
                &s.columns,
                &MirrorParams::for_epsilon(3.28),
            );
            assert!(mirrors.is_empty(), "{mirrors:?}");
            assert!(!hidden.iter().any(|h| *h));
        }
    }

    #[test]
    fn the_convex_outline_holds_its_inside_and_not_its_outside() {
        let mut square = vec![
            [0.0, 0.0],
            [1.0, 0.0],
            [1.0, 1.0],
            [0.0, 1.0],
            [0.5, 0.5],
            [0.2, 0.7],
        ];
        let outline = convex_hull(&mut square);
        assert_eq!(outline.len(), 4, "{outline:?}");
        let m = Mirror {
            normal: [0.0, 0.0, 1.0],
            offset_mm: 1.0,
            pixels: 0,
            outline,
            axes: [Vec3::x(), Vec3::y()],
        };
        assert!(m.contains([0.5, 0.5]) && m.contains([0.99, 0.01]));
        assert!(!m.contains([1.01, 0.5]) && !m.contains([-0.01, 0.5]));
        // A point 2 mm beyond the plane behind the square, seen from below it: hidden; beside
        // it or on the plane: not.
        let projector = Vec3::new(100.0, 0.0, 0.0);
        assert!(m.hides([0.5, 0.5, 3.0], projector, 1.0));
        assert!(!m.hides([5.0, 5.0, 3.0], Vec3::new(5.0, 5.0, 0.0), 1.0));
        assert!(!m.hides([0.5, 0.5, 1.5], projector, 1.0));
    }
}
