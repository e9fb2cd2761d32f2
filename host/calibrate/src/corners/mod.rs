//! The board's inner corners in a camera image, sub-pixel.
//!
//! [`detect`] takes one grey image (row-major `f32`, any scale: the white-frame capture in
//! sensor codes, a signal in reference whites, …) and returns the board's inner corners in the
//! camera pixel convention of SPEC §1 (pixel centres at integer coordinates), in the order of
//! [`Checkerboard::corners_mm`] — or an error that says what failed.
//!
//! ## How
//!
//! 1. **Normalise**: the 2nd and 98th percentiles of the image map to 0 and 1 (an image with no
//!    contrast is an error).
//! 2. **Candidates**: the ChESS response (Bennett & Lasenby 2014) on a ring of 16 samples of
//!    radius `r` around each pixel of the lightly smoothed image — large where opposite ring
//!    samples agree and the two diameters at right angles to each other differ, i.e. at an
//!    X-junction of squares, and negative on edges; then non-maximum suppression and a threshold
//!    relative to the strongest response. Radii 5, 3 and 8 px are tried in that order (squares
//!    from ≈ 8 px to hundreds of px across).
//! 3. **Grid**: from a seed candidate and its four lattice neighbours, the lattice is grown
//!    cell by cell, each neighbour predicted by linear extrapolation along its row or column
//!    (perspective and distortion bend the lattice slowly) and accepted within 0.3 of a step.
//!    The grown grid must hold a complete `inner_columns × inner_rows` block (either way round).
//! 4. **Orientation** (the board's symmetry ambiguity; see below).
//! 5. **Sub-pixel**, in three steps:
//!    1. the gradient-orthogonality iteration of OpenCV's `cornerSubPix` (every image
//!       gradient near a corner is perpendicular to the vector from the corner, on both edges
//!       through it) on the image smoothed by 1.5 px, in a smoothly weighted window of
//!       3/4 of the local lattice step, iterated to 1e-4 px (`refine`);
//!    2. from there, a least-squares fit of a model of the corner (two blurred edges, the
//!       pixel's square footprint, graded light) to the raw pixels of the four squares around
//!       it (`corners/junction.rs`), with straight edges;
//!    3. the same fit with each edge bent as its row or column of corners from step 2 is (the
//!       lens's distortion).
//!
//!    A corner whose fit fails its checks keeps the previous step's position. The fit is what
//!    makes the corners precise enough for the 0.02% calibration (3 to 8 times less error than
//!    `cornerSubPix` alone: figures in `corners/junction.rs`).
//!
//! ## Which corner is (0, 0): the orientation rule
//!
//! The camera sees the board's printed face, so the grid found is the board turned by 0°, 90°,
//! 180° or 270° in the image (never mirrored). The detector keeps the turns whose grid shape
//! matches `inner_columns × inner_rows` (rows of the board run along the grid's side with
//! `inner_columns` corners: only 0°/180° when `inner_columns != inner_rows`), then:
//!
//! 1. **colour**: the squares must have the board's colours — the square between corners
//!    `(c, r)` and `(c + 1, r + 1)` dark when `c + r` is even, i.e. the square diagonally
//!    outside corner (0, 0) dark ([`Checkerboard::square_is_dark`]). This settles 0° against
//!    180° whenever `inner_columns + inner_rows` is odd (the default 9 × 6 board: any pose);
//! 2. **image orientation**, among the turns the colours cannot tell apart (boards with
//!    `inner_columns + inner_rows` even): the one whose rows run most nearly along the image's
//!    `+x` (left to right).
//!
//! Use a board with `inner_columns + inner_rows` odd for calibration: with it, the order never
//! depends on how the board is held.

use std::collections::{HashMap, VecDeque};
use std::fmt;

use nalgebra::{Matrix2, Point2, Vector2};

use crate::board::Checkerboard;

mod junction;

/// Why no corners were returned.
#[derive(Clone, Debug, PartialEq)]
pub enum CornerError {
    /// The board definition breaks a rule (the key and the rule).
    InvalidBoard {
        /// The board's field.
        key: &'static str,
        /// The rule it breaks.
        rule: &'static str,
    },
    /// `pixels.len()` is not `width · height`.
    ImageSize {
        /// Width given.
        width: usize,
        /// Height given.
        height: usize,
        /// Values given.
        len: usize,
    },
    /// The image is too small to hold a board.
    ImageTooSmall {
        /// Width.
        width: usize,
        /// Height.
        height: usize,
    },
    /// A pixel is NaN or infinite.
    NonFinite {
        /// Column.
        x: usize,
        /// Row.
        y: usize,
    },
    /// Every pixel has (nearly) the same value.
    NoContrast,
    /// No complete grid of the board's corners was found.
    BoardNotFound {
        /// Corner candidates (X-junctions) found in the image.
        candidates: usize,
        /// The largest grid grown from them, `(a, b)` corners along its two directions (0 × 0 if
        /// none).
        grid: (usize, usize),
        /// The board's `(inner_columns, inner_rows)`.
        expected: (u32, u32),
        /// Whether that grid runs into the image border (the board partly out of view).
        at_border: bool,
    },
    /// A corner's sub-pixel refinement did not converge near where it was detected.
    Refinement {
        /// Board column of the corner.
        column: u32,
        /// Board row of the corner.
        row: u32,
        /// Where it was detected, pixels.
        x: f64,
        /// Where it was detected, pixels.
        y: f64,
    },
}

