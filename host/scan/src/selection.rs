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

/// `8` or `16` (`fsm scan --paths`).
impl std::str::FromStr for Paths {
    type Err = String;

    fn from_str(s: &str) -> Result<Paths, String> {
        [Paths::Eight, Paths::Sixteen]
            .into_iter()
            .find(|p| p.count().to_string() == s)
            .ok_or_else(|| format!("`{s}`: the selection aggregates along 8 or 16 paths"))
    }
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
    /// Give no point to a pixel that straddles a depth edge or a crease
    /// ([`crate::surface::NoPoint::Edge`]): its footprint sees two surfaces, and its point
    /// may be on either, or on neither. Nor to one whose point its neighbourhood does not
    /// confirm ([`crate::surface::NoPoint::Unconfirmed`]).
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
    let row = w.max(1);
    // Rows in parallel from here on: a pixel's outcome depends on nothing another row writes.
    // First the least cost per pixel, with what the rest needs of it: the labels are read once.
    let mut choice = vec![None; w * h];
    let mut point = vec![[0.0f32; 3]; w * h];
    let mut direct = vec![0.0f32; w * h];
    let mut all = vec![0.0f32; w * h];
    choice
        .par_chunks_mut(row)
        .zip(point.par_chunks_mut(row))
        .zip(direct.par_chunks_mut(row))
        .zip(all.par_chunks_mut(row))
        .enumerate()
        .for_each(|(y, (((choice, point), direct), all))| {
            for x in 0..w {
                let i = y * w + x;
                let start = field.starts[i] as usize;
                let labels = &field.labels[start..field.starts[i + 1] as usize];
                // The least cost; ties go to the lower index (candidates come strongest first).
                let mut best: Option<(usize, f32)> = None;
                for l in 0..labels.len() {
                    let cost = ahead[start + l] + back[start + l];
                    match best {
                        Some((_, least)) if least <= cost => {}
                        _ => best = Some((l, cost)),
                    }
                }
                if let Some((l, _)) = best {
                    choice[x] = Some(l as u16);
                    point[x] = labels[l].point_mm;
                    direct[x] = labels[l].amplitude;
                }
                all[x] = labels.iter().map(|l| l.amplitude).sum();
            }
        });
    // Then a choice no chosen 8-neighbour lies within 2ε of is dropped, and the amplitudes.
    let reach_mm = 2.0 * params.epsilon_mm;
    let mut kept = vec![None; w * h];
    let mut indirect = vec![0.0f32; w * h];
    kept.par_chunks_mut(row)
        .zip(direct.par_chunks_mut(row))
        .zip(indirect.par_chunks_mut(row))
        .enumerate()
        .for_each(|(y, ((kept, direct), indirect))| {
            for x in 0..w {
                let i = y * w + x;
                let mut c = choice[i];
                if params.drop_isolated && c.is_some() {
                    // Isolated: some neighbour has chosen, and none within reach; the first
                    // one within reach settles it.
                    let mut chosen = neighbours(i, w, h)
                        .flatten()
                        .filter(|&j| choice[j].is_some());
                    let isolated = match chosen.next() {
                        None => false,
                        Some(first) => {
                            let near = |j: usize| distance_mm(&point[i], &point[j]) <= reach_mm;
                            !near(first) && !chosen.any(near)
                        }
                    };
                    if isolated {
                        c = None;
                        direct[x] = 0.0;
                    }
                }
                kept[x] = c;
                indirect[x] = all[i] - direct[x];
            }
        });
    Selection {
        width: w,
        height: h,
        choice: kept,
        direct,
        indirect,
    }
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
    // `f32::max` without its NaN test, which a running maximum from 0 never needs (a NaN
    // amplitude is skipped either way); a zero's sign does not change a data term.
    labels
        .iter()
        .map(|l| l.amplitude)
        .fold(0.0f32, |m, a| if a > m { a } else { m })
}

/// Candidates of a pixel in one [`Group`], one vector lane each.
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

/// Empty pixels on either side of a kept row, so that a step of up to two columns always lands
/// in the row: no bounds test per direction.
const PAD: usize = 2;

/// Up to [`LANES`] candidates of one pixel, structure of arrays, so a candidate is a lane.
#[derive(Clone, Copy, Default)]
struct Group {
    x: [f32; LANES],
    y: [f32; LANES],
    z: [f32; LANES],
    /// `C(v, l)`; +∞ in unused lanes, so their path costs are +∞ (or NaN), which [`least`]
    /// never takes from its second operand: a previous group can be used whole.
    data: [f32; LANES],
    /// Candidates in it, 1 to [`LANES`]; 0 for a pixel without candidates. The other lanes
    /// repeat the first's point.
    len: u32,
    /// Its first candidate's index in the field.
    label: u32,
}

impl Group {
    /// The group of `chunk`, 1 to [`LANES`] candidates from the field's `label`-th, whose
    /// pixel's strongest amplitude is `strongest`.
    #[inline(always)]
    fn new(chunk: &[Label], label: usize, strongest: f32) -> Self {
        // The other lanes repeat the first candidate: every lane then reads a candidate, and
        // the full group, nearly every pixel's, has no loop of unknown length.
        let lanes: [&Label; LANES] = match <&[Label; LANES]>::try_from(chunk) {
            Ok(full) => full.each_ref(),
            Err(_) => std::array::from_fn(|k| chunk.get(k).unwrap_or(&chunk[0])),
        };
        let n = chunk.len();
        let data = lanes.map(|l| data_cost(l.amplitude, strongest));
        Group {
            x: lanes.map(|l| l.point_mm[0]),
            y: lanes.map(|l| l.point_mm[1]),
            z: lanes.map(|l| l.point_mm[2]),
            data: std::array::from_fn(|k| if k < n { data[k] } else { f32::INFINITY }),
            len: n as u32,
            label: label as u32,
        }
    }
}

