//! The lights of a pixel from its column profile (SPEC §2b): the inverse cosine transform
//! ([`crate::transform::cosine`]) gives the light `p_j` of every column `j = 0..=span` with
//! white noise of a known RMS `σ` ([`crate::noise::profile_noise_dn`]), so a light is read off
//! the profile directly, with no model of its spectrum:
//!
//! 1. **Runs.** A run is a stretch of adjacent columns above `noise_factor·σ`. A run whose
//!    feet (the adjacent columns above [`FOOT_LEVEL`]`·σ`) make it [`BACKGROUND_WINDOW`]
//!    columns long is read with them (hysteresis: a broad light's run is as long under EFSM's
//!    noise as under BFSM's, step 3), and takes in the runs its feet meet. Columns 0 and
//!    `span` are not read: column 0 carries the noise of the dark and white frames (and any
//!    error of the white level), and column `span` is never lit (BFSM: past the projector;
//!    EFSM: the next block's column 0).
//! 2. **Lights of a run.** Its significant maxima and minima alternate with swings of at least
//!    `noise_factor·σ` (so noise makes no maximum). A minimum below [`SPLIT_DEPTH`] of the
//!    lower of its two maxima separates two lights whose footprints touch; a shallower one
//!    leaves two lights that cannot be told apart: one mixed light, and the list is marked
//!    [`PeakList::unresolved`], unless the minimum is within [`RIPPLE_DEPTH`] of the maxima
//!    (the uneven top of one wide light). The columns between two touching lights are shared:
//!    first at the minimum, then in proportion to what each light sends there, read off its own far
//!    side as the mirror image about its centroid (a light is nearly symmetric, and its far
//!    side holds none of the other's light); two lights 3 columns apart are then both within
//!    0.1 column (`tests/cosine.rs`).
//! 3. **Narrow lights on a broad one.** Under glossy interreflection most columns of a run are
//!    lit by a lobe tens of columns wide, and the direct light is a narrow bump on it. A run of
//!    at least [`BACKGROUND_WINDOW`] columns is opened morphologically (the largest curve under
//!    the profile made of flat segments [`BACKGROUND_WINDOW`] wide, which no narrower light
//!    fits under); each maximum of what stands above the opening is a narrow light, measured
//!    above the straight line between its feet (where the profile bends most sharply upwards
//!    on either side of it: the narrow light's flanks meet the lobe there).
//!    The lobe is then no candidate: its column is ill defined, and its amplitude would
//!    outweigh the direct light's in the selection. Columns standing above an opening that
//!    stays below the threshold have no broad light under them: they are read as in 2 (a
//!    wide light whose feet make its run a window long). A run with no narrow light on it is
//!    one wide light (a pixel seeing a surface at a grazing angle covers many projector
//!    columns), read as in 2.
//! 4. **Each light** is the centroid of its columns, with a one-column margin beyond the ends
//!    of its run (a column at a split is shared half and half), each column weighing its light
//!    less [`WEIGHT_FLOOR`] noise RMS (never negative): a column of noise alone then weighs
//!    nothing 99.9% of the time, where its lever arm on the centroid would be largest, and every
//!    lit column loses the same small amount, which moves no centroid. Measured on synthetic
//!    lights (box footprints of 1–3 columns, blur σ 0.4–1, intensity ramps of ±50%, the noise of
//!    EFSM cB 64): 21% less scatter than the plain centroid, no bias. Its amplitude is the sum of
//!    its non-negative light, in sensor DN of fringe modulation (the unit of every search).
//!    An isolated light (the only maximum of its run) at least 0.8 column wide is then moved
//!    to where the profile correlates best with a bell of its own width (a centroid
//!    re-weighted by a window on the light, [`MATCHED_REACH`]): a matched filter, 16–32% less
//!    scatter than the floored centroid. A narrower light keeps its centroid (the window's
//!    sampling bias would exceed the noise it saves), and so does one the window would move
//!    by more than [`MATCHED_MAX_SHIFT`] (a light that is not a bell). Lights below
//!    `min_amplitude_dn` or `relative_floor` of the strongest are dropped; at most `max_peaks`
//!    are kept, strongest first.

use heapless::Vec;

use crate::math::{exp, ln};
use crate::peak::deconvolution::ColumnWeights;
use crate::peak::{Peak, PeakList};
use crate::plan::{ScanPlan, MAX_PEAKS};
use crate::transform::simd::Vector;
use crate::transform::Lanes;

