//! Semi-global selection of the direct candidate (SPEC §4, paper §III-E, eqs. 10–13).
//!
//! Each pixel `v` has candidates `V_v`, each triangulated to a 3D point with the amplitude `I_c`
//! of its peak. A labelling `g` picks one candidate per pixel, or none, and minimises
//!
//! ```text
//! E(g) = Σ_v C(v, g(v)) + Σ_v Σ_{u ∈ N(v)} β·max(0, D(v, u) − ε)          (eqs. 10–11)
//! ```
//!
//! with `D` the distance between the chosen points of neighbours. The data term is the paper's
//! `−I_c`, divided by the pixel's strongest amplitude so that it does not depend on the surface's
//! albedo or the light level: `C = −I_c / max I`, in `[−1, 0)`. The energy is minimised
//! semi-globally (Hirschmüller, paper ref. \[34\]): costs are aggregated along 16 (or 8) straight
//! paths through the image,
//!
//! ```text
//! L_r(v, l) = C(v, l) + min_{l'} (L_r(v − r, l') + S(l, l')) − min_{l'} L_r(v − r, l'),
//! ```
//!
//! and each pixel takes the label of least `Σ_r L_r(v, l)`. Label sets differ from pixel to
//! pixel, so `S` is evaluated between the actual points of neighbours; a pixel without candidates
//! ends the paths through it. "None" is not a label: as one, it would let a path step from the
//! real surface to a fictitious one for two cheap steps instead of the jump `β·(D − ε)`, and
//! then collect a stronger fictitious data term pixel after pixel. Instead a pixel keeps no
//! candidate when its choice is isolated: neighbours have chosen, none within `2ε` of it.
//! The direct illumination is the chosen candidate's amplitude (eq. 12), the indirect
//! illumination the sum of the others (eq. 13).

use rayon::prelude::*;

/// One candidate of a pixel, triangulated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Label {
    /// 3D point in the camera frame, millimetres.
    pub point_mm: [f32; 3],
    /// Fringe modulation of its peak, sensor DN (`I_c`).
    pub amplitude: f32,
    /// The candidate's projector column.
    pub column: f32,
}

/// The candidates of every pixel of an image, row-major.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CandidateField {
    width: usize,
    height: usize,
    /// `labels[starts[i]..starts[i + 1]]` are pixel `i`'s.
    starts: Vec<u32>,
    labels: Vec<Label>,
}

impl CandidateField {
    /// A field of `width × height` pixels, filled by `labels(x, y)`.
    pub fn from_fn<I>(
        width: usize,
        height: usize,
        mut labels: impl FnMut(usize, usize) -> I,
    ) -> Self
    where
        I: IntoIterator<Item = Label>,
    {
        let mut field = CandidateField {
            width,
            height,
            starts: Vec::with_capacity(width * height + 1),
            labels: Vec::new(),
        };
        field.starts.push(0);
        for y in 0..height {
            for x in 0..width {
                field.labels.extend(labels(x, y));
                field.starts.push(field.labels.len() as u32);
            }
        }
        field
    }

    /// A field of `width × height` pixels from each pixel's label count (row-major) and all
    /// labels in that order.
    ///
    /// # Panics
    /// If there is not one count per pixel or the counts do not add up to the labels.
    pub fn from_counts(width: usize, height: usize, counts: &[u32], labels: Vec<Label>) -> Self {
        assert_eq!(counts.len(), width * height, "one label count per pixel");
        let mut starts = Vec::with_capacity(counts.len() + 1);
        let mut end = 0u32;
        starts.push(end);
        for &c in counts {
            end += c;
            starts.push(end);
        }
        assert_eq!(
            end as usize,
            labels.len(),
            "the counts add up to the labels"
        );
        CandidateField {
            width,
            height,
            starts,
            labels,
        }
    }

    /// Image width.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Image height.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The candidates of pixel `(x, y)`.
    pub fn labels(&self, x: usize, y: usize) -> &[Label] {
        let i = y * self.width + x;
        &self.labels[self.starts[i] as usize..self.starts[i + 1] as usize]
    }