/// One row as a sweep visits it: its pixels' groups and their path costs in each of the
/// sweep's `ND` directions. A pixel's first group sits at its own index, so a previous pixel
/// is found without a table; nearly every pixel has at most [`LANES`] candidates.
struct Row<const ND: usize> {
    /// Pixel `a` (the `a`-th visited) has its first group in slot `a + PAD`.
    slots: Vec<Group>,
    /// `L_r` of slot `p`'s group and direction `d` at `[p][d]`.
    costs: Vec<[[f32; LANES]; ND]>,
    /// The groups after a slot's first (more than [`LANES`] candidates): slot `p`'s are
    /// `more[more_first[p]..more_first[p + 1]]`.
    more_first: Vec<u32>,
    more: Vec<Group>,
    more_costs: Vec<[[f32; LANES]; ND]>,
    /// Whether slots `p − PAD..=p + PAD` hold one group each: then every previous pixel of
    /// slot `p` in this row has exactly one.
    plain: Vec<bool>,
}

impl<const ND: usize> Default for Row<ND> {
    fn default() -> Self {
        Row {
            slots: Vec::new(),
            costs: Vec::new(),
            more_first: Vec::new(),
            more: Vec::new(),
            more_costs: Vec::new(),
            plain: Vec::new(),
        }
    }
}

impl<const ND: usize> Row<ND> {
    /// A row of `width` pixels without candidates.
    fn empty(width: usize) -> Self {
        let slots = width + 2 * PAD;
        Row {
            slots: vec![Group::default(); slots],
            costs: vec![[[0.0; LANES]; ND]; slots],
            more_first: vec![0; slots + 1],
            plain: vec![false; slots],
            ..Row::default()
        }
    }

    /// Fills the row with image row `y` in `order`. Inlined into each version's sweep, so
    /// that it is compiled with the sweep's vector instructions.
    #[inline(always)]
    fn fill(&mut self, field: &CandidateField, y: usize, order: Order) {
        let w = field.width;
        let slots = w + 2 * PAD;
        self.slots.clear();
        self.slots.resize(slots, Group::default());
        self.more_first.clear();
        self.more.clear();
        self.more_first.extend([0; PAD]);
        for a in 0..w {
            let x = if order == Order::Raster { a } else { w - 1 - a };
            let i = y * w + x;
            let start = field.starts[i] as usize;
            let here = &field.labels[start..field.starts[i + 1] as usize];
            self.more_first.push(self.more.len() as u32);
            let strongest = strongest(here);
            // The first group in the pixel's slot, the rest (rare) in `more`.
            let (first, rest) = here.split_at(here.len().min(LANES));
            if !first.is_empty() {
                self.slots[a + PAD] = Group::new(first, start, strongest);
            }
            for (c, chunk) in rest.chunks(LANES).enumerate() {
                self.more
                    .push(Group::new(chunk, start + (c + 1) * LANES, strongest));
            }
        }
        let end = self.more.len() as u32;
        self.more_first.extend([end; PAD + 1]);
        self.plain.clear();
        self.plain.resize(slots, false);
        let mut run = 0;
        for p in 0..slots {
            let one = self.slots[p].len > 0 && self.more_first[p] == self.more_first[p + 1];
            run = if one { run + 1 } else { 0 };
            if run > 2 * PAD {
                self.plain[p - PAD] = true;
            }
        }
        self.costs.resize(slots, [[0.0; LANES]; ND]);
        self.more_costs.resize(self.more.len(), [[0.0; LANES]; ND]);
    }

    /// Slots `a` to `a + 2·PAD` (pixel `a`'s and the two on either side) and their costs.
    #[inline(always)]
    #[allow(clippy::type_complexity)]
    fn window(&self, a: usize) -> (&[Group; 2 * PAD + 1], &[[[f32; LANES]; ND]; 2 * PAD + 1]) {
        (
            self.slots[a..=a + 2 * PAD].try_into().unwrap(),
            self.costs[a..=a + 2 * PAD].try_into().unwrap(),
        )
    }

    /// Slot `p`'s groups with their path costs, in the field's order.
    #[inline(always)]
    fn groups(&self, p: usize) -> impl Iterator<Item = (&Group, &[[f32; LANES]; ND])> {
        let more = self.more_first[p] as usize..self.more_first[p + 1] as usize;
        let first = (self.slots[p].len > 0).then(|| (&self.slots[p], &self.costs[p]));
        first
            .into_iter()
            .chain(self.more[more.clone()].iter().zip(&self.more_costs[more]))
    }
}

/// `Σ_r L_r` per candidate over `directions`, added in their order, in one sweep over the image
/// in `order` (every direction's previous pixel must come earlier in it).
fn sweep(
    field: &CandidateField,
    params: &SelectionParams,
    directions: &[Step],
    order: Order,
) -> Vec<f32> {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F.
            return unsafe { avx512::sweep(field, params, directions, order) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2.
            return unsafe { avx2::sweep(field, params, directions, order) };
        }
    }
    portable_sweep(field, params, directions, order)
}

/// [`sweep`] without vector instructions of its own.
fn portable_sweep(
    field: &CandidateField,
    params: &SelectionParams,
    directions: &[Step],
    order: Order,
) -> Vec<f32> {
    sweep_with::<Portable>(field, params, directions, order)
}