/// A minimum below this fraction of the lower of its two maxima separates two lights.
pub const SPLIT_DEPTH: f32 = 0.25;

/// A minimum less than this fraction below the lower of its two maxima is a ripple on one
/// light, not a sign of two: a camera pixel that covers several projector columns sees a
/// footprint whose top is not flat (3-7% dips at 6 columns per pixel, `fsm demo --camera
/// 128x96`). Between this and [`SPLIT_DEPTH`], the two maxima are lights that cannot be told
/// apart.
pub const RIPPLE_DEPTH: f32 = 0.1;

/// A column's weight in a light's centroid is its light less this many noise RMS.
pub const WEIGHT_FLOOR: f32 = 3.0;

/// The feet of a run are the adjacent columns above this many noise RMS (step 1): the feet of
/// a glossy lobe under a direct light count in its run's length even where they are below the
/// threshold, so that the run is as long under EFSM's noise (3.5 times BFSM's with one group)
/// as under BFSM's and its lobe is found (step 3). Measured with `fsm simulate --camera
/// 400x300 --seed 5` and `fsm scan --truth`, `vgroove_glossy` EFSM two groups: 10.4% → 2.7%
/// of the points wrong, 51% → 84% of the directly lit pixels right; `vgroove` EFSM 0.23% →
/// 0.19% wrong; BFSM, and `sphere_mirror`, within a point.
pub const FOOT_LEVEL: f32 = 2.0;

/// Passes that share the columns between two touching lights by their mirror images.
const UNMIX_PASSES: usize = 2;

/// Width of the flat segments of the opening that models a broad light under narrow ones,
/// columns: wider than a direct light (a camera footprint of up to 6 projector columns and a
/// projector blur of up to 1 column), narrower than a glossy lobe.
pub const BACKGROUND_WINDOW: usize = 11;

/// Most significant extrema recorded in one run (a run holding more is read up to there).
const MAX_EXTREMA: usize = 4 * MAX_PEAKS + 1;

/// Floats of scratch [`find_lights`] needs for a span: the broad light of a run.
pub(crate) fn scratch_len(span: u16) -> usize {
    span as usize + 1
}

/// Most columns [`Search`] records as lit for a group of lanes; past it, each lane scans its
/// profile again.
const MAX_LIT: usize = 512;

/// The cosine search's working state, kept from pixel to pixel and row to row (setting it up
/// costs more than a pixel's search): the lit columns of a group of lanes, the lights of one
/// profile.
pub(crate) struct Search {
    /// Lit columns, ascending, with the lanes (bit `l`) lit there.
    lit: Vec<(u16, u32), MAX_LIT>,
    /// Whether every lit column is recorded.
    complete: bool,
    found: Found,
}

impl Search {
    pub(crate) const fn new() -> Self {
        Search {
            lit: Vec::new(),
            complete: true,
            found: Found {
                lights: Vec::new(),
                unresolved: false,
            },
        }
    }

    /// Finds the columns `1..span` of `profile` above `thresholds` in any lane, in one pass
    /// over the profiles for every lane (`L/W` chunks of the vector type `V`), so that each
    /// lane's search then reads only those columns. Most of a profile is dark: four columns at
    /// a time are checked with one mask ([`Vector::above_any`]), and only a quad with a lit
    /// column is read column by column (one compare and one mask per chunk and column).
    #[inline(always)]
    pub(crate) fn find_lit<const L: usize, const W: usize, V: Vector<W>>(
        &mut self,
        profile: &[Lanes<L>],
        thresholds: &[f32; L],
    ) {
        const { assert!(L <= 32, "a lane set is a u32") };
        self.lit.clear();
        self.complete = true;
        let span = profile.len().saturating_sub(1);
        let thresholds = thresholds.as_chunks::<W>().0;
        let chunk = |j: usize, c: usize| V::load(&profile[j].as_chunks::<W>().0[c]);
        let mut j = 1;
        while j < span {
            let end = (j + 4).min(span);
            if end - j == 4 {
                let mut any = 0u32;
                for (c, t) in thresholds.iter().enumerate() {
                    let quad = [
                        chunk(j, c),
                        chunk(j + 1, c),
                        chunk(j + 2, c),
                        chunk(j + 3, c),
                    ];
                    any |= V::above_any(quad, V::load(t));
                }
                if any == 0 {
                    j = end;
                    continue;
                }
            }
            for j in j..end {
                let mut lanes = 0u32;
                for (c, t) in thresholds.iter().enumerate() {
                    lanes |= chunk(j, c).above(V::load(t)) << (c * W);
                }
                if lanes != 0 && self.lit.push((j as u16, lanes)).is_err() {
                    self.complete = false;
                    return;
                }
            }
            j = end;
        }
    }
}