impl fmt::Display for CornerError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CornerError::InvalidBoard { key, rule } => write!(f, "invalid board: {key}: {rule}"),
            CornerError::ImageSize { width, height, len } => write!(
                f,
                "image of {width} x {height} pixels needs {} values, got {len}",
                width.saturating_mul(*height)
            ),
            CornerError::ImageTooSmall { width, height } => write!(
                f,
                "image of {width} x {height} pixels is too small to find a board in (at least {MIN_SIDE} x {MIN_SIDE})"
            ),
            CornerError::NonFinite { x, y } => {
                write!(f, "pixel ({x}, {y}) is not a finite number")
            }
            CornerError::NoContrast => {
                write!(f, "board not found: the image has no contrast (all pixels alike)")
            }
            CornerError::BoardNotFound {
                candidates,
                grid,
                expected,
                at_border,
            } => {
                write!(
                    f,
                    "board not found: found {candidates} corner candidates, the largest grid of them is {} x {}, expected {} x {} inner corners",
                    grid.0, grid.1, expected.0, expected.1
                )?;
                if *at_border {
                    write!(f, "; that grid runs into the image border: is the board partly out of view?")?;
                }
                Ok(())
            }
            CornerError::Refinement { column, row, x, y } => write!(
                f,
                "corner ({column}, {row}) detected at ({x:.1}, {y:.1}) px: its sub-pixel refinement did not converge (blurred, occluded or too close to the border?)"
            ),
        }
    }
}

impl std::error::Error for CornerError {}

/// Smallest image side searched, pixels.
const MIN_SIDE: usize = 16;
/// ChESS ring radii tried, in order.
const RADII: [f64; 3] = [5.0, 3.0, 8.0];
/// Smoothing of the image whose gradients refine the corners, px (see [`refine`]).
const REFINE_SMOOTHING_PX: f64 = 1.5;
/// Seeds tried per radius.
const MAX_SEEDS: usize = 40;
/// Accepting a lattice neighbour: distance to its prediction, fraction of the step.
const GROW_TOLERANCE: f64 = 0.3;

/// The board's inner corners in a camera image (row-major `pixels`, any scale, e.g. the
/// white-frame capture), sub-pixel, camera pixel convention of SPEC §1 (pixel centres at
/// integer coordinates), in the order of [`Checkerboard::corners_mm`]. The orientation rule is
/// in the [module documentation](self).
pub fn detect(
    pixels: &[f32],
    width: usize,
    height: usize,
    board: &Checkerboard,
) -> Result<Vec<Point2<f64>>, CornerError> {
    board
        .validate()
        .map_err(|(key, rule)| CornerError::InvalidBoard { key, rule })?;
    if width.checked_mul(height) != Some(pixels.len()) {
        return Err(CornerError::ImageSize {
            width,
            height,
            len: pixels.len(),
        });
    }
    if width < MIN_SIDE || height < MIN_SIDE {
        return Err(CornerError::ImageTooSmall { width, height });
    }
    if let Some(i) = pixels.iter().position(|v| !v.is_finite()) {
        return Err(CornerError::NonFinite {
            x: i % width,
            y: i / width,
        });
    }
    let image = Image::normalised(pixels, width, height)?;
    let smooth = image.binomial();
    let mut best_error: Option<CornerError> = None;
    for &radius in &RADII {
        if (width as f64) < 4.0 * radius + 4.0 || (height as f64) < 4.0 * radius + 4.0 {
            continue;
        }
        match detect_at_radius(&image, &smooth, board, radius) {
            Ok(corners) => return Ok(corners),
            Err(e) => {
                let better = match (&best_error, &e) {
                    (None, _) => true,
                    (
                        Some(CornerError::BoardNotFound { grid: a, .. }),
                        CornerError::BoardNotFound { grid: b, .. },
                    ) => b.0 * b.1 > a.0 * a.1,
                    (Some(CornerError::BoardNotFound { .. }), _) => true,
                    _ => false,
                };
                if better {
                    best_error = Some(e);
                }
            }
        }
    }
    Err(best_error.unwrap_or(CornerError::ImageTooSmall { width, height }))
}

/// A normalised grey image.
struct Image {
    w: usize,
    h: usize,
    v: Vec<f32>,
}

impl Image {
    /// Percentiles 2 and 98 → 0 and 1.
    fn normalised(pixels: &[f32], w: usize, h: usize) -> Result<Image, CornerError> {
        let step = (pixels.len() / 20_000).max(1);
        let mut sample: Vec<f32> = pixels.iter().step_by(step).copied().collect();
        sample.sort_by(f32::total_cmp);
        let at = |q: f64| sample[((sample.len() - 1) as f64 * q).round() as usize] as f64;
        let (lo, hi) = (at(0.02), at(0.98));
        let scale = hi - lo;
        if scale.is_nan() || scale <= 1e-9 * lo.abs().max(hi.abs()).max(1e-30) || !scale.is_finite()
        {
            return Err(CornerError::NoContrast);
        }
        let v = pixels
            .iter()
            .map(|&p| ((p as f64 - lo) / scale) as f32)
            .collect();
        Ok(Image { w, h, v })
    }

    fn at(&self, x: usize, y: usize) -> f32 {
        self.v[y * self.w + x]
    }

    /// Bilinear sample; `None` outside `[0, w−1] × [0, h−1]`.
    fn sample(&self, x: f64, y: f64) -> Option<f64> {
        if !(x >= 0.0 && y >= 0.0 && x <= (self.w - 1) as f64 && y <= (self.h - 1) as f64) {
            return None;
        }
        let x0 = (x.floor() as usize).min(self.w - 2);
        let y0 = (y.floor() as usize).min(self.h - 2);
        let fx = x - x0 as f64;
        let fy = y - y0 as f64;
        let a = self.at(x0, y0) as f64;
        let b = self.at(x0 + 1, y0) as f64;
        let c = self.at(x0, y0 + 1) as f64;
        let d = self.at(x0 + 1, y0 + 1) as f64;
        Some(a + (b - a) * fx + (c - a) * fy + (a - b - c + d) * fx * fy)
    }