/// The instructions a sweep is compiled for: a group's points prepared for [`fold`], a version
/// of it, and of [`plain_by_fold`].
trait Version {
    type Here;

    fn here(group: &Group) -> Self::Here;

    fn fold(
        here: &Self::Here,
        there: &Group,
        previous: &[f32; LANES],
        best: [f32; LANES],
        beta: f32,
        epsilon: f32,
    ) -> [f32; LANES];

    #[inline(always)]
    fn plain<const ND: usize>(
        group: &Group,
        there: [&Group; ND],
        previous: [&[f32; LANES]; ND],
        beta: f32,
        epsilon: f32,
    ) -> ([[f32; LANES]; ND], [f32; LANES]) {
        plain_by_fold::<Self, ND>(group, there, previous, beta, epsilon)
    }
}

/// [`fold`] as it is.
struct Portable;

impl Version for Portable {
    type Here = Group;

    #[inline(always)]
    fn here(group: &Group) -> Group {
        *group
    }

    #[inline(always)]
    fn fold(
        here: &Group,
        there: &Group,
        previous: &[f32; LANES],
        best: [f32; LANES],
        beta: f32,
        epsilon: f32,
    ) -> [f32; LANES] {
        fold(here, there, previous, best, beta, epsilon)
    }
}

/// `min_{l'} (L_r(v − r, l') + S(l, l'))` for a group's candidates `l`, one lane each, carried
/// on from `best` over the previous candidates `l'` of `there`, whose path costs are
/// `previous`, in their order: each lane does the scalar operations of [`step_cost`] in the
/// same order as one candidate at a time (the test oracle).
#[inline(always)]
fn fold(
    here: &Group,
    there: &Group,
    previous: &[f32; LANES],
    mut best: [f32; LANES],
    beta: f32,
    epsilon: f32,
) -> [f32; LANES] {
    for (j, &cost) in previous.iter().enumerate() {
        let (tx, ty, tz) = (there.x[j], there.y[j], there.z[j]);
        for (k, best) in best.iter_mut().enumerate() {
            let step = step_cost(
                here.x[k] - tx,
                here.y[k] - ty,
                here.z[k] - tz,
                beta,
                epsilon,
            );
            *best = least(*best, cost + step);
        }
    }
    best
}

/// `L_r` of `group` in every direction `d` whose previous pixel holds exactly one group,
/// `there[d]` with path costs `previous[d]`, and their sum in the directions' order.
#[inline(always)]
fn plain_by_fold<V: Version + ?Sized, const ND: usize>(
    group: &Group,
    there: [&Group; ND],
    previous: [&[f32; LANES]; ND],
    beta: f32,
    epsilon: f32,
) -> ([[f32; LANES]; ND], [f32; LANES]) {
    let prepared = V::here(group);
    let paths: [[f32; LANES]; ND] = std::array::from_fn(|d| {
        let mut floor = f32::INFINITY;
        for &cost in previous[d] {
            floor = least(floor, cost);
        }
        let best = V::fold(
            &prepared,
            there[d],
            previous[d],
            [f32::INFINITY; LANES],
            beta,
            epsilon,
        );
        std::array::from_fn(|k| group.data[k] + best[k] - floor)
    });
    let mut total = [0.0f32; LANES];
    for path in &paths {
        for k in 0..LANES {
            total[k] += path[k];
        }
    }
    (paths, total)
}

/// Four lanes in and out of an SSE register, for both vector versions of [`fold`].
#[cfg(target_arch = "x86_64")]
mod sse {
    use super::LANES;
    use std::arch::x86_64::*;

    #[inline(always)]
    pub(super) fn load(v: &[f32; LANES]) -> __m128 {
        // SAFETY: reads the four floats of `v`; SSE is part of x86-64.
        unsafe { _mm_loadu_ps(v.as_ptr()) }
    }

    #[inline(always)]
    pub(super) fn store(v: __m128) -> [f32; LANES] {
        // SAFETY: four floats either way.
        unsafe { std::mem::transmute::<__m128, [f32; LANES]>(v) }
    }
}