/// The lights of lane `lane` of `profile[0..=span]`, whose columns have noise RMS
/// `column_noise_dn`, written to `out`; `search` holds the lit columns of the profiles
/// ([`Search::find_lit`] with this lane's threshold, `noise_factor × column_noise_dn`).
/// `background` holds [`scratch_len`] floats.
/// Not inlined: this crate's copies serve its dependants (`decoder::cosine`'s `SHARED`).
#[inline(never)]
pub(crate) fn find_lights<const L: usize>(
    plan: &ScanPlan,
    profile: &[Lanes<L>],
    lane: usize,
    column_noise_dn: f32,
    search: &mut Search,
    background: &mut [f32],
    out: &mut PeakList,
) {
    out.peaks.clear();
    out.bin_noise = 0.0;
    out.unresolved = false;
    let span = profile.len().saturating_sub(1);
    let levels = Levels {
        noise: column_noise_dn,
        threshold: plan.decoding.noise_factor * column_noise_dn,
        floor: WEIGHT_FLOOR * column_noise_dn,
    };
    let threshold = levels.threshold;
    let value = |j: usize| profile[j][lane];
    let faint_level = FOOT_LEVEL * column_noise_dn;
    let faint = |j: usize| value(j) > faint_level;
    let found = &mut search.found;
    found.lights.clear();
    found.unresolved = false;
    let mut each_run = |run: Run| {
        if run.len() < BACKGROUND_WINDOW {
            lights_of_run(&value, &run, &levels, found);
        } else {
            broad_run(&value, &run, &levels, background, found);
        }
    };
    if search.complete {
        let mine = search
            .lit
            .iter()
            .filter(|(_, lanes)| lanes & (1 << lane) != 0)
            .map(|&(j, _)| j as usize);
        runs(mine, span, faint, &mut each_run);
    } else {
        runs(
            (1..span).filter(|&j| value(j) > threshold),
            span,
            faint,
            &mut each_run,
        );
    }
    out.unresolved = found.unresolved;
    keep_strongest(plan, &mut found.lights, out);
}

/// Groups ascending lit columns into runs of adjacent ones. A run whose feet (the adjacent
/// columns for which `faint` holds: hysteresis) make it at least [`BACKGROUND_WINDOW`]
/// columns long is handed on with them (a broad light, step 3), absorbing the runs its feet
/// meet; any other run is handed on as it is.
fn runs(
    mut columns: impl Iterator<Item = usize>,
    span: usize,
    faint: impl Fn(usize) -> bool,
    each: &mut impl FnMut(Run),
) {
    let Some(mut first) = columns.next() else {
        return;
    };
    let mut last = first;
    // A broad run still taking the runs its feet meet; the last column handed on.
    let mut broad: Option<Run> = None;
    let mut done = 0;
    let mut hand_on = |first: usize, last: usize, broad: &mut Option<Run>, done: &mut usize| {
        let (mut lo, mut hi) = (first, last);
        while lo > *done + 1 && faint(lo - 1) {
            lo -= 1;
        }
        while hi + 1 < span && faint(hi + 1) {
            hi += 1;
        }
        if let Some(b) = broad.take() {
            if lo <= b.last + 1 {
                *broad = Some(Run {
                    last: b.last.max(hi),
                    ..b
                });
                return;
            }
            *done = b.last;
            each(b);
        }
        if hi + 1 - lo >= BACKGROUND_WINDOW {
            *broad = Some(Run {
                first: lo,
                last: hi,
                span,
            });
        } else {
            *done = last;
            each(Run { first, last, span });
        }
    };
    for j in columns {
        if j != last + 1 {
            hand_on(first, last, &mut broad, &mut done);
            first = j;
        }
        last = j;
    }
    hand_on(first, last, &mut broad, &mut done);
    if let Some(b) = broad {
        each(b);
    }
}