    /// Separable Gaussian smoothing of std `sigma` px (borders clamped).
    fn gaussian(&self, sigma: f64) -> Image {
        let (w, h) = (self.w, self.h);
        let reach = (3.0 * sigma).ceil() as i64;
        let kernel: Vec<f64> = (-reach..=reach)
            .map(|d| (-(d * d) as f64 / (2.0 * sigma * sigma)).exp())
            .collect();
        let total: f64 = kernel.iter().sum();
        let kernel: Vec<f32> = kernel.iter().map(|k| (k / total) as f32).collect();
        let clamp = |v: i64, n: usize| v.clamp(0, n as i64 - 1) as usize;
        let mut tmp = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut s = 0.0;
                for (k, &kv) in kernel.iter().enumerate() {
                    s += kv * self.at(clamp(x as i64 + k as i64 - reach, w), y);
                }
                tmp[y * w + x] = s;
            }
        }
        let mut out = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut s = 0.0;
                for (k, &kv) in kernel.iter().enumerate() {
                    s += kv * tmp[clamp(y as i64 + k as i64 - reach, h) * w + x];
                }
                out[y * w + x] = s;
            }
        }
        Image { w, h, v: out }
    }

    /// 3 × 3 binomial smoothing (borders copied).
    fn binomial(&self) -> Image {
        let (w, h) = (self.w, self.h);
        let mut tmp = self.v.clone();
        for y in 0..h {
            for x in 1..w - 1 {
                tmp[y * w + x] =
                    0.25 * self.at(x - 1, y) + 0.5 * self.at(x, y) + 0.25 * self.at(x + 1, y);
            }
        }
        let mut out = tmp.clone();
        for y in 1..h - 1 {
            for x in 0..w {
                out[y * w + x] = 0.25 * tmp[(y - 1) * w + x]
                    + 0.5 * tmp[y * w + x]
                    + 0.25 * tmp[(y + 1) * w + x];
            }
        }
        Image { w, h, v: out }
    }
}

/// A corner candidate: position (pixel, with a parabolic sub-pixel offset of the response) and
/// ChESS response.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    p: Point2<f64>,
    response: f64,
}

fn detect_at_radius(
    image: &Image,
    smooth: &Image,
    board: &Checkerboard,
    radius: f64,
) -> Result<Vec<Point2<f64>>, CornerError> {
    let expected = (board.inner_columns, board.inner_rows);
    let candidates = candidates(smooth, radius, board.corner_count());
    let not_found = |grid: (usize, usize), at_border: bool| CornerError::BoardNotFound {
        candidates: candidates.len(),
        grid,
        expected,
        at_border,
    };
    // Grow a lattice from the strongest seeds until one holds the board.
    let mut order: Vec<usize> = (0..candidates.len()).collect();
    order.sort_by(|&a, &b| candidates[b].response.total_cmp(&candidates[a].response));
    let mut largest: Option<Lattice> = None;
    let mut tried: Vec<bool> = vec![false; candidates.len()];
    for &seed in order.iter().take(MAX_SEEDS) {
        if tried[seed] {
            continue;
        }
        let Some(lattice) = grow(&candidates, seed) else {
            continue;
        };
        for &c in lattice.cells.values() {
            tried[c] = true;
        }
        // A complete board has exactly its corners; otherwise keep the largest lattice for the
        // error message.
        let block = (lattice.cells.len() == board.corner_count())
            .then(|| board_block(&lattice, &candidates, board))
            .flatten();
        if let Some(grid) = block {
            let ordered = orient(image, &candidates, &grid, board);
            return refine_all(image, &candidates, &ordered, board);
        }
        if largest
            .as_ref()
            .is_none_or(|l| lattice.cells.len() > l.cells.len())
        {
            largest = Some(lattice);
        }
    }
    match largest {
        None => Err(not_found((0, 0), false)),
        Some(l) => {
            let (na, nb) = l.extent();
            Err(not_found((na, nb), l.at_border(&candidates, image, radius)))
        }
    }
}