/// [`fold`] with AVX2: two previous candidates a register.
#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::sse::{load, store};
    use super::*;
    use std::arch::x86_64::*;

    /// [`super::sweep_with`] for AVX2 and [`fold`].
    #[target_feature(enable = "avx2")]
    pub(super) fn sweep(
        field: &CandidateField,
        params: &SelectionParams,
        directions: &[Step],
        order: Order,
    ) -> Vec<f32> {
        sweep_with::<Avx2>(field, params, directions, order)
    }

    /// [`sweep`]'s version.
    pub(super) struct Avx2;

    impl Version for Avx2 {
        type Here = Here;

        #[inline(always)]
        fn here(group: &Group) -> Here {
            Here::new(group)
        }

        #[inline(always)]
        fn fold(
            here: &Here,
            there: &Group,
            previous: &[f32; LANES],
            best: [f32; LANES],
            beta: f32,
            epsilon: f32,
        ) -> [f32; LANES] {
            // SAFETY: `sweep`, the only user of `Avx2`, runs with AVX2.
            unsafe { fold(here, there, previous, best, beta, epsilon) }
        }
    }

    /// A group's points, each coordinate's lanes twice (for two previous candidates).
    #[derive(Clone, Copy)]
    pub(super) struct Here {
        x: __m256,
        y: __m256,
        z: __m256,
    }

    impl Here {
        #[inline(always)]
        fn new(group: &Group) -> Self {
            // SAFETY: `sweep`, the only caller, runs with AVX2.
            unsafe {
                let twice = |v: &[f32; LANES]| _mm256_broadcast_ps(&load(v));
                Here {
                    x: twice(&group.x),
                    y: twice(&group.y),
                    z: twice(&group.z),
                }
            }
        }
    }

    /// [`super::fold`], the same operations per lane: lanes 0–3 step from previous candidate
    /// `j`, lanes 4–7 from `j + 1`; each half is folded into `best` in turn.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn fold(
        here: &Here,
        there: &Group,
        previous: &[f32; LANES],
        best: [f32; LANES],
        beta: f32,
        epsilon: f32,
    ) -> [f32; LANES] {
        let (beta, epsilon, zero) = (
            _mm256_set1_ps(beta),
            _mm256_set1_ps(epsilon),
            _mm256_setzero_ps(),
        );
        let mut best = load(&best);
        let twice = |v: &[f32; LANES]| _mm256_broadcast_ps(&load(v));
        let (tx, ty, tz) = (twice(&there.x), twice(&there.y), twice(&there.z));
        for half in 0..2 {
            // Previous candidate `2·half` in lanes 0–3, the next one in lanes 4–7.
            let j = 2 * half as i32;
            let spread = _mm256_setr_epi32(j, j, j, j, j + 1, j + 1, j + 1, j + 1);
            let (ex, ey, ez) = (
                _mm256_sub_ps(here.x, _mm256_permutevar8x32_ps(tx, spread)),
                _mm256_sub_ps(here.y, _mm256_permutevar8x32_ps(ty, spread)),
                _mm256_sub_ps(here.z, _mm256_permutevar8x32_ps(tz, spread)),
            );
            let squared = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(ex, ex), _mm256_mul_ps(ey, ey)),
                _mm256_mul_ps(ez, ez),
            );
            let beyond = _mm256_sub_ps(_mm256_sqrt_ps(squared), epsilon);
            // `max(a, b)` is `a > b ? a : b`, as in `step_cost`.
            let step = _mm256_mul_ps(beta, _mm256_max_ps(beyond, zero));
            // `cost + step` a half at a time, the cost broadcast from memory: no shuffle.
            // `least(a, b)` is `b < a ? b : a`, that is `min(b, a)`.
            let j = 2 * half;
            let moved = _mm_add_ps(_mm_set1_ps(previous[j]), _mm256_castps256_ps128(step));
            best = _mm_min_ps(moved, best);
            let high = _mm256_extractf128_ps::<1>(step);
            let moved = _mm_add_ps(_mm_set1_ps(previous[j + 1]), high);
            best = _mm_min_ps(moved, best);
        }
        store(best)
    }
}

/// [`fold`] with AVX-512: the sixteen steps between a group's candidates and a previous
/// group's in one register, lane `4j + k` from previous candidate `j` to candidate `k`.
#[cfg(target_arch = "x86_64")]
mod avx512 {
    use super::sse::{load, store};
    use super::*;
    use std::arch::x86_64::*;

    /// [`super::sweep_with`] for AVX-512, [`fold`] and [`plain`].
    #[target_feature(enable = "avx512f")]
    pub(super) fn sweep(
        field: &CandidateField,
        params: &SelectionParams,
        directions: &[Step],
        order: Order,
    ) -> Vec<f32> {
        sweep_with::<Avx512>(field, params, directions, order)
    }

    /// [`sweep`]'s version.
    pub(super) struct Avx512;

    impl Version for Avx512 {
        type Here = Here;

        #[inline(always)]
        fn here(group: &Group) -> Here {
            Here::new(group)
        }

        #[inline(always)]
        fn fold(
            here: &Here,
            there: &Group,
            previous: &[f32; LANES],
            best: [f32; LANES],
            beta: f32,
            epsilon: f32,
        ) -> [f32; LANES] {
            // SAFETY: `sweep`, the only user of `Avx512`, runs with AVX-512F.
            unsafe { fold(here, there, previous, best, beta, epsilon) }
        }

        #[inline(always)]
        fn plain<const ND: usize>(
            group: &Group,
            there: [&Group; ND],
            previous: [&[f32; LANES]; ND],
            beta: f32,
            epsilon: f32,
        ) -> ([[f32; LANES]; ND], [f32; LANES]) {
            // SAFETY: as for `fold`.
            unsafe { plain(group, there, previous, beta, epsilon) }
        }
    }

    /// A group's points, each coordinate's lanes four times (once per previous candidate).
    #[derive(Clone, Copy)]
    pub(super) struct Here {
        x: __m512,
        y: __m512,
        z: __m512,
    }

    impl Here {
        #[inline(always)]
        fn new(group: &Group) -> Self {
            // SAFETY: `sweep`, the only caller, runs with AVX-512F.
            let four = |v: &[f32; LANES]| unsafe { _mm512_broadcast_f32x4(load(v)) };
            Here {
                x: four(&group.x),
                y: four(&group.y),
                z: four(&group.z),
            }
        }
    }

    /// Lane `4j + k` takes lane `j` of four.
    #[inline(always)]
    fn spread(v: &[f32; LANES]) -> __m512 {
        // SAFETY: `sweep`, the only caller, runs with AVX-512F.
        unsafe {
            let spread = _mm512_set_epi32(3, 3, 3, 3, 2, 2, 2, 2, 1, 1, 1, 1, 0, 0, 0, 0);
            _mm512_permutexvar_ps(spread, _mm512_castps128_ps512(load(v)))
        }
    }