/// The levels a profile is read at, sensor DN.
struct Levels {
    /// The noise RMS of a column.
    noise: f32,
    /// A column above it is lit; two extrema of a run differ by at least it.
    threshold: f32,
    /// What every column's weight in a centroid loses.
    floor: f32,
}

/// A light of a profile, as found: a [`Peak`] without the DFT searches' column weights (the
/// profile's columns are the weights), which every light found is copied with several times.
#[derive(Clone, Copy)]
struct Light {
    /// Column in the span domain.
    column: f32,
    /// The sum of its non-negative light, sensor DN.
    amplitude: f32,
    /// Its largest column's light, sensor DN.
    magnitude: f32,
    /// The column of its largest light.
    bin: u16,
}

/// Lights found so far in a profile.
struct Found {
    /// More than `MAX_PEAKS` are kept while searching: the weakest go at the end.
    lights: Vec<Light, { 2 * MAX_PEAKS }>,
    unresolved: bool,
}

impl Found {
    /// Adds a light; when the list is full, it replaces the weakest if it is stronger.
    fn push(&mut self, light: Light) {
        if let Err(light) = self.lights.push(light) {
            let weakest = (0..self.lights.len()).min_by(|&a, &b| {
                self.lights[a]
                    .amplitude
                    .total_cmp(&self.lights[b].amplitude)
            });
            if let Some(i) = weakest {
                if light.amplitude > self.lights[i].amplitude {
                    self.lights[i] = light;
                }
            }
        }
    }
}

/// Columns `first..=last` above the threshold, in a profile of `span + 1` columns.
struct Run {
    first: usize,
    last: usize,
    span: usize,
}

impl Run {
    fn len(&self) -> usize {
        self.last - self.first + 1
    }

    /// The run with its one-column margin, within the columns that are read (`1..span`).
    fn with_margin(&self) -> (usize, usize) {
        (self.first.max(2) - 1, (self.last + 1).min(self.span - 1))
    }
}

/// Significant extrema of `v` over a run, alternating maximum, minimum, …, maximum (an odd
/// count): each swing at least `swing` (hysteresis, so noise makes none), the run's ends
/// counting as 0. A run with more than `MAX_EXTREMA` is read up to its last complete maximum.
fn extrema(v: &impl Fn(usize) -> f32, run: &Run, swing: f32, out: &mut Vec<usize, MAX_EXTREMA>) {
    out.clear();
    // The most extreme column since the last recorded extremum: a maximum while rising.
    let mut best = run.first;
    let mut rising = true;
    for j in run.first..=run.last {
        let x = v(j);
        let turned = if rising {
            x < v(best) - swing
        } else {
            x > v(best) + swing
        };
        if turned {
            if out.push(best).is_err() {
                break;
            }
            rising = !rising;
            best = j;
        } else if (rising && x > v(best)) || (!rising && x < v(best)) {
            best = j;
        }
    }
    // The run's end falls to 0: a pending maximum stands, a pending minimum is the tail.
    if rising && out.len().is_multiple_of(2) && out.push(best).is_err() {
        out.pop();
    }
    if out.len().is_multiple_of(2) {
        out.pop();
    }
}