    /// Candidates in the field.
    pub fn len(&self) -> usize {
        self.labels.len()
    }

    /// Whether the field has no candidate at all.
    pub fn is_empty(&self) -> bool {
        self.labels.is_empty()
    }
}

/// A path's step `r = (dx, dy)` from one pixel to the next, pixels.
type Step = (i32, i32);

/// The aggregation paths.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Paths {
    /// Horizontal, vertical and diagonal, both ways (Hirschmüller's default).
    Eight,
    /// The eight plus the knight's moves.
    Sixteen,
}

impl Paths {
    /// 8 or 16.
    pub fn count(self) -> u8 {
        self.directions().len() as u8
    }

    /// The directions of the raster sweep (the previous pixel `v − r` comes earlier in raster
    /// order: `r` points down, or right along a row) and of the reverse sweep, each in the
    /// order of [`Paths::directions`].
    fn sweeps(self) -> (Vec<Step>, Vec<Step>) {
        self.directions()
            .iter()
            .partition(|&&(dx, dy)| dy > 0 || (dy == 0 && dx > 0))
    }

    fn directions(self) -> &'static [Step] {
        // Horizontal, vertical, diagonal, then the knight's moves.
        const DIRECTIONS: [Step; 16] = [
            (1, 0),
            (-1, 0),
            (0, 1),
            (0, -1),
            (1, 1),
            (-1, -1),
            (1, -1),
            (-1, 1),
            (2, 1),
            (-2, -1),
            (2, -1),
            (-2, 1),
            (1, 2),
            (-1, -2),
            (1, -2),
            (-1, 2),
        ];
        match self {
            Paths::Eight => &DIRECTIONS[..8],
            Paths::Sixteen => &DIRECTIONS,
        }
    }
}

/// The default [`SelectionParams::min_quality`]: a light at least this many times the noise
/// RMS of one column of a dark pixel's profile.
pub const DEFAULT_MIN_QUALITY: f32 = 20.0;

/// Parameters of eqs. 10–11.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SelectionParams {
    /// Aggregation paths.
    pub paths: Paths,
    /// `ε`: neighbours closer than this (mm) cost nothing: the system's discrimination distance.
    pub epsilon_mm: f32,
    /// `β`: cost per millimetre beyond `ε`, in units of the strongest candidate's data term.
    pub beta_per_mm: f32,
    /// Drop a choice that no chosen neighbour lies within `2ε` of.
    pub drop_isolated: bool,
    /// Give no point to a pixel whose candidates may be mixtures of two lights
    /// ([`fsm_core::PixelFlags::is_mixed`]: aliased, EFSM lights unresolved modulo the block
    /// width; unresolved, two touching lights the cosine search could not split): a missing
    /// point rather than a wrong one.
    pub drop_aliased: bool,
    /// Give no point to a pixel whose chosen point the projector cannot light directly
    /// ([`crate::visibility`]): a surface that exists only in reflections.
    pub drop_fictitious: bool,
    /// Give no point to a pixel that straddles a depth edge
    /// ([`crate::surface::NoPoint::Edge`]): its footprint sees two surfaces, and its point
    /// may be on either.
    pub drop_edges: bool,
    /// Give no point to a pixel whose chosen light's quality (signal-to-noise ratio,
    /// [`crate::Surface::quality`]) is below this; methods without a quality are not filtered.
    pub min_quality: f32,
}

impl SelectionParams {
    /// Defaults derived from the system: `footprint_mm` is the distance between the points of
    /// neighbouring pixels on a surface facing the camera at the working distance (depth over
    /// focal length in pixels). Neighbours on a surface tilted up to ~75° are within
    /// `ε = 4·footprint`; a jump costs `β = 1/footprint` per mm beyond that, so a fictitious
    /// surface a few millimetres away is dearer than any data term it could win.
    ///
    /// Sixteen paths: on the simulator's mirror and glossy scenes (whole images, BFSM) they cut
    /// the wrong points of `plane_mirror` from 0.21% to 0.10% and raise the right points of
    /// the glossy V from 94.4% to 97.1% of the directly lit pixels, for twice the selection's
    /// time (`docs/scan.md`).
    pub fn for_footprint(footprint_mm: f32) -> Self {
        SelectionParams {
            paths: Paths::Sixteen,
            epsilon_mm: 4.0 * footprint_mm,
            beta_per_mm: 1.0 / footprint_mm,
            drop_isolated: true,
            drop_aliased: true,
            drop_fictitious: true,
            drop_edges: true,
            min_quality: DEFAULT_MIN_QUALITY,
        }
    }
}