/// ChESS response, non-maximum suppression, threshold; the strongest `4·count + 100` at most.
fn candidates(image: &Image, radius: f64, count: usize) -> Vec<Candidate> {
    let (w, h) = (image.w, image.h);
    let margin = radius.ceil() as usize + 2;
    let ring: Vec<(f64, f64)> = (0..16)
        .map(|k| {
            let a = std::f64::consts::PI * k as f64 / 8.0;
            (radius * a.cos(), radius * a.sin())
        })
        .collect();
    let mut response = vec![f32::MIN; w * h];
    let mut max = 0.0f32;
    for y in margin..h - margin {
        for x in margin..w - margin {
            let mut s = [0.0f64; 16];
            for (k, &(dx, dy)) in ring.iter().enumerate() {
                s[k] = image
                    .sample(x as f64 + dx, y as f64 + dy)
                    .unwrap_or_default();
            }
            let mut sum_response = 0.0;
            for k in 0..4 {
                sum_response += ((s[k] + s[k + 8]) - (s[k + 4] + s[k + 12])).abs();
            }
            let mut diff_response = 0.0;
            for k in 0..8 {
                diff_response += (s[k] - s[k + 8]).abs();
            }
            let ring_mean = s.iter().sum::<f64>() / 16.0;
            let mut local = 0.0;
            for yy in y - 1..=y + 1 {
                for xx in x - 1..=x + 1 {
                    local += image.at(xx, yy) as f64;
                }
            }
            local /= 9.0;
            let r = (sum_response - diff_response - 16.0 * (ring_mean - local).abs()) as f32;
            response[y * w + x] = r;
            max = max.max(r);
        }
    }
    let threshold = (0.15 * max).max(0.3);
    let nms = (radius.round() as usize).clamp(2, 4);
    let mut out = Vec::new();
    for y in margin..h - margin {
        for x in margin..w - margin {
            let r = response[y * w + x];
            if r < threshold {
                continue;
            }
            let mut is_max = true;
            'window: for yy in y.saturating_sub(nms)..=(y + nms).min(h - 1) {
                for xx in x.saturating_sub(nms)..=(x + nms).min(w - 1) {
                    let q = response[yy * w + xx];
                    // Ties go to the first pixel in raster order.
                    if q > r || (q == r && (yy, xx) < (y, x)) {
                        is_max = false;
                        break 'window;
                    }
                }
            }
            if !is_max {
                continue;
            }
            let parabolic = |a: f32, b: f32, c: f32| {
                let d = a - 2.0 * b + c;
                if d < 0.0 {
                    (0.5 * (a - c) / d).clamp(-0.5, 0.5) as f64
                } else {
                    0.0
                }
            };
            let dx = parabolic(response[y * w + x - 1], r, response[y * w + x + 1]);
            let dy = parabolic(response[(y - 1) * w + x], r, response[(y + 1) * w + x]);
            out.push(Candidate {
                p: Point2::new(x as f64 + dx, y as f64 + dy),
                response: r as f64,
            });
        }
    }
    out.sort_by(|a, b| b.response.total_cmp(&a.response));
    out.truncate(4 * count + 100);
    out
}

/// A grown lattice: cell `(a, b)` → candidate, right-handed in the image (`a` along `u`, `b`
/// along `v`, `u × v > 0` with `y` down).
struct Lattice {
    cells: HashMap<(i32, i32), usize>,
}

impl Lattice {
    fn bounds(&self) -> (i32, i32, i32, i32) {
        let mut b = (i32::MAX, i32::MIN, i32::MAX, i32::MIN);
        for &(a, c) in self.cells.keys() {
            b = (b.0.min(a), b.1.max(a), b.2.min(c), b.3.max(c));
        }
        b
    }

    fn extent(&self) -> (usize, usize) {
        let (a0, a1, b0, b1) = self.bounds();
        ((a1 - a0 + 1) as usize, (b1 - b0 + 1) as usize)
    }

    /// Whether the lattice continues past the image border: a cell whose next neighbour
    /// (extrapolated) falls where no candidate can be found.
    fn at_border(&self, cands: &[Candidate], image: &Image, radius: f64) -> bool {
        let limit = radius + 2.0;
        for (&(a, b), &c) in &self.cells {
            for (da, db) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                if self.cells.contains_key(&(a + da, b + db)) {
                    continue;
                }
                let Some(&back) = self.cells.get(&(a - da, b - db)) else {
                    continue;
                };
                let p = cands[c].p + (cands[c].p - cands[back].p);
                if p.x < limit
                    || p.y < limit
                    || p.x > image.w as f64 - 1.0 - limit
                    || p.y > image.h as f64 - 1.0 - limit
                {
                    return true;
                }
            }
        }
        false
    }
}

fn nearest(cands: &[Candidate], p: Point2<f64>, skip: usize) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for (i, c) in cands.iter().enumerate() {
        if i == skip {
            continue;
        }
        let d = (c.p - p).norm();
        if best.is_none_or(|(_, bd)| d < bd) {
            best = Some((i, d));
        }
    }
    best
}

fn cross(a: &Vector2<f64>, b: &Vector2<f64>) -> f64 {
    a.x * b.y - a.y * b.x
}

/// The lattice grown from `seed`, or `None` when the seed has no four lattice neighbours.
fn grow(cands: &[Candidate], seed: usize) -> Option<Lattice> {
    let s = cands[seed].p;
    let (n1, d1) = nearest(cands, s, seed)?;
    if d1.is_nan() || d1 <= 2.0 {
        return None;
    }
    let u = cands[n1].p - s;
    // v: the nearest candidate well off the u direction, within 2 steps.
    let mut v: Option<(Vector2<f64>, f64)> = None;
    for (i, c) in cands.iter().enumerate() {
        if i == seed {
            continue;
        }
        let d = c.p - s;
        let n = d.norm();
        if n > 2.0 * d1 || n < 0.5 * d1 {
            continue;
        }
        if cross(&u, &d).abs() / (n * d1) < 0.57 {
            continue; // within 35° of ±u
        }
        if v.is_none_or(|(_, bn)| n < bn) {
            v = Some((d, n));
        }
    }
    let (mut v, _) = v?;
    if cross(&u, &v) < 0.0 {
        v = -v;
    }
    let mut cells: HashMap<(i32, i32), usize> = HashMap::new();
    let mut owner: HashMap<usize, (i32, i32)> = HashMap::new();
    cells.insert((0, 0), seed);
    owner.insert(seed, (0, 0));
    // The seed's four neighbours must all be there.
    for (da, db) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
        let step = u * da as f64 + v * db as f64;
        let (i, d) = nearest(cands, s + step, seed)?;
        if d > GROW_TOLERANCE * step.norm() || owner.contains_key(&i) {
            return None;
        }
        cells.insert((da, db), i);
        owner.insert(i, (da, db));
    }
    let mut queue: VecDeque<(i32, i32)> = [(1, 0), (-1, 0), (0, 1), (0, -1)].into();
    let max_cells = cands.len();
    while let Some((a, b)) = queue.pop_front() {
        let p = cands[cells[&(a, b)]].p;
        for (da, db) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let t = (a + da, b + db);
            if cells.contains_key(&t) {
                continue;
            }
            let pos = |k: (i32, i32)| cells.get(&k).map(|&i| cands[i].p);
            let step = if let Some(back) = pos((a - da, b - db)) {
                p - back
            } else {
                let (pa, pb) = (db, da); // perpendicular offsets
                let side = [(pa, pb), (-pa, -pb)].into_iter().find_map(|(oa, ob)| {
                    Some(pos((a + da + oa, b + db + ob))? - pos((a + oa, b + ob))?)
                });
                side.unwrap_or(u * da as f64 + v * db as f64)
            };
            let pred = p + step;
            let Some((i, d)) = nearest(cands, pred, usize::MAX) else {
                continue;
            };
            if d > GROW_TOLERANCE * step.norm() || owner.contains_key(&i) {
                continue;
            }
            cells.insert(t, i);
            owner.insert(i, t);
            queue.push_back(t);
            if cells.len() >= max_cells {
                break;
            }
        }
    }
    Some(Lattice { cells })
}