/// Splits one run of `v` into lights at its deep minima and adds them to `found`.
fn lights_of_run(v: &impl Fn(usize) -> f32, run: &Run, levels: &Levels, found: &mut Found) {
    let mut ext: Vec<usize, MAX_EXTREMA> = Vec::new();
    extrema(v, run, levels.threshold, &mut ext);
    let isolated = ext.len() == 1;
    // Merge the two maxima around each shallow minimum, the larger standing for both, until
    // every remaining minimum is deep.
    loop {
        let shallow = (1..ext.len()).step_by(2).find_map(|i| {
            let lower = v(ext[i - 1]).min(v(ext[i + 1]));
            (v(ext[i]) > (1.0 - SPLIT_DEPTH) * lower).then_some((i, lower))
        });
        let Some((i, lower)) = shallow else { break };
        if v(ext[i]) < (1.0 - RIPPLE_DEPTH) * lower {
            found.unresolved = true;
        }
        let keep = if v(ext[i - 1]) >= v(ext[i + 1]) {
            ext[i - 1]
        } else {
            ext[i + 1]
        };
        ext[i - 1] = keep;
        // Remove the minimum and the second maximum.
        let _ = ext.remove(i);
        let _ = ext.remove(i);
    }
    let (first, last) = run.with_margin();
    let tops: Vec<usize, { MAX_EXTREMA / 2 + 1 }> = ext.iter().step_by(2).copied().collect();
    if tops.len() == 1 {
        found.push(if isolated {
            isolated_light(v, levels.floor, (first, last), tops[0])
        } else {
            measure(v, levels.floor, (first, last), |_| 1.0, tops[0])
        });
        return;
    }
    // Lights whose footprints touch: each column between two maxima is shared by those two
    // lights. First split at the minimum between them (the minimum's column half and half),
    // then, twice, in proportion to what each light sends there, read off its own far side as
    // the mirror image about its centroid (a light is nearly symmetric; the far side carries
    // none of the other's light): this undoes most of the bias a hard split leaves when two
    // lights' tails overlap.
    let minima: Vec<usize, { MAX_EXTREMA / 2 + 1 }> =
        ext.iter().skip(1).step_by(2).copied().collect();
    let n = tops.len();
    let territory = |k: usize| {
        let lo = if k == 0 { first } else { tops[k - 1] + 1 };
        let hi = if k + 1 == n { last } else { tops[k + 1] - 1 };
        (lo, hi)
    };
    let hard = |k: usize, j: usize| -> f32 {
        let below = k > 0 && j < tops[k] && j <= minima[k - 1];
        let above = k + 1 < n && j > tops[k] && j >= minima[k];
        match (below, above) {
            (true, _) if j == minima[k - 1] => 0.5,
            (_, true) if j == minima[k] => 0.5,
            (true, _) | (_, true) => 0.0,
            _ => 1.0,
        }
    };
    let mut centres: Vec<f32, { MAX_EXTREMA / 2 + 1 }> = (0..n)
        .map(|k| measure(v, levels.floor, territory(k), |j| hard(k, j), tops[k]).column)
        .collect();
    let mirrored = |centre: f32, j: usize| -> f32 {
        let x = 2.0 * centre - j as f32;
        if x < first as f32 || x > last as f32 {
            return 0.0;
        }
        let i = crate::math::floor(x) as usize;
        let t = x - i as f32;
        // A light's flank falls about exponentially: interpolate geometrically, a column
        // lighter than the noise counting as the noise.
        let (a, b) = (
            v(i).max(levels.noise),
            v((i + 1).min(last)).max(levels.noise),
        );
        exp((1.0 - t) * ln(a) + t * ln(b))
    };
    let shared = |centres: &[f32], k: usize, j: usize| -> f32 {
        // The neighbour whose maximum lies on `j`'s side of this light's.
        let other = if j < tops[k] && k > 0 {
            k - 1
        } else if j > tops[k] && k + 1 < n {
            k + 1
        } else {
            return 1.0;
        };
        // Only light above the floor is attributed: a mirror image on a steep far flank is
        // mostly interpolation, and it would pull the light towards its neighbour.
        let above = |c: f32| (mirrored(c, j) - levels.floor).max(0.0);
        let (mine, theirs) = (above(centres[k]), above(centres[other]));
        if mine + theirs > 0.0 {
            mine / (mine + theirs)
        } else {
            // Neither light's far side says: the split at the minimum does.
            hard(k, j)
        }
    };
    for _ in 0..UNMIX_PASSES {
        let next: Vec<f32, { MAX_EXTREMA / 2 + 1 }> = (0..n)
            .map(|k| {
                let share = |j: usize| shared(&centres, k, j);
                measure(v, levels.floor, territory(k), share, tops[k]).column
            })
            .collect();
        centres = next;
    }
    for k in 0..n {
        let share = |j: usize| shared(&centres, k, j);
        found.push(measure(v, levels.floor, territory(k), share, tops[k]));
    }
}

/// The light over columns `first..=last` whose largest weight is at `top`, each column
/// weighing its light less `floor`, times the share of the column this light has.
fn measure(
    v: &impl Fn(usize) -> f32,
    floor: f32,
    (first, last): (usize, usize),
    share: impl Fn(usize) -> f32,
    top: usize,
) -> Light {
    let (mut light, mut sum, mut moment) = (0.0f32, 0.0f32, 0.0f32);
    for j in first..=last {
        let share = share(j);
        let x = v(j);
        let w = share * (x - floor).max(0.0);
        light += share * x.max(0.0);
        sum += w;
        moment += w * j as f32;
    }
    Light {
        column: if sum > 0.0 { moment / sum } else { top as f32 },
        amplitude: light,
        magnitude: v(top),
        bin: top as u16,
    }
}