/// The outcome of the selection.
#[derive(Clone, Debug, PartialEq)]
pub struct Selection {
    /// Image width.
    pub width: usize,
    /// Image height.
    pub height: usize,
    /// Per pixel, the index of the chosen candidate in its label list, or `None` (no candidate,
    /// or an isolated choice).
    pub choice: Vec<Option<u16>>,
    /// `I_d` (eq. 12): the chosen candidate's amplitude, 0 where none.
    pub direct: Vec<f32>,
    /// `I_id` (eq. 13): the sum of the other candidates' amplitudes.
    pub indirect: Vec<f32>,
}

/// Minimises eq. 10 semi-globally.
///
/// The paths run in two sweeps over the image, each on its own thread ([`rayon::join`]): one in
/// raster order for every direction whose previous pixel comes earlier in it, one in reverse
/// raster order for the opposite directions. A sweep holds the path costs of its last three
/// rows only (a knight's move reaches two rows back) and adds them per candidate in the
/// directions' order; the choice takes the raster sweep's sum plus the reverse one's. The sums,
/// so the choice, are the same bits for any number of threads.
pub fn select(field: &CandidateField, params: &SelectionParams) -> Selection {
    let (raster, reverse) = params.paths.sweeps();
    let (ahead, back) = rayon::join(
        || sweep(field, params, &raster, Order::Raster),
        || sweep(field, params, &reverse, Order::Reverse),
    );
    let (w, h) = (field.width, field.height);
    let starts = &field.starts;
    // Rows in parallel from here on: a pixel's outcome depends on nothing another row writes.
    let mut choice = vec![None; w * h];
    choice
        .par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, c) in row.iter_mut().enumerate() {
                let i = y * w + x;
                let (start, end) = (starts[i] as usize, starts[i + 1] as usize);
                // The least cost; ties go to the lower index (candidates come strongest first).
                let mut best: Option<(usize, f32)> = None;
                for l in start..end {
                    let cost = ahead[l] + back[l];
                    match best {
                        Some((_, least)) if least <= cost => {}
                        _ => best = Some((l - start, cost)),
                    }
                }
                *c = best.map(|(l, _)| l as u16);
            }
        });
    if params.drop_isolated {
        choice = drop_isolated(field, &choice, 2.0 * params.epsilon_mm);
    }
    let mut direct = vec![0.0; w * h];
    let mut indirect = vec![0.0; w * h];
    direct
        .par_chunks_mut(w.max(1))
        .zip(indirect.par_chunks_mut(w.max(1)))
        .enumerate()
        .for_each(|(y, (direct, indirect))| {
            for x in 0..w {
                let i = y * w + x;
                let labels = &field.labels[starts[i] as usize..starts[i + 1] as usize];
                let all: f32 = labels.iter().map(|l| l.amplitude).sum();
                let chosen = choice[i].map_or(0.0, |c| labels[c as usize].amplitude);
                direct[x] = chosen;
                indirect[x] = all - chosen;
            }
        });
    Selection {
        width: w,
        height: h,
        choice,
        direct,
        indirect,
    }
}

/// Clears every choice that has chosen 8-neighbours but none within `reach_mm` of it.
fn drop_isolated(
    field: &CandidateField,
    choice: &[Option<u16>],
    reach_mm: f32,
) -> Vec<Option<u16>> {
    let (w, h) = (field.width, field.height);
    let point =
        |i: usize| choice[i].map(|c| field.labels[field.starts[i] as usize + c as usize].point_mm);
    let mut kept = choice.to_vec();
    kept.par_chunks_mut(w.max(1))
        .enumerate()
        .for_each(|(y, row)| {
            for (x, kept) in row.iter_mut().enumerate() {
                let i = y * w + x;
                let Some(p) = point(i) else { continue };
                let mut chosen_neighbours = 0;
                let mut near = false;
                for q in neighbours(i, w, h).flatten().filter_map(point) {
                    chosen_neighbours += 1;
                    near |= distance_mm(&p, &q) <= reach_mm;
                }
                if chosen_neighbours > 0 && !near {
                    *kept = None;
                }
            }
        });
    kept
}