    /// [`super::fold`], the same operations per step. The least over the previous candidates
    /// is taken as a tree (halves, then quarters) instead of one after another: the same value,
    /// as a minimum does not round, once a NaN step (which the sequential fold skips, as
    /// `least` never takes a NaN second operand) is made +∞, which no minimum takes either.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn fold(
        here: &Here,
        there: &Group,
        previous: &[f32; LANES],
        best: [f32; LANES],
        beta: f32,
        epsilon: f32,
    ) -> [f32; LANES] {
        let (ex, ey, ez) = (
            _mm512_sub_ps(here.x, spread(&there.x)),
            _mm512_sub_ps(here.y, spread(&there.y)),
            _mm512_sub_ps(here.z, spread(&there.z)),
        );
        let squared = _mm512_add_ps(
            _mm512_add_ps(_mm512_mul_ps(ex, ex), _mm512_mul_ps(ey, ey)),
            _mm512_mul_ps(ez, ez),
        );
        let beyond = _mm512_sub_ps(_mm512_sqrt_ps(squared), _mm512_set1_ps(epsilon));
        // `max(a, b)` is `a > b ? a : b`, as in `step_cost`.
        let step = _mm512_mul_ps(
            _mm512_set1_ps(beta),
            _mm512_max_ps(beyond, _mm512_setzero_ps()),
        );
        // Previous candidate `j`'s cost in lanes `4j` to `4j + 3`.
        let costs = spread(previous);
        // `min(a, +∞)` is `a < +∞ ? a : +∞`: +∞ for NaN, `a` otherwise.
        let moved = _mm512_min_ps(_mm512_add_ps(costs, step), _mm512_set1_ps(f32::INFINITY));
        let high = _mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(_mm512_castps_pd(moved)));
        let halves = _mm256_min_ps(_mm512_castps512_ps256(moved), high);
        let quarters = _mm_min_ps(
            _mm256_castps256_ps128(halves),
            _mm256_extractf128_ps::<1>(halves),
        );
        // `least(a, b)` is `b < a ? b : a`, that is `min(b, a)`.
        store(_mm_min_ps(quarters, load(&best)))
    }

    /// The least of lanes `4i` to `4i + 3` of `a` in lane `4i`, and of `b` in lane `4i + 2`,
    /// with [`least`]'s outcome one lane after another: on a tie the earlier lane's value (the
    /// same bits even for ±0). NaN lanes must be made +∞ first.
    #[inline(always)]
    fn least_of_fours(a: __m512, b: __m512) -> __m512 {
        // SAFETY: `sweep`, the only caller, runs with AVX-512F.
        unsafe {
            // Lanes 0, 2 of `a`, then of `b`; and lanes 1, 3.
            let even = _mm512_shuffle_ps::<0b10_00_10_00>(a, b);
            let odd = _mm512_shuffle_ps::<0b11_01_11_01>(a, b);
            // `least(x, y)` is `min(y, x)`: the later lane only where it is less.
            let pairs = _mm512_min_ps(odd, even);
            _mm512_min_ps(_mm512_permute_ps::<0b10_11_00_01>(pairs), pairs)
        }
    }

    /// A group's four lanes in each quarter, NaN made +∞.
    #[inline(always)]
    fn four(v: &[f32; LANES]) -> __m512 {
        // SAFETY: `sweep`, the only caller, runs with AVX-512F.
        unsafe {
            _mm512_min_ps(
                _mm512_broadcast_f32x4(load(v)),
                _mm512_set1_ps(f32::INFINITY),
            )
        }
    }

    /// `L_r(v − r, j) + S(j, k)` in lane `4k + j` for a group spread over `here` (lane
    /// `4k + j` of candidate `k`), NaN made +∞ (see [`fold`]).
    #[inline(always)]
    fn moved(
        here: &[__m512; 3],
        there: &Group,
        previous: &[f32; LANES],
        beta: __m512,
        epsilon: __m512,
    ) -> __m512 {
        // SAFETY: `sweep`, the only caller, runs with AVX-512F.
        unsafe {
            let four = |v: &[f32; LANES]| _mm512_broadcast_f32x4(load(v));
            let (ex, ey, ez) = (
                _mm512_sub_ps(here[0], four(&there.x)),
                _mm512_sub_ps(here[1], four(&there.y)),
                _mm512_sub_ps(here[2], four(&there.z)),
            );
            let squared = _mm512_add_ps(
                _mm512_add_ps(_mm512_mul_ps(ex, ex), _mm512_mul_ps(ey, ey)),
                _mm512_mul_ps(ez, ez),
            );
            let beyond = _mm512_sub_ps(_mm512_sqrt_ps(squared), epsilon);
            // `max(a, b)` is `a > b ? a : b`, as in `step_cost`.
            let step = _mm512_mul_ps(beta, _mm512_max_ps(beyond, _mm512_setzero_ps()));
            _mm512_min_ps(
                _mm512_add_ps(four(previous), step),
                _mm512_set1_ps(f32::INFINITY),
            )
        }
    }

    /// `L_r(v, k) = C(v, k) + best − floor` for two directions, the first in lanes `4k`, the
    /// second in lanes `4k + 2`, from [`moved`]'s least (see [`least_of_fours`]).
    #[inline(always)]
    fn pair(
        here: &[__m512; 3],
        data: __m512,
        there: [&Group; 2],
        previous: [&[f32; LANES]; 2],
        beta: __m512,
        epsilon: __m512,
    ) -> __m512 {
        let best = least_of_fours(
            moved(here, there[0], previous[0], beta, epsilon),
            moved(here, there[1], previous[1], beta, epsilon),
        );
        let floor = least_of_fours(four(previous[0]), four(previous[1]));
        // SAFETY: `sweep`, the only caller, runs with AVX-512F.
        unsafe { _mm512_sub_ps(_mm512_add_ps(data, best), floor) }
    }

    /// [`super::plain_by_fold`] with the roles turned: lane `4k + j` steps from previous
    /// candidate `j` to candidate `k`, so the previous group is read by a broadcast load
    /// rather than spread by permutes, and the minima of two directions share their shuffles.
    /// The same operations per step, and the minima are [`least`]'s (see [`least_of_fours`]).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn plain<const ND: usize>(
        group: &Group,
        there: [&Group; ND],
        previous: [&[f32; LANES]; ND],
        beta: f32,
        epsilon: f32,
    ) -> ([[f32; LANES]; ND], [f32; LANES]) {
        assert!(ND.is_multiple_of(4));
        let mut out = [[0.0f32; LANES]; ND];
        let (hx, hy, hz, data) = (
            spread(&group.x),
            spread(&group.y),
            spread(&group.z),
            spread(&group.data),
        );
        let here = [hx, hy, hz];
        let (beta, epsilon) = (_mm512_set1_ps(beta), _mm512_set1_ps(epsilon));
        // Lanes 0, 4, 8, 12 of `a`, then 2, 6, 10, 14; the same of `b`.
        let gather = _mm512_set_epi32(30, 26, 22, 18, 28, 24, 20, 16, 14, 10, 6, 2, 12, 8, 4, 0);
        let mut total = _mm_setzero_ps();
        for (q, out) in out.chunks_exact_mut(4).enumerate() {
            let d = 4 * q;
            let (ahead, next) = (
                pair(
                    &here,
                    data,
                    [there[d], there[d + 1]],
                    [previous[d], previous[d + 1]],
                    beta,
                    epsilon,
                ),
                pair(
                    &here,
                    data,
                    [there[d + 2], there[d + 3]],
                    [previous[d + 2], previous[d + 3]],
                    beta,
                    epsilon,
                ),
            );
            let paths = _mm512_permutex2var_ps(ahead, gather, next);
            total = _mm_add_ps(total, _mm512_castps512_ps128(paths));
            total = _mm_add_ps(total, _mm512_extractf32x4_ps::<1>(paths));
            total = _mm_add_ps(total, _mm512_extractf32x4_ps::<2>(paths));
            total = _mm_add_ps(total, _mm512_extractf32x4_ps::<3>(paths));
            // SAFETY: sixteen floats either way.
            let paths = unsafe { std::mem::transmute::<__m512, [[f32; LANES]; 4]>(paths) };
            out.copy_from_slice(&paths);
        }
        (out, store(total))
    }
}