/// An isolated light, the only maximum of columns `first..=last`, at most
/// [`MATCHED_MAX_COLUMNS`] of them: [`measure`]d, then its column moved by [`matched`] if it is
/// at least [`MATCHED_MIN_VARIANCE`] wide. A light over more columns (a surface seen at a
/// grazing angle) is measured alone.
fn isolated_light(
    v: &impl Fn(usize) -> f32,
    floor: f32,
    (first, last): (usize, usize),
    top: usize,
) -> Light {
    let n = last + 1 - first;
    if n > MATCHED_MAX_COLUMNS {
        return measure(v, floor, (first, last), |_| 1.0, top);
    }
    // The columns, read once: both passes read them again.
    let mut columns = [0.0f32; MATCHED_MAX_COLUMNS];
    let columns = &mut columns[..n];
    for (k, x) in columns.iter_mut().enumerate() {
        *x = v(first + k);
    }
    // `measure`'s sums in its order (bit for bit its light and centroid), and the spread of the
    // weights about the top column. A column as a float is counted (exact below 2²⁴).
    let (mut light, mut sum, mut moment, mut spread) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    let (mut at, top_at) = (first as u32 as f32, top as u32 as f32);
    for &x in columns.iter() {
        let w = (x - floor).max(0.0);
        let d = at - top_at;
        light += x.max(0.0);
        sum += w;
        moment += w * at;
        spread += w * d * d;
        at += 1.0;
    }
    let mut peak = Light {
        column: top as f32,
        amplitude: light,
        magnitude: columns[top - first],
        bin: top as u16,
    };
    if sum > 0.0 {
        let centroid = moment / sum;
        let off = centroid - top_at;
        let variance = spread / sum - off * off;
        peak.column = if variance >= MATCHED_MIN_VARIANCE {
            matched(columns, first, centroid, variance)
        } else {
            centroid
        };
    }
    peak
}

/// `centroid`, the floored centroid of an isolated light whose weights have `variance` about
/// it, moved to the fixed point of a centroid weighted by a biweight window `(1 − u²)²`,
/// `u = (j − c)/R`, on the light itself (not floored); `columns` holds the light of columns
/// `first..`. That is the column where the profile's correlation with a bell-shaped footprint
/// (the triweight `(1 − u²)³`, the biweight's integral) peaks: a matched filter. Columns far
/// from the centre, whose noise moves a centroid most and which hold the least light, weigh
/// little, without the floor's threshold. `R` is [`MATCHED_REACH`] times the floored light's
/// RMS width, so the window fits the footprint (a camera pixel spanning several columns, the
/// projector's blur); a light's own asymmetry still moves its column about as it moves the
/// centroid. One pass from the centroid: on synthetic lights (`tests/suite/cosine.rs`) the
/// scatter falls from 0.0046 to 0.0034 column (BFSM) and from 0.0107 to 0.0090 (EFSM two
/// groups), on the simulated plane from 0.0038 to 0.0026 and from 0.0084 to 0.0065; a second
/// pass gained 5% more for about 130 more x86 instructions a pixel. A pass that leaves the
/// columns, or moves the column by more than [`MATCHED_MAX_SHIFT`], keeps the centroid.
fn matched(columns: &[f32], first: usize, centroid: f32, variance: f32) -> f32 {
    let reach = MATCHED_REACH * crate::math::sqrt(variance);
    let per_column = 1.0 / reach;
    let (mut weight, mut moment) = (0.0f32, 0.0f32);
    let mut d = first as u32 as f32 - centroid;
    for &x in columns {
        let u = d * per_column;
        let t = (1.0 - u * u).max(0.0);
        let w = x * (t * t);
        weight += w;
        moment += w * d;
        d += 1.0;
    }
    if weight <= 0.0 {
        return centroid;
    }
    let column = centroid + moment / weight;
    let inside = column >= first as f32 && column <= (first + columns.len() - 1) as f32;
    if inside && (column - centroid).abs() <= MATCHED_MAX_SHIFT {
        column
    } else {
        centroid
    }
}