/// The 8 neighbours of pixel `i` in a `width × height` image, `None` off the image.
pub(crate) fn neighbours(
    i: usize,
    width: usize,
    height: usize,
) -> impl Iterator<Item = Option<usize>> {
    let (x, y) = ((i % width) as isize, (i / width) as isize);
    [
        (-1, -1),
        (0, -1),
        (1, -1),
        (-1, 0),
        (1, 0),
        (-1, 1),
        (0, 1),
        (1, 1),
    ]
    .into_iter()
    .map(move |(dx, dy)| {
        let (nx, ny) = (x + dx, y + dy);
        (nx >= 0 && ny >= 0 && (nx as usize) < width && (ny as usize) < height)
            .then(|| ny as usize * width + nx as usize)
    })
}

/// `C(v, l) = −I_l / max I`: a candidate's data term, from its amplitude and its pixel's
/// strongest.
#[inline(always)]
fn data_cost(amplitude: f32, strongest: f32) -> f32 {
    if strongest > 0.0 {
        -amplitude / strongest
    } else {
        0.0
    }
}

/// The strongest amplitude among a pixel's candidates (0 for none).
#[inline(always)]
fn strongest(labels: &[Label]) -> f32 {
    labels.iter().map(|l| l.amplitude).fold(0.0f32, f32::max)
}

/// Candidates of a pixel whose best predecessor is found at once, one lane each.
const LANES: usize = 4;

/// The order a sweep visits pixels in.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Order {
    /// Rows top to bottom, each left to right.
    Raster,
    /// Rows bottom to top, each right to left.
    Reverse,
}

/// Rows of path costs a sweep keeps: the current one and two before (a knight's move).
const ROWS_KEPT: usize = 3;