/// [`sweep`] for version `V`.
#[inline(always)]
fn sweep_with<V: Version>(
    field: &CandidateField,
    params: &SelectionParams,
    directions: &[Step],
    order: Order,
) -> Vec<f32> {
    // The number of directions is a constant of the loops: a group's paths are an array, and
    // a row's costs are indexed by group without a multiplication.
    match directions.len() {
        0 => vec![0.0; field.labels.len()],
        4 => sweep_rows::<4, V>(field, params, directions, order),
        8 => sweep_rows::<8, V>(field, params, directions, order),
        n => unreachable!("a sweep takes half of 8 or 16 paths, not {n}"),
    }
}

/// Where the previous pixel of each of a sweep's directions is in the sweep's own frame, for
/// both sweeps of [`Paths::directions`]: its slot relative to the current pixel's
/// `slot − PAD`, and the rows back. As constants, the one-group step finds its previous
/// pixels without a table or a bounds test.
const BACK: [(usize, usize); 8] = [
    (1, 0),
    (2, 1),
    (1, 1),
    (3, 1),
    (0, 1),
    (4, 1),
    (1, 2),
    (3, 2),
];

/// [`sweep_with`] for `ND` directions.
///
/// A row's points are gathered once into [`Group`]s for all the sweep's directions.
#[inline(always)]
fn sweep_rows<const ND: usize, V: Version>(
    field: &CandidateField,
    params: &SelectionParams,
    directions: &[Step],
    order: Order,
) -> Vec<f32> {
    let (w, h) = (field.width, field.height);
    let mut sum = vec![0.0f32; field.labels.len()];
    if w == 0 || h == 0 {
        return sum;
    }
    let (beta, epsilon) = (params.beta_per_mm, params.epsilon_mm);
    // In the order's own frame (pixel `a` of row `s`, both counted as visited) every previous
    // pixel is `(a − dx, s − dy)` with `dy` 0 to 2 and `dx` −2 to 2: its slot relative to
    // `a`, and the rows back.
    let back: [(usize, usize); ND] = std::array::from_fn(|d| {
        let (dx, dy) = directions[d];
        let (dx, dy) = if order == Order::Raster {
            (dx, dy)
        } else {
            (-dx, -dy)
        };
        debug_assert!((0..ROWS_KEPT as i32).contains(&dy) && dx.unsigned_abs() as usize <= PAD);
        ((PAD as i32 - dx) as usize, dy as usize)
    });
    let known = back[..] == BACK[..ND];
    let empty = Row::<ND>::empty(w);
    let mut rows: [Row<ND>; ROWS_KEPT] = std::array::from_fn(|_| Row::default());
    for s in 0..h {
        let y = if order == Order::Raster { s } else { h - 1 - s };
        let mut row = std::mem::take(&mut rows[s % ROWS_KEPT]);
        row.fill(field, y, order);
        // The rows 1 and 2 back, or rows without candidates above the image.
        let earlier: [&Row<ND>; ROWS_KEPT - 1] = std::array::from_fn(|k| {
            let dy = k + 1;
            if dy <= s {
                &rows[(s - dy) % ROWS_KEPT]
            } else {
                &empty
            }
        });
        for a in 0..w {
            let p = a + PAD;
            if row.slots[p].len == 0 {
                continue;
            }
            let before_rows = [&row, earlier[0], earlier[1]];
            if known && before_rows.iter().all(|r| r.plain[p]) {
                // Every previous pixel has one group: found at fixed places, no list to walk.
                let windows = before_rows.map(|r| r.window(a));
                let there: [&Group; ND] = std::array::from_fn(|d| {
                    let (slot, dy) = BACK[d];
                    &windows[dy].0[slot]
                });
                let previous: [&[f32; LANES]; ND] = std::array::from_fn(|d| {
                    let (slot, dy) = BACK[d];
                    &windows[dy].1[slot][d]
                });
                let group = &row.slots[p];
                let (paths, total) = V::plain(group, there, previous, beta, epsilon);
                let (n, at) = (group.len as usize, group.label as usize);
                row.costs[p] = paths;
                if n == LANES {
                    sum[at..at + LANES].copy_from_slice(&total);
                } else {
                    // Element by element: a slice copy of at most three floats calls memcpy.
                    #[allow(clippy::manual_memcpy)]
                    for k in 0..n {
                        sum[at + k] = total[k];
                    }
                }
                continue;
            }
            let more = row.more_first[p] as usize..row.more_first[p + 1] as usize;
            for g in 0..1 + more.len() {
                let before_rows = [&row, earlier[0], earlier[1]];
                let group = if g == 0 {
                    &row.slots[p]
                } else {
                    &row.more[more.start + g - 1]
                };
                let prepared = V::here(group);
                let paths: [[f32; LANES]; ND] = std::array::from_fn(|d| {
                    let (offset, dy) = back[d];
                    let before = before_rows[dy];
                    let q = a + offset;
                    if before.slots[q].len == 0 {
                        // A path starts here: at the border or after a pixel without candidates.
                        return group.data;
                    }
                    let mut floor = f32::INFINITY;
                    let mut best = [f32::INFINITY; LANES];
                    for (there, costs) in before.groups(q) {
                        let previous = &costs[d];
                        for &cost in previous {
                            floor = least(floor, cost);
                        }
                        best = V::fold(&prepared, there, previous, best, beta, epsilon);
                    }
                    std::array::from_fn(|k| group.data[k] + best[k] - floor)
                });
                let mut total = [0.0f32; LANES];
                for path in &paths {
                    for k in 0..LANES {
                        total[k] += path[k];
                    }
                }
                let (n, at) = (group.len as usize, group.label as usize);
                if g == 0 {
                    row.costs[p] = paths;
                } else {
                    row.more_costs[more.start + g - 1] = paths;
                }
                if n == LANES {
                    sum[at..at + LANES].copy_from_slice(&total);
                } else {
                    // Element by element: a slice copy of at most three floats calls memcpy.
                    #[allow(clippy::manual_memcpy)]
                    for k in 0..n {
                        sum[at + k] = total[k];
                    }
                }
            }
        }
        rows[s % ROWS_KEPT] = row;
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

    #[test]
    fn paths_are_named_by_their_count() {
        assert_eq!("8".parse::<Paths>(), Ok(Paths::Eight));
        assert_eq!("16".parse::<Paths>(), Ok(Paths::Sixteen));
        for bad in ["4", "", "16 "] {
            let e = bad.parse::<Paths>().unwrap_err();
            assert!(e.contains("8 or 16"), "{e}");
        }
    }

    /// Marsaglia's xorshift64 from `state`: the tests' random layouts, the same on every run.
    fn xorshift(mut state: u64) -> impl FnMut() -> u64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        }
    }

    /// `C(v, l)` of every candidate, in the field's order.
    fn data_costs(field: &CandidateField) -> Vec<f32> {
        let w = field.width;
        (0..w * field.height)
            .flat_map(|i| {
                let labels = field.labels(i % w, i / w);
                let strongest = strongest(labels);
                labels
                    .iter()
                    .map(move |l| data_cost(l.amplitude, strongest))
            })
            .collect()
    }

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
        // 0 to 9 candidates per pixel (more than one group of lanes, and partial groups); then
        // mostly 1 to 4, as in a scan, where most pixels take the one-group path.
        let few = |r: u64| match r % 40 {
            0 => 0,
            1 => 5 + (r >> 8) % 5,
            _ => 1 + (r >> 8) % 4,
        };
        for count in [|r: u64| r % 10, few] {
            compare_sweeps_with_the_oracle(count);
        }
    }

    /// Compares every version of [`sweep`] with [`aggregate_one_at_a_time`], with `count(r)`
    /// candidates per pixel for a random `r`.
    fn compare_sweeps_with_the_oracle(count: fn(u64) -> u64) {
        // Some candidates within ε of their neighbours', some beyond; a xorshift for the layout.
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15u64);
        let mut counts = Vec::new();
        let mut labels = Vec::new();
        let (w, h) = (23, 17);
        for y in 0..h {
            for x in 0..w {
                let n = count(next()) as u32;
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
        let data = data_costs(&field);
        let params = SelectionParams::for_footprint(0.5);
        let (mut compared, mut runs) = (0, 0);
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
                // The portable sweep and each vector version the CPU has.
                let mut versions = vec![portable_sweep(&field, &params, &directions, order)];
                #[cfg(target_arch = "x86_64")]
                {
                    if std::arch::is_x86_feature_detected!("avx2") {
                        // SAFETY: the CPU has AVX2.
                        versions.push(unsafe { avx2::sweep(&field, &params, &directions, order) });
                    }
                    if std::arch::is_x86_feature_detected!("avx512f") {
                        // SAFETY: the CPU has AVX-512F.
                        versions
                            .push(unsafe { avx512::sweep(&field, &params, &directions, order) });
                    }
                }
                runs += versions.len();
                for (version, swept) in versions.into_iter().enumerate() {
                    assert_eq!(swept.len(), oracle.len());
                    for (i, (a, b)) in swept.iter().zip(&oracle).enumerate() {
                        assert_eq!(
                            a.to_bits(),
                            b.to_bits(),
                            "{paths:?} {directions:?}, version {version}, candidate {i}"
                        );
                        compared += 1;
                    }
                }
            }
        }
        assert!(runs >= 4, "two path sets, two sweeps each");
        assert_eq!(compared, runs * data.len());
    }

    /// [`select`] written out plainly on the oracle's paths: the sums, the least, the isolated
    /// choices dropped, the amplitudes.
    fn select_plainly(field: &CandidateField, params: &SelectionParams) -> Selection {
        let (w, h) = (field.width, field.height);
        let data = data_costs(field);
        let (raster, reverse) = params.paths.sweeps();
        let sum = |directions: &[Step]| {
            let mut sum = vec![0.0f32; data.len()];
            for &direction in directions {
                let path = aggregate_one_at_a_time(field, &data, params, direction);
                for (s, p) in sum.iter_mut().zip(path) {
                    *s += p;
                }
            }
            sum
        };
        let (ahead, back) = (sum(&raster), sum(&reverse));
        let mut choice = vec![None; w * h];
        for (i, c) in choice.iter_mut().enumerate() {
            let start = field.starts[i] as usize;
            let mut best: Option<(u16, f32)> = None;
            for l in 0..field.labels(i % w, i / w).len() {
                let cost = ahead[start + l] + back[start + l];
                if best.is_none_or(|(_, least)| cost < least) {
                    best = Some((l as u16, cost));
                }
            }
            *c = best.map(|(l, _)| l);
        }
        let point = |x: usize, y: usize, choice: &[Option<u16>]| {
            choice[y * w + x].map(|c| field.labels(x, y)[c as usize].point_mm)
        };
        let mut kept = choice.clone();
        if params.drop_isolated {
            for y in 0..h {
                for x in 0..w {
                    let Some(p) = point(x, y, &choice) else {
                        continue;
                    };
                    let mut chosen = 0;
                    let mut near = false;
                    for ny in y.saturating_sub(1)..(y + 2).min(h) {
                        for nx in x.saturating_sub(1)..(x + 2).min(w) {
                            if (nx, ny) == (x, y) {
                                continue;
                            }
                            if let Some(q) = point(nx, ny, &choice) {
                                chosen += 1;
                                near |= distance_mm(&p, &q) <= 2.0 * params.epsilon_mm;
                            }
                        }
                    }
                    if chosen > 0 && !near {
                        kept[y * w + x] = None;
                    }
                }
            }
        }
        let amplitudes = |i: usize| field.labels(i % w, i / w).iter().map(|l| l.amplitude);
        let direct: Vec<f32> = (0..w * h)
            .map(|i| kept[i].map_or(0.0, |c| amplitudes(i).nth(c as usize).unwrap()))
            .collect();
        let indirect = (0..w * h)
            .map(|i| amplitudes(i).sum::<f32>() - direct[i])
            .collect();
        Selection {
            width: w,
            height: h,
            choice: kept,
            direct,
            indirect,
        }
    }

    #[test]
    fn the_selection_is_the_plain_one_bit_for_bit() {
        // 0 to 6 candidates per pixel at random points, some within ε of their neighbours'.
        let mut next = xorshift(0x2545_f491_4f6c_dd1du64);
        let (w, h) = (31, 19);
        let mut counts = Vec::new();
        let mut labels = Vec::new();
        for y in 0..h {
            for x in 0..w {
                let n = (next() % 7) as u32;
                counts.push(n);
                for _ in 0..n {
                    let r = next();
                    let on_surface = r & 3 != 0;
                    let jitter = |shift: u32| (r >> shift & 0xff) as f32 / 255.0;
                    let point_mm = if on_surface {
                        [
                            x as f32 * 0.5 + 0.2 * jitter(8),
                            y as f32 * 0.5 + 0.2 * jitter(16),
                            500.0 + 0.05 * x as f32 + 0.5 * jitter(24),
                        ]
                    } else {
                        [
                            40.0 * jitter(8) - 10.0,
                            40.0 * jitter(16) - 10.0,
                            450.0 + 100.0 * jitter(24),
                        ]
                    };
                    labels.push(Label {
                        point_mm,
                        amplitude: 1.0 + (r >> 32 & 0xff) as f32,
                        column: 0.0,
                    });
                }
            }
        }
        let field = CandidateField::from_counts(w, h, &counts, labels);
        for paths in [Paths::Eight, Paths::Sixteen] {
            for drop_isolated in [false, true] {
                let params = SelectionParams {
                    paths,
                    drop_isolated,
                    ..SelectionParams::for_footprint(0.5)
                };
                let (got, plain) = (select(&field, &params), select_plainly(&field, &params));
                assert_eq!(got.choice, plain.choice, "{paths:?} {drop_isolated}");
                let bits = |v: &[f32]| v.iter().map(|a| a.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&got.direct), bits(&plain.direct));
                assert_eq!(bits(&got.indirect), bits(&plain.indirect));
                assert!(got.choice.iter().any(Option::is_some));
            }
        }
    }
}