/// The biweight window of step 4 reaches this many RMS widths of the floored light. Chosen
/// on a model of box footprints in white noise, before any measurement of the decoder: there
/// 3–3.5 scattered least (2.5: 4% more, 4: 3% more), and 3.5 was the least biased without noise.
pub const MATCHED_REACH: f32 = 3.5;

/// The least variance, columns², of an isolated light's floored weights for [`matched`] to move
/// it (an RMS width of 0.8 column). A narrower light lies on two or three columns, across which
/// the window is far from flat: sampled so coarsely, the window's fixed point is off the
/// centroid by up to 0.1 column (two columns lit, or a spot blurred by σ 0.4: the suites
/// `accuracy` and `estimators`), more than the noise it saves; it keeps its centroid.
const MATCHED_MIN_VARIANCE: f32 = 0.64;

/// The most the matched window (step 4) may move a light, columns. On a symmetric light it
/// moves the column by about its noise (a hundredth of a column); a larger move means a light
/// that is not the bell the window fits, and the light keeps its centroid. Allowing a whole
/// column, the window changed the selection along `vgroove`'s crease (EFSM): the scan's edge
/// test then took 0.3% of that band's right points (`tests/workspace/wrong_points.rs`).
pub const MATCHED_MAX_SHIFT: f32 = 0.05;

/// Most columns of an isolated light that [`matched`] re-measures.
const MATCHED_MAX_COLUMNS: usize = 32;

/// A run of at least [`BACKGROUND_WINDOW`] columns: the narrow lights on its opening, or, if
/// there are none, the run as one wide light.
fn broad_run(
    v: &impl Fn(usize) -> f32,
    run: &Run,
    levels: &Levels,
    background: &mut [f32],
    found: &mut Found,
) {
    let swing = levels.threshold;
    let half = BACKGROUND_WINDOW / 2;
    let (first, last) = (run.first, run.last);
    // Beyond the run's ends the profile counts as 0 (unlit), so the erosion of a column within
    // `half` of an end is 0; but where the run meets the end of the columns read (EFSM: its
    // light goes on in the next block) the profile counts as its last column. The opening is
    // the dilation of the erosion.
    let (open_below, open_above) = (first == 1, last + 2 == run.span);
    let at = |j: isize| -> f32 {
        if j < first as isize {
            if open_below {
                v(first)
            } else {
                0.0
            }
        } else if j > last as isize {
            if open_above {
                v(last)
            } else {
                0.0
            }
        } else {
            v(j as usize)
        }
    };
    let eroded = |j: isize| -> f32 {
        let mut m = at(j - half as isize);
        for k in (j - half as isize + 1)..=(j + half as isize) {
            m = m.min(at(k));
        }
        m
    };
    // Erosion into `background[first..=last]`, then the dilation in place with a window of
    // the erosion values kept in a small ring.
    let bg = &mut background[..=last];
    for (j, b) in bg.iter_mut().enumerate().skip(first) {
        *b = eroded(j as isize).max(0.0);
    }
    let mut ring = [0.0f32; BACKGROUND_WINDOW];
    let erosion_at = |bg: &[f32], j: isize| -> f32 {
        if j < first as isize {
            if open_below {
                bg[first]
            } else {
                0.0
            }
        } else if j > last as isize {
            if open_above {
                bg[last]
            } else {
                0.0
            }
        } else {
            bg[j as usize]
        }
    };
    for (k, r) in ring.iter_mut().enumerate() {
        *r = erosion_at(bg, first as isize - half as isize + k as isize);
    }
    for j in first..=last {
        // `ring` holds the erosion over `j − half ..= j + half`, oldest first at `slot`.
        let opened = ring.iter().copied().fold(0.0f32, f32::max);
        let slot = (j - first) % BACKGROUND_WINDOW;
        let next = erosion_at(bg, j as isize + half as isize + 1);
        bg[j] = opened;
        ring[slot] = next;
    }
    // The narrow lights: maxima of the top-hat's runs above the threshold (beyond the run, where a
    // narrow light's margin may reach, the opening is 0).
    let broad = |j: usize| if j < first || j > last { 0.0 } else { bg[j] };
    let top_hat = |j: usize| v(j) - broad(j);
    let mut narrow_lights = false;
    let mut j = first;
    while j <= last {
        if top_hat(j) <= swing {
            j += 1;
            continue;
        }
        let start = j;
        while j < last && top_hat(j + 1) > swing {
            j += 1;
        }
        let narrow = Run {
            first: start,
            last: j,
            span: run.span,
        };
        if (start..=j).all(|k| broad(k) <= swing) {
            // No broad light under these columns (a run that reaches a window's length only
            // with its feet): they are lights of their own, read as in step 2.
            lights_of_run(v, &narrow, levels, found);
            narrow_lights = true;
            j += 1;
            continue;
        }
        let mut ext: Vec<usize, MAX_EXTREMA> = Vec::new();
        extrema(&top_hat, &narrow, swing, &mut ext);
        for &top in ext.iter().step_by(2) {
            if let Some(light) = narrow_light(v, top, run.with_margin(), levels) {
                found.push(light);
                narrow_lights = true;
            }
        }
        j += 1;
    }
    if !narrow_lights {
        // Nothing stands above the opening: one wide light (a camera pixel seeing a surface
        // at a grazing angle covers many columns).
        lights_of_run(v, run, levels, found);
    }
}