/// The lattice as the board's block: `grid[b·na + a]` candidates, `na × nb` =
/// `(inner_columns, inner_rows)` or the transpose, every cell present.
struct Block {
    na: usize,
    nb: usize,
    grid: Vec<usize>,
}

fn board_block(lattice: &Lattice, cands: &[Candidate], board: &Checkerboard) -> Option<Block> {
    let (a0, a1, b0, b1) = lattice.bounds();
    let (c, r) = (board.inner_columns as usize, board.inner_rows as usize);
    let mut best: Option<(f64, Block)> = None;
    for (na, nb) in [(c, r), (r, c)] {
        // The grid must be the board, not more: a larger grid is another board (or the wrong
        // target definition), never a part to pick from.
        let (ea, eb) = ((a1 - a0 + 1) as usize, (b1 - b0 + 1) as usize);
        if na != ea || nb != eb {
            continue;
        }
        for sa in a0..=a1 - na as i32 + 1 {
            for sb in b0..=b1 - nb as i32 + 1 {
                let mut grid = Vec::with_capacity(na * nb);
                let mut total = 0.0;
                'fill: for b in 0..nb as i32 {
                    for a in 0..na as i32 {
                        match lattice.cells.get(&(sa + a, sb + b)) {
                            Some(&i) => {
                                grid.push(i);
                                total += cands[i].response;
                            }
                            None => break 'fill,
                        }
                    }
                }
                if grid.len() == na * nb && best.as_ref().is_none_or(|(t, _)| total > *t) {
                    best = Some((total, Block { na, nb, grid }));
                }
            }
        }
    }
    best.map(|(_, b)| b)
}

/// The block's candidates in board order (row-major), by the orientation rule of the module
/// documentation.
fn orient(image: &Image, cands: &[Candidate], block: &Block, board: &Checkerboard) -> Vec<usize> {
    let (c, r) = (board.inner_columns as usize, board.inner_rows as usize);
    let (na, nb) = (block.na, block.nb);
    let at = |a: usize, b: usize| block.grid[b * na + a];
    // Each turn maps board (column, row) to block (a, b).
    type Turn = fn(usize, usize, usize, usize) -> (usize, usize);
    let turns: [(bool, Turn); 4] = [
        (false, |col, row, _, _| (col, row)),
        (false, |col, row, na, nb| (na - 1 - col, nb - 1 - row)),
        (true, |col, row, na, _| (na - 1 - row, col)),
        (true, |col, row, _, nb| (row, nb - 1 - col)),
    ];
    let mut options: Vec<(f64, f64, Vec<usize>)> = Vec::new();
    for (transposed, turn) in turns {
        if (!transposed && (na, nb) != (c, r)) || (transposed && (na, nb) != (r, c)) {
            continue;
        }
        let order: Vec<usize> = (0..r)
            .flat_map(|row| (0..c).map(move |col| (col, row)))
            .map(|(col, row)| {
                let (a, b) = turn(col, row, na, nb);
                at(a, b)
            })
            .collect();
        let p = |col: usize, row: usize| cands[order[row * c + col]].p;
        // Colour: light squares minus dark squares, over the interior squares.
        let mut score = 0.0;
        for row in 0..r - 1 {
            for col in 0..c - 1 {
                let centre = Point2::from(
                    (p(col, row).coords
                        + p(col + 1, row).coords
                        + p(col, row + 1).coords
                        + p(col + 1, row + 1).coords)
                        / 4.0,
                );
                let v = image.sample(centre.x, centre.y).unwrap_or(0.5) - 0.5;
                if Checkerboard::square_is_dark(col as i64, row as i64) {
                    score -= v;
                } else {
                    score += v;
                }
            }
        }
        // Image orientation: how nearly the rows run along +x.
        let mut along = Vector2::zeros();
        for row in 0..r {
            along += p(c - 1, row) - p(0, row);
        }
        let along_x = along.x / along.norm().max(1e-12);
        options.push((score, along_x, order));
    }
    let best_score = options
        .iter()
        .map(|o| o.0)
        .fold(f64::NEG_INFINITY, f64::max);
    let tolerance = 1e-6 * (c * r) as f64;
    options
        .into_iter()
        .filter(|o| o.0 >= best_score - tolerance)
        .max_by(|x, y| x.1.total_cmp(&y.1))
        .map(|o| o.2)
        .expect("a block of the board's shape has at least one turn")
}