/// `Σ_r L_r` per candidate over `directions`, added in their order, in one sweep over the image
/// in `order` (every direction's previous pixel must come earlier in it).
///
/// For each candidate `l` of a pixel, `min_{l'} (L_r(v − r, l') + S(l, l'))` runs over the
/// previous pixel's candidates in their order, [`LANES`] candidates `l` at a time: each lane
/// does the scalar operations of [`step_cost`] in the same order, so every `L_r` is the same,
/// bit for bit, as one candidate and one direction at a time (the test oracle). A pixel's
/// points are loaded once for all the sweep's directions.
fn sweep(
    field: &CandidateField,
    params: &SelectionParams,
    directions: &[Step],
    order: Order,
) -> Vec<f32> {
    let (w, h) = (field.width, field.height);
    let (starts, labels) = (&field.starts, &field.labels);
    let mut sum = vec![0.0f32; labels.len()];
    if directions.is_empty() || w == 0 || h == 0 {
        return sum;
    }
    let (beta, epsilon) = (params.beta_per_mm, params.epsilon_mm);
    let row_start = |y: usize| starts[y * w] as usize;
    let widest = (0..h)
        .map(|y| row_start(y + 1) - row_start(y))
        .max()
        .unwrap_or(0);
    // Path costs of the rows kept, per direction: row `y`'s candidates (numbered from its
    // first) at `((y % ROWS_KEPT) · directions + d) · widest`.
    let mut kept = vec![0.0f32; ROWS_KEPT * directions.len() * widest];
    let slot = |y: usize, d: usize| (y % ROWS_KEPT * directions.len() + d) * widest;
    for step in 0..h {
        let y = if order == Order::Raster {
            step
        } else {
            h - 1 - step
        };
        let first_here = row_start(y);
        for across in 0..w {
            let x = if order == Order::Raster {
                across
            } else {
                w - 1 - across
            };
            let i = y * w + x;
            let (vs, ve) = (starts[i] as usize, starts[i + 1] as usize);
            if vs == ve {
                continue;
            }
            let here = &labels[vs..ve];
            let strongest = strongest(here);
            for first in (0..here.len()).step_by(LANES) {
                let n = (here.len() - first).min(LANES);
                // Unused lanes repeat the first candidate; their results are not stored.
                let lane = |k: usize| &here[first + if k < n { k } else { 0 }];
                let [hx, hy, hz]: [[f32; LANES]; 3] =
                    std::array::from_fn(|axis| std::array::from_fn(|k| lane(k).point_mm[axis]));
                let data: [f32; LANES] =
                    std::array::from_fn(|k| data_cost(lane(k).amplitude, strongest));
                let mut total = [0.0f32; LANES];
                for (d, &(dx, dy)) in directions.iter().enumerate() {
                    let (px, py) = (x as i32 - dx, y as i32 - dy);
                    // The previous pixel's candidates in the field, and where their path costs
                    // are kept.
                    let (ps, pe, at) = if px < 0 || py < 0 || px >= w as i32 || py >= h as i32 {
                        (0, 0, 0)
                    } else {
                        let (px, py) = (px as usize, py as usize);
                        let p = py * w + px;
                        let (ps, pe) = (starts[p] as usize, starts[p + 1] as usize);
                        (ps, pe, slot(py, d) + ps - row_start(py))
                    };
                    let path = if ps == pe {
                        // A path starts here: at the border or after a pixel without candidates.
                        data
                    } else {
                        let previous = &kept[at..at + (pe - ps)];
                        let floor = previous.iter().copied().fold(f32::INFINITY, least);
                        let mut best = [f32::INFINITY; LANES];
                        for (there, &cost) in labels[ps..pe].iter().zip(previous) {
                            let [tx, ty, tz] = there.point_mm;
                            for k in 0..LANES {
                                let step =
                                    step_cost(hx[k] - tx, hy[k] - ty, hz[k] - tz, beta, epsilon);
                                best[k] = least(best[k], cost + step);
                            }
                        }
                        std::array::from_fn(|k| data[k] + best[k] - floor)
                    };
                    let at = slot(y, d) + vs + first - first_here;
                    // Element by element: a slice copy of at most four floats calls memcpy.
                    #[allow(clippy::manual_memcpy)]
                    for k in 0..n {
                        kept[at + k] = path[k];
                    }
                    for k in 0..LANES {
                        total[k] += path[k];
                    }
                }
                for k in 0..n {
                    sum[vs + first + k] = total[k];
                }
            }
        }
    }
    sum
}

/// `S(l, l')` (eq. 11) for the points `e` mm apart: `β·max(0, D − ε)`. A step shorter than
/// `ε` gives `√(e·e) − ε ≤ 0`, so 0 exactly, with no branch.
#[inline(always)]
fn step_cost(ex: f32, ey: f32, ez: f32, beta: f32, epsilon: f32) -> f32 {
    let squared = ex * ex + ey * ey + ez * ez;
    let beyond = squared.sqrt() - epsilon;
    beta * if beyond > 0.0 { beyond } else { 0.0 }
}

/// The lesser of two costs. Costs are never NaN, so this is `f32::min` without the NaN
/// handling that keeps the compiler from using one vector instruction for it.
#[inline(always)]
fn least(a: f32, b: f32) -> f32 {
    if b < a {
        b
    } else {
        a
    }
}