/// The narrow light whose maximum is at `top`, on a broad light, within columns `lo..=hi`:
/// the light above the straight line between its feet, the columns on either side within
/// half a [`BACKGROUND_WINDOW`] where the profile bends most sharply upwards (the largest
/// second difference; where it does not bend upwards, half a window out): there the narrow
/// light's flank meets the broad light. The opening
/// only found it: under a narrow light on a broad light's corner it lies lower than the broad
/// light, and what stands above it is not the narrow light alone.
fn narrow_light(
    v: &impl Fn(usize) -> f32,
    top: usize,
    (lo, hi): (usize, usize),
    levels: &Levels,
) -> Option<Light> {
    let reach = BACKGROUND_WINDOW / 2;
    let bend = |j: usize| v(j - 1) - 2.0 * v(j) + v(j + 1);
    // Without an upward bend within reach, the foot is where the reach ends.
    let foot = |candidates: &mut dyn Iterator<Item = usize>, end: usize| {
        candidates
            .filter(|&j| bend(j) > 0.0)
            .max_by(|&a, &b| bend(a).total_cmp(&bend(b)))
            .unwrap_or(end)
    };
    let left_end = top.saturating_sub(reach).max(lo + 1);
    let right_end = (top + reach).min(hi.saturating_sub(1));
    let a = foot(&mut (left_end..top).rev(), left_end);
    let b = foot(&mut ((top + 1)..right_end + 1), right_end);
    if !(a < top && top < b) {
        return None;
    }
    let (va, vb) = (v(a), v(b));
    let slope = (vb - va) / (b - a) as f32;
    let above = |j: usize| v(j) - (va + slope * (j as f32 - a as f32));
    let light = measure(&above, levels.floor, (a + 1, b - 1), |_| 1.0, top);
    (light.amplitude > 0.0).then_some(light)
}

/// The lights that pass the floors, strongest first, at most `max_peaks` (`lights` is sorted
/// in place).
fn keep_strongest(plan: &ScanPlan, lights: &mut [Light], out: &mut PeakList) {
    let settings = plan.decoding;
    let strongest = lights.iter().map(|l| l.amplitude).fold(0.0f32, f32::max);
    let floor = settings
        .min_amplitude_dn
        .max(settings.relative_floor * strongest);
    // Insertion sort, amplitude descending then column ascending: the order must not depend
    // on a sort algorithm.
    for i in 1..lights.len() {
        let mut k = i;
        while k > 0 && stronger(&lights[k], &lights[k - 1]) {
            lights.swap(k, k - 1);
            k -= 1;
        }
    }
    let kept = lights.iter().filter(|l| l.amplitude > floor);
    for light in kept.take(settings.max_peaks as usize) {
        let _ = out.peaks.push(Peak {
            column: light.column,
            amplitude: light.amplitude,
            magnitude: light.magnitude,
            bin: light.bin,
            weights: ColumnWeights::default(),
        });
    }
}

fn stronger(a: &Light, b: &Light) -> bool {
    b.amplitude
        .total_cmp(&a.amplitude)
        .then(a.column.total_cmp(&b.column))
        .is_lt()
}