/// Refines every corner (in board order) to sub-pixel.
fn refine_all(
    image: &Image,
    cands: &[Candidate],
    order: &[usize],
    board: &Checkerboard,
) -> Result<Vec<Point2<f64>>, CornerError> {
    let c = board.inner_columns as usize;
    let r = board.inner_rows as usize;
    let smooth = image.gaussian(REFINE_SMOOTHING_PX);
    let grad = Gradient::of(&smooth);
    let at = |col: i64, row: i64| -> Option<Point2<f64>> {
        (col >= 0 && row >= 0 && (col as usize) < c && (row as usize) < r)
            .then(|| cands[order[row as usize * c + col as usize]].p)
    };
    // The lattice step at a corner along (dc, dr): forwards if there is a next corner, else
    // backwards.
    let step = |col: i64, row: i64, dc: i64, dr: i64| -> Vector2<f64> {
        let p = at(col, row).expect("inside the board");
        match at(col + dc, row + dr) {
            Some(q) => q - p,
            None => p - at(col - dc, row - dr).expect("a board has at least 2 x 2 corners"),
        }
    };
    // Pass 1: `cornerSubPix`, then the junction fit with straight edges.
    let mut first = Vec::with_capacity(order.len());
    for row in 0..r as i64 {
        for col in 0..c as i64 {
            let p = at(col, row).expect("inside the board");
            let u = step(col, row, 1, 0);
            let v = step(col, row, 0, 1);
            // The window: 3/4 of the shorter step (no other corner's edges weigh in).
            let radius = (0.75 * u.norm().min(v.norm())).clamp(4.0, 24.0);
            // Near the image border, a smaller window that stays inside (gradients exist from
            // the second pixel to the last but one).
            let room = (p.x - 2.0)
                .min(p.y - 2.0)
                .min(image.w as f64 - 3.0 - p.x)
                .min(image.h as f64 - 3.0 - p.y);
            let radius = radius.min(room);
            let fail = CornerError::Refinement {
                column: col as u32,
                row: row as u32,
                x: p.x,
                y: p.y,
            };
            if radius < 3.0 {
                return Err(fail);
            }
            let shading = Shading::around(image, p, u, v);
            let q = refine(&grad, &smooth, p, radius, shading.as_ref()).ok_or(fail)?;
            let straight = [Vector2::zeros(); 2];
            let q = junction::fit(image, q, u, v, straight).unwrap_or(q);
            first.push((q, u, v));
        }
    }
    // Pass 2: the same fit with each edge bent as its whole grid line is.
    let mut bend = vec![[Vector2::zeros(); 2]; first.len()];
    for row in 0..r {
        let line: Vec<Point2<f64>> = (0..c).map(|col| first[row * c + col].0).collect();
        for (col, b) in junction::bends(&line).into_iter().enumerate() {
            bend[row * c + col][0] = b;
        }
    }
    for col in 0..c {
        let line: Vec<Point2<f64>> = (0..r).map(|row| first[row * c + col].0).collect();
        for (row, b) in junction::bends(&line).into_iter().enumerate() {
            bend[row * c + col][1] = b;
        }
    }
    Ok(first
        .iter()
        .zip(&bend)
        .map(|((q, u, v), b)| junction::fit(image, *q, *u, *v, *b).unwrap_or(*q))
        .collect())
}

/// The shading around a corner: how the light and the dark squares' levels change across it
/// (the illumination is never uniform: the projector's fall-off, vignetting). Left in, its
/// gradient adds to the edges' and pulls `cornerSubPix` off the corner by ~20 px per unit of
/// relative gradient (0.07 px for 0.3%/px); [`refine`] subtracts it.
#[derive(Clone, Copy, Debug)]
struct Shading {
    light: f64,
    dark: f64,
    grad_light: Vector2<f64>,
    grad_dark: Vector2<f64>,
}

impl Shading {
    /// From the four squares around the corner at `c` (lattice steps `u`, `v`): each square's
    /// level at its centre and its gradient from 3 × 3-averaged samples a quarter step either
    /// side of the centre (well inside the square).
    fn around(image: &Image, c: Point2<f64>, u: Vector2<f64>, v: Vector2<f64>) -> Option<Shading> {
        let box3 = |p: Point2<f64>| -> Option<f64> {
            let mut s = 0.0;
            for dy in [-1.0, 0.0, 1.0] {
                for dx in [-1.0, 0.0, 1.0] {
                    s += image.sample(p.x + dx, p.y + dy)?;
                }
            }
            Some(s / 9.0)
        };
        let m = Matrix2::new(0.5 * u.x, 0.5 * u.y, 0.5 * v.x, 0.5 * v.y);
        let m_inv = m.try_inverse()?;
        let mut squares = Vec::with_capacity(4);
        for (su, sv) in [(1.0, 1.0), (-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0)] {
            let centre = c + 0.5 * (su * u + sv * v);
            let level = box3(centre)?;
            let du = box3(centre + 0.25 * u)? - box3(centre - 0.25 * u)?;
            let dv = box3(centre + 0.25 * v)? - box3(centre - 0.25 * v)?;
            squares.push((level, m_inv * Vector2::new(du, dv)));
        }
        // The diagonal pairs: (+,+) & (−,−), and (+,−) & (−,+).
        let a = (squares[0].0 + squares[1].0) / 2.0;
        let b = (squares[2].0 + squares[3].0) / 2.0;
        let ga = (squares[0].1 + squares[1].1) / 2.0;
        let gb = (squares[2].1 + squares[3].1) / 2.0;
        let (light, dark, grad_light, grad_dark) = if a >= b {
            (a, b, ga, gb)
        } else {
            (b, a, gb, ga)
        };
        (light - dark > 0.05).then_some(Shading {
            light,
            dark,
            grad_light,
            grad_dark,
        })
    }