/// Euclidean distance between two points, mm.
pub(crate) fn distance_mm(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    let (x, y, z) = (a[0] - b[0], a[1] - b[1], a[2] - b[2]);
    (x * x + y * y + z * z).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `L_r` one candidate at a time, written as eq. 11 reads: the oracle of [`sweep`].
    fn aggregate_one_at_a_time(
        field: &CandidateField,
        data: &[f32],
        params: &SelectionParams,
        (dx, dy): Step,
    ) -> Vec<f32> {
        let (w, h) = (field.width as i32, field.height as i32);
        let mut path = vec![0.0f32; data.len()];
        let ys: Vec<i32> = if dy >= 0 {
            (0..h).collect()
        } else {
            (0..h).rev().collect()
        };
        let xs: Vec<i32> = if dx >= 0 {
            (0..w).collect()
        } else {
            (0..w).rev().collect()
        };
        for &y in &ys {
            for &x in &xs {
                let here = field.labels(x as usize, y as usize);
                let vs = field.starts[(y * w + x) as usize] as usize;
                let (px, py) = (x - dx, y - dy);
                let inside = px >= 0 && py >= 0 && px < w && py < h;
                let before = if inside {
                    field.labels(px as usize, py as usize)
                } else {
                    &[]
                };
                let ps = if inside {
                    field.starts[(py * w + px) as usize] as usize
                } else {
                    0
                };
                for (l, label) in here.iter().enumerate() {
                    if before.is_empty() {
                        path[vs + l] = data[vs + l];
                        continue;
                    }
                    let previous = &path[ps..ps + before.len()];
                    let floor = previous.iter().copied().fold(f32::INFINITY, f32::min);
                    let mut best = f32::INFINITY;
                    for (there, &prev) in before.iter().zip(previous) {
                        let d = distance_mm(&label.point_mm, &there.point_mm);
                        let step = if d <= params.epsilon_mm {
                            0.0
                        } else {
                            params.beta_per_mm * (d - params.epsilon_mm)
                        };
                        best = best.min(prev + step);
                    }
                    path[vs + l] = data[vs + l] + best - floor;
                }
            }
        }
        path
    }

    #[test]
    fn the_sweeps_give_the_paths_of_one_candidate_and_one_direction_at_a_time_bit_for_bit() {
        // 0 to 9 candidates per pixel (more than one group of lanes, and partial groups), some
        // within ε of their neighbours', some beyond; a xorshift for the layout.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut counts = Vec::new();
        let mut labels = Vec::new();
        let (w, h) = (23, 17);
        for y in 0..h {
            for x in 0..w {
                let n = (next() % 10) as u32;
                counts.push(n);
                for _ in 0..n {
                    let r = next();
                    let jump = (r % 4) as f32 * 3.0 * (r >> 8 & 1) as f32;
                    labels.push(Label {
                        point_mm: [
                            x as f32 * 0.5 + jump,
                            y as f32 * 0.5 - jump * 0.3,
                            500.0 + (r >> 16 & 0xff) as f32 * 0.01 + jump * 7.0,
                        ],
                        amplitude: 1.0 + (r >> 24 & 0xff) as f32,
                        column: 0.0,
                    });
                }
            }
        }
        let field = CandidateField::from_counts(w, h, &counts, labels);
        let data: Vec<f32> = (0..w * h)
            .flat_map(|i| {
                let labels = field.labels(i % w, i / w);
                let strongest = strongest(labels);
                labels
                    .iter()
                    .map(move |l| data_cost(l.amplitude, strongest))
            })
            .collect();
        let params = SelectionParams::for_footprint(0.5);
        let mut compared = 0;
        for paths in [Paths::Eight, Paths::Sixteen] {
            let (raster, reverse) = paths.sweeps();
            assert_eq!(raster.len() + reverse.len(), paths.count() as usize);
            for (directions, order) in [(raster, Order::Raster), (reverse, Order::Reverse)] {
                let mut oracle = vec![0.0f32; data.len()];
                for &direction in &directions {
                    let path = aggregate_one_at_a_time(&field, &data, &params, direction);
                    for (o, p) in oracle.iter_mut().zip(path) {
                        *o += p;
                    }
                }
                let swept = sweep(&field, &params, &directions, order);
                assert_eq!(swept.len(), oracle.len());
                for (i, (a, b)) in swept.iter().zip(&oracle).enumerate() {
                    assert_eq!(
                        a.to_bits(),
                        b.to_bits(),
                        "{paths:?} {directions:?}, candidate {i}"
                    );
                    compared += 1;
                }
            }
        }
        assert_eq!(compared, 4 * data.len(), "two path sets, two sweeps each");
    }
}