    /// The shading's part of the gradient at a pixel of smoothed level `level`.
    fn gradient(&self, level: f64) -> Vector2<f64> {
        let alpha = ((level - self.dark) / (self.light - self.dark)).clamp(0.0, 1.0);
        self.grad_light * alpha + self.grad_dark * (1.0 - alpha)
    }
}

/// Central-difference gradients of an image.
struct Gradient {
    w: usize,
    h: usize,
    gx: Vec<f32>,
    gy: Vec<f32>,
}

impl Gradient {
    fn of(image: &Image) -> Gradient {
        let (w, h) = (image.w, image.h);
        let mut gx = vec![0.0f32; w * h];
        let mut gy = vec![0.0f32; w * h];
        for y in 1..h - 1 {
            for x in 1..w - 1 {
                gx[y * w + x] = 0.5 * (image.at(x + 1, y) - image.at(x - 1, y));
                gy[y * w + x] = 0.5 * (image.at(x, y + 1) - image.at(x, y - 1));
            }
        }
        Gradient { w, h, gx, gy }
    }
}

/// `cornerSubPix`: `q = (Σ w·g·gᵀ)⁻¹ Σ w·g·gᵀ·p` over the pixels `p` within `radius` px of
/// the estimate `q`, weighted by the smooth bump `w = (1 − |p − q|²/radius²)³`, iterated; `None`
/// when the window leaves the image, the system is singular or the corner wanders more than a
/// third of the window.
///
/// Why it is unbiased: an X-junction is point-symmetric about its centre `c`, so the terms at
/// `c ± d` cancel and `c` is the fixed point of the integral. The sums over whole pixels equal
/// that integral wherever `c` lies between pixels only if what is summed is smooth: the
/// gradients are those of the image smoothed by a Gaussian of 1.5 px (a symmetric kernel does
/// not move the centre), and the window falls smoothly to 0 at its rim (a hard cut, or
/// interpolating the gradients at points centred on `q`, biases the result by up to 0.1 px).
fn refine(
    grad: &Gradient,
    smooth: &Image,
    start: Point2<f64>,
    radius: f64,
    shading: Option<&Shading>,
) -> Option<Point2<f64>> {
    let reach = radius.ceil() as i64;
    let inv = 1.0 / (radius * radius);
    let mut q = start;
    for _ in 0..50 {
        let (cx, cy) = (q.x.round() as i64, q.y.round() as i64);
        if cx - reach < 1
            || cy - reach < 1
            || cx + reach > grad.w as i64 - 2
            || cy + reach > grad.h as i64 - 2
        {
            return None;
        }
        let mut a = Matrix2::zeros();
        let mut b = Vector2::zeros();
        for y in cy - reach..=cy + reach {
            for x in cx - reach..=cx + reach {
                let p = Vector2::new(x as f64, y as f64);
                let t = 1.0 - (p - q.coords).norm_squared() * inv;
                if t <= 0.0 {
                    continue;
                }
                let wgt = t * t * t;
                let i = y as usize * grad.w + x as usize;
                let mut g = Vector2::new(grad.gx[i] as f64, grad.gy[i] as f64);
                if let Some(shading) = shading {
                    g -= shading.gradient(smooth.v[i] as f64);
                }
                let ggt = g * g.transpose() * wgt;
                a += ggt;
                b += ggt * p;
            }
        }
        let det = a.determinant();
        if det.is_nan() || det.abs() <= 1e-9 * (a.trace() * a.trace()).max(1e-300) {
            return None;
        }
        let next = Point2::from(a.try_inverse()? * b);
        if !(next.x.is_finite() && next.y.is_finite()) || (next - start).norm() > radius / 3.0 + 1.0
        {
            return None;
        }
        let moved = (next - q).norm();
        q = next;
        if moved < 1e-4 {
            break;
        }
    }
    Some(q)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An X-junction of two lines through `c` at angles `t1`, `t2` (dark 0.05, light 0.85), each
    /// pixel integrated with 16 × 16 samples, lit with a relative gradient `gain` per px along x.
    fn junction(c: Point2<f64>, t1: f64, t2: f64, gain: f64) -> Vec<f32> {
        bent_junction(c, t1, t2, gain, 0.0, 16)
    }

    /// [`junction`] with both edges bent by `kappa` px⁻¹ (`d = n·r − κ/2 (t·r)²`), each pixel
    /// integrated with `n × n` samples.
    pub(super) fn bent_junction(
        c: Point2<f64>,
        t1: f64,
        t2: f64,
        gain: f64,
        kappa: f64,
        n: usize,
    ) -> Vec<f32> {
        let (w, h) = (64, 64);
        let (a, b) = (
            Vector2::new(-t1.sin(), t1.cos()),
            Vector2::new(-t2.sin(), t2.cos()),
        );
        let (ta, tb) = (
            Vector2::new(t1.cos(), t1.sin()),
            Vector2::new(t2.cos(), t2.sin()),
        );
        let mut out = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let mut s = 0.0;
                for i in 0..n {
                    for j in 0..n {
                        let p = Vector2::new(
                            x as f64 + (i as f64 + 0.5) / n as f64 - 0.5 - c.x,
                            y as f64 + (j as f64 + 0.5) / n as f64 - 0.5 - c.y,
                        );
                        let da = a.dot(&p) - 0.5 * kappa * ta.dot(&p).powi(2);
                        let db = b.dot(&p) - 0.5 * kappa * tb.dot(&p).powi(2);
                        if (da > 0.0) == (db > 0.0) {
                            s += 1.0;
                        }
                    }
                }
                let albedo = 0.05 + 0.8 * s / (n * n) as f64;
                out[y * w + x] = (albedo * (1.0 + gain * (x as f64 - c.x))) as f32;
            }
        }
        out
    }

    /// An X-junction at `c` whose edges run along the pixel grid (a board parallel to the image,
    /// not rolled), each pixel's light its exact area share of each colour (no ray counting),
    /// lit with a relative gradient `gain` per px along x.
    fn aligned_junction(c: Point2<f64>, gain: f64) -> Vec<f32> {
        let (w, h) = (64, 64);
        let share = |p: f64, e: f64| (p + 0.5 - e).clamp(0.0, 1.0); // of the pixel past the edge
        let mut out = vec![0.0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let (sx, sy) = (share(x as f64, c.x), share(y as f64, c.y));
                let light = sx * sy + (1.0 - sx) * (1.0 - sy);
                let albedo = 0.05 + 0.8 * light;
                out[y * w + x] = (albedo * (1.0 + gain * (x as f64 - c.x))) as f32;
            }
        }
        out
    }

    /// The refinement on junctions aligned with the pixel grid, exactly integrated, over 8 × 8
    /// sub-pixel phases: the detector's own pixel-phase bias. With every point of the edges at
    /// the same phase φ the refinement is off by about A · sin 2πφ per axis (towards the pixel
    /// border). Measured A: 0.017 px with a 6 px window, 0.010 px with 12 px, 0.0096 px with
    /// 18 px (with the shading gradient 0.003/px: 0.026, 0.014, 0.012). It falls roughly as
    /// 1/σ² of the smoothing (σ = 2 px: 0.0067 px at 12 px, phase ¼), as aliasing of the box
    /// footprint's samples would (its spectrum has only a simple zero at 1 cycle/px, and
    /// smoothing the samples cannot remove what is already aliased); but σ = 2 px raises the
    /// rolled junctions' error of the next test (RMS 0.016 → 0.027 px, worst 0.05 → 0.10 px).
    /// On rolled or tilted boards the edges cross every phase and the bias averages out; on a
    /// fronto-parallel board with 18 px windows it is ≤ 0.012 px, well under the steps a fixed
    /// ray grid in the renderer used to cause (the rays are now jittered per pixel:
    /// `tests/corners.rs`, `fronto_parallel_corners_at_the_default_rays`).
    #[test]
    fn refinement_pixel_phase_bias_on_aligned_junctions() {
        for (gain, limits) in [(0.0, [0.018, 0.011, 0.011]), (0.003, [0.027, 0.014, 0.012])] {
            let mut worst = [0.0f64; 3];
            for i in 0..8 {
                for j in 0..8 {
                    let c = Point2::new(31.0 + i as f64 / 8.0, 30.0 + j as f64 / 8.0);
                    let image = Image::normalised(&aligned_junction(c, gain), 64, 64).unwrap();
                    let smooth = image.gaussian(REFINE_SMOOTHING_PX);
                    let grad = Gradient::of(&smooth);
                    let (u, v) = (Vector2::new(24.0, 0.0), Vector2::new(0.0, 24.0));
                    let shading = Shading::around(&image, c, u, v);
                    for (k, radius) in [6.0, 12.0, 18.0].into_iter().enumerate() {
                        let start = Point2::new(31.0, 30.0);
                        let q = refine(&grad, &smooth, start, radius, shading.as_ref()).unwrap();
                        let e = q - c;
                        worst[k] = worst[k].max(e.x.abs()).max(e.y.abs());
                    }
                }
            }
            eprintln!(
                "aligned junctions, gain {gain}: worst error per axis {:.4} / {:.4} / {:.4} px with windows of 6 / 12 / 18 px",
                worst[0], worst[1], worst[2]
            );
            for k in 0..3 {
                assert!(worst[k] <= limits[k], "gain {gain}: {worst:?}");
            }
        }
    }

    /// The refinement on ideal junctions at any sub-pixel phase, any angle between the lines,
    /// under uniform and under graded light (the shading correction).
    #[test]
    fn refinement_finds_ideal_junctions_at_any_phase() {
        for (gain, max_rms, max_worst) in [(0.0, 0.02, 0.06), (0.003, 0.03, 0.09)] {
            let (mut worst, mut sum, mut k) = (0.0f64, 0.0, 0);
            for &(t1, t2) in &[(0.1, 1.6), (0.3, 1.5), (0.2, 1.1), (-0.4, 0.9), (0.05, 2.2)] {
                for &(ox, oy) in &[(0.0, 0.0), (0.3, 0.7), (0.5, 0.5), (0.81, 0.13)] {
                    let c = Point2::new(31.0 + ox, 30.0 + oy);
                    let image = Image::normalised(&junction(c, t1, t2, gain), 64, 64).unwrap();
                    let smooth = image.gaussian(REFINE_SMOOTHING_PX);
                    let grad = Gradient::of(&smooth);
                    let u = Vector2::new(t1.cos(), t1.sin()) * 16.0;
                    let v = Vector2::new(t2.cos(), t2.sin()) * 16.0;
                    let shading = Shading::around(&image, c, u, v);
                    assert!(shading.is_some());
                    for radius in [6.0, 10.0, 16.0] {
                        let start = Point2::new(31.0, 30.0);
                        let q = refine(&grad, &smooth, start, radius, shading.as_ref()).unwrap();
                        let e = (q - c).norm();
                        worst = worst.max(e);
                        sum += e * e;
                        k += 1;
                    }
                }
            }
            let rms = (sum / k as f64).sqrt();
            eprintln!("gain {gain}: RMS {rms:.4} px, worst {worst:.4} px");
            assert!(
                rms < max_rms && worst < max_worst,
                "gain {gain}: {rms} {worst}"
            );
        }
    }
}
