//! The cosine search's path (SPEC §2b), `L` adjacent pixels at a time: each group's fringes
//! and the reference frames → the column profile of every lane in one lane-parallel inverse
//! cosine transform → the lights of each lane → candidates.
//!
//! The loads and the transform are lane loops over `[f32; L]` with the same scalar operations
//! in every lane, which the compiler turns into vector instructions where the target has
//! them; the lights are read lane by lane. So `L` changes the speed, never the bits.
//!
//! [`decode_row_fastest`] enters the row's loop compiled for the widest instructions the CPU
//! runs ([`Isa::detect`]): on x86-64, 16 lanes of AVX-512F or 8 of AVX2 where the CPU has
//! them, else the build's own (SSE2, [`super::DEFAULT_LANES`]).

use super::{saturation_code, Decoder, Row};
use crate::candidate::{PixelCandidates, PixelFlags};
use crate::noise::{profile_noise_dn, sample_noise_dn};
use crate::peak::PeakList;
use crate::plan::sequence::Group;
use crate::plan::ScanPlan;
use crate::search::cosine::{self as search, Search};
use crate::transform::isa::Isa;
use crate::transform::simd::Vector;
use crate::transform::{CosineTransform, Lanes, TransformError};

/// Floats of scratch for `L` lanes: the profiles (`span + 1` lanes), the transform's own
/// scratch, one lane's broad light.
pub(super) fn scratch_len<const L: usize>(span: u16) -> usize {
    let n = span as usize;
    (n + 1 + CosineTransform::scratch_len(n)) * L + search::scratch_len(span)
}

/// The profiles, the transform's scratch and the search's, carved from `scratch`.
fn split<const L: usize>(
    scratch: &mut [f32],
    span: usize,
) -> (&mut [Lanes<L>], &mut [Lanes<L>], &mut [f32]) {
    let (lanes, rest) = scratch.split_at_mut((span + 1 + CosineTransform::scratch_len(span)) * L);
    let (lanes, _) = lanes.as_chunks_mut::<L>();
    let (profile, work) = lanes.split_at_mut(span + 1);
    (profile, work, rest)
}

/// What the dark and white frames say about one pixel.
#[derive(Clone, Copy, Default)]
pub(super) struct References {
    /// `dark + PA/(PA+PB)·(white − dark)`: the level a fringe sample swings about.
    offset: f32,
    /// `PB/(PA+PB)·(white − dark)`: the transform's term `h = 0`.
    zero_term: f32,
    /// The pixel's sample noise RMS, sensor DN.
    sample_noise_dn: f32,
    /// A reference frame reached the saturation code.
    saturated: bool,
}

impl References {
    fn of(plan: &ScanPlan, row: &Row<'_>, x: usize) -> References {
        let sample = |frame: Option<usize>| frame.map_or(0, |i| row.frames[i * row.width + x]);
        // Cosine plans have both frames (validated).
        let (dark, white) = (sample(plan.dark_index()), sample(plan.white_index()));
        let levels = plan.levels;
        let full = levels.offset + levels.amplitude;
        // Integer codes below 2^16: exact in f32, and so is their difference.
        let range = white as f32 - dark as f32;
        let signal = levels.offset / full * range;
        let saturation = saturation_code(row.bit_depth);
        References {
            offset: dark as f32 + signal,
            zero_term: levels.amplitude / full * range,
            sample_noise_dn: sample_noise_dn(&plan.decoding.sensor, row.bit_depth, signal),
            saturated: dark >= saturation || white >= saturation,
        }
    }
}

/// Loads `z_0..=z_span` of the group whose fringes start at frame `start`, for the pixels
/// `x0..x0 + refs.len()`, into `profile`, lanes
/// past them zero, `L/W` chunks of the vector type `V` at a time; returns the lanes (bit `l`)
/// that saturated a fringe sample.
#[inline(always)]
fn load_with<const L: usize, const W: usize, V: Vector<W>>(
    row: &Row<'_>,
    x0: usize,
    start: usize,
    refs: &[References],
    profile: &mut [Lanes<L>],
) -> u32 {
    let mut offset = [0.0f32; L];
    let mut zero = [0.0f32; L];
    for (l, r) in refs.iter().enumerate() {
        offset[l] = r.offset;
        zero[l] = r.zero_term;
    }
    profile[0] = zero;
    let w = row.width;
    // Codes are integers: a lane's largest code reaches the saturation code exactly when it
    // is above half a code below it.
    let saturation = saturation_code(row.bit_depth) as f32 - 0.5;
    let mut saturated = 0u32;
    // Fringe `h − 1` is harmonic `h` (a full band starts at the first harmonic).
    if refs.len() == L {
        // The group's fringes, frame by frame (a checked row holds them all).
        let fringes = row.frames.get(start * w..).unwrap_or(&[]).chunks_exact(w);
        for c in 0..L / W {
            let offset = V::load(&offset.as_chunks::<W>().0[c]);
            let mut brightest = V::splat(0.0);
            for (z, frame) in profile.iter_mut().skip(1).zip(fringes.clone()) {
                let Some(codes) = frame.get(x0 + c * W..).and_then(|f| f.first_chunk::<W>()) else {
                    break;
                };
                let s = V::load_codes(codes);
                (s - offset).store(&mut z.as_chunks_mut::<W>().0[c]);
                brightest = brightest.max(s);
            }
            saturated |= brightest.above(V::splat(saturation)) << (c * W);
        }
        return saturated;
    }
    // The row's last, partial chunk.
    let mut brightest = [0u16; L];
    for (h, z) in profile.iter_mut().enumerate().skip(1) {
        let at = (start + h - 1) * w + x0;
        *z = [0.0; L];
        for l in 0..refs.len() {
            let s = row.frames[at + l];
            z[l] = s as f32 - offset[l];
            brightest[l] = brightest[l].max(s);
        }
    }
    for (l, &b) in brightest.iter().enumerate() {
        saturated |= ((b as f32 > saturation) as u32) << l;
    }
    saturated
}

/// What the path keeps from chunk to chunk of a row: the search's working state and one
/// peak list (setting them up costs more than a pixel's search).
pub(super) struct RowState {
    search: Search,
    lights: PeakList,
}

impl RowState {
    pub(super) fn new() -> Self {
        RowState {
            search: Search::new(),
            lights: PeakList::default(),
        }
    }
}

/// The vector instructions a chunk of `L` lanes runs its lane loops with: the loads, the
/// transform, the lit columns.
pub(super) trait Path<const L: usize> {
    fn load(
        row: &Row<'_>,
        x0: usize,
        start: usize,
        refs: &[References],
        profile: &mut [Lanes<L>],
    ) -> u32;
    fn inverse(
        transform: &CosineTransform<'_>,
        data: &mut [Lanes<L>],
        scratch: &mut [Lanes<L>],
    ) -> Result<(), TransformError>;
    fn find_lit(search: &mut Search, profile: &[Lanes<L>], thresholds: &[f32; L]);

    /// One group of a chunk: [`Path::load`], [`Path::inverse`] and [`Path::find_lit`]. These
    /// lane loops do not depend on the candidate capacity `K`, so each path compiles them
    /// once, in this crate, and the row loops of every `K` in every crate call that copy.
    /// Inlined into the row loops instead, they were compiled again for each `K` in each
    /// dependant: the workspace's test build took 1,762 s of CPU, 629 s without.
    #[inline(always)]
    fn group(lanes: GroupLanes<'_, '_, L>) -> Result<u32, TransformError> {
        group_with::<L, Self>(lanes)
    }
}

/// The arguments of [`Path::group`]: a chunk's group, its fringes and its working space.
pub(super) struct GroupLanes<'a, 'r, const L: usize> {
    transform: &'a CosineTransform<'a>,
    row: &'a Row<'r>,
    x0: usize,
    start: usize,
    refs: &'a [References],
    thresholds: &'a [f32; L],
    profile: &'a mut [Lanes<L>],
    work: &'a mut [Lanes<L>],
    search: &'a mut Search,
}

/// [`Path::group`]'s lane loops, inlined into the function that enters them.
#[inline(always)]
fn group_with<const L: usize, P: Path<L> + ?Sized>(
    lanes: GroupLanes<'_, '_, L>,
) -> Result<u32, TransformError> {
    let saturated = P::load(lanes.row, lanes.x0, lanes.start, lanes.refs, lanes.profile);
    P::inverse(lanes.transform, lanes.profile, lanes.work)?;
    P::find_lit(lanes.search, lanes.profile, lanes.thresholds);
    Ok(saturated)
}

/// Implements [`Path`]'s loops for one vector type `V` of `W` lanes, as many lanes as a
/// chunk (the x86-64 lanes entered after run-time detection).
#[cfg(target_arch = "x86_64")]
macro_rules! path_with {
    ($w:literal, $v:ty) => {
        #[inline(always)]
        fn load(
            row: &Row<'_>,
            x0: usize,
            start: usize,
            refs: &[References],
            profile: &mut [Lanes<$w>],
        ) -> u32 {
            load_with::<$w, $w, $v>(row, x0, start, refs, profile)
        }
        #[inline(always)]
        fn find_lit(search: &mut Search, profile: &[Lanes<$w>], thresholds: &[f32; $w]) {
            search.find_lit::<$w, $w, $v>(profile, thresholds)
        }
    };
}

/// What the build targets: chunks of its 4-lane vector (SSE2 on x86-64, NEON on the camera)
/// where 4 divides `L`, else scalar.
pub(super) struct Portable;

impl<const L: usize> Path<L> for Portable {
    #[inline(always)]
    fn load(
        row: &Row<'_>,
        x0: usize,
        start: usize,
        refs: &[References],
        profile: &mut [Lanes<L>],
    ) -> u32 {
        if L.is_multiple_of(4) {
            return load_with::<L, 4, crate::transform::simd::F4>(row, x0, start, refs, profile);
        }
        load_with::<L, 1, f32>(row, x0, start, refs, profile)
    }
    #[inline(always)]
    fn inverse(
        transform: &CosineTransform<'_>,
        data: &mut [Lanes<L>],
        scratch: &mut [Lanes<L>],
    ) -> Result<(), TransformError> {
        transform.inverse::<L>(data, scratch)
    }
    #[inline(always)]
    fn find_lit(search: &mut Search, profile: &[Lanes<L>], thresholds: &[f32; L]) {
        if L.is_multiple_of(4) {
            return search.find_lit::<L, 4, crate::transform::simd::F4>(profile, thresholds);
        }
        search.find_lit::<L, 1, f32>(profile, thresholds)
    }
    fn group(lanes: GroupLanes<'_, '_, L>) -> Result<u32, TransformError> {
        portable_group::<L>(lanes)
    }
}

/// [`Portable`]'s group, not inlined: a dependant links this crate's copy for
/// [`super::DEFAULT_LANES`] ([`SHARED`]) rather than compiling its own.
// `inline(never)`: a generic function's copy is shared with dependants only then.
#[inline(never)]
fn portable_group<const L: usize>(lanes: GroupLanes<'_, '_, L>) -> Result<u32, TransformError> {
    group_with::<L, Portable>(lanes)
}

/// The generic functions this crate compiles for its dependants at the build's lane count
/// and at one lane ([`Decoder::decode_row_lanes`] of the DFT searches): the portable group
/// and the lights. Dependants link these copies instead of compiling their own; the x86-64
/// paths' groups are not generic, their lights are in `x86`.
#[used]
static SHARED: (
    PortableGroup<{ super::DEFAULT_LANES }>,
    PortableGroup<1>,
    FindLights<{ super::DEFAULT_LANES }>,
    FindLights<1>,
) = (
    portable_group::<{ super::DEFAULT_LANES }>,
    portable_group::<1>,
    search::find_lights::<{ super::DEFAULT_LANES }>,
    search::find_lights::<1>,
);

/// [`portable_group`]'s signature.
type PortableGroup<const L: usize> = fn(GroupLanes<'_, '_, L>) -> Result<u32, TransformError>;

/// [`search::find_lights`]' signature.
type FindLights<const L: usize> =
    fn(&ScanPlan, &[Lanes<L>], usize, f32, &mut Search, &mut [f32], &mut PeakList);

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{
        decode_row, group_with, load_with, search, Decoder, FindLights, GroupLanes, Path,
        PixelCandidates, References, Row, Search, TransformError,
    };
    use crate::transform::simd::{F16, F8};
    use crate::transform::{CosineTransform, Lanes};

    /// 8 lanes of AVX2: for [`decode_avx2`] only.
    pub(super) struct Avx2;
    /// 16 lanes of AVX-512F: for [`decode_avx512`] only.
    pub(super) struct Avx512;

    impl Path<8> for Avx2 {
        path_with!(8, F8);
        #[inline(always)]
        fn inverse(
            transform: &CosineTransform<'_>,
            data: &mut [Lanes<8>],
            scratch: &mut [Lanes<8>],
        ) -> Result<(), TransformError> {
            transform.inverse_with::<8, 8, F8>(data, scratch)
        }
        #[inline(always)]
        #[allow(unsafe_code)]
        fn group(lanes: GroupLanes<'_, '_, 8>) -> Result<u32, TransformError> {
            // SAFETY: `Avx2` is only a path of `decode_avx2`, which `decode_row_fastest`
            // enters where `Isa::detect` found AVX2.
            unsafe { group_avx2(lanes) }
        }
    }

    impl Path<16> for Avx512 {
        path_with!(16, F16);
        #[inline(always)]
        fn inverse(
            transform: &CosineTransform<'_>,
            data: &mut [Lanes<16>],
            scratch: &mut [Lanes<16>],
        ) -> Result<(), TransformError> {
            transform.inverse_with::<16, 16, F16>(data, scratch)
        }
        #[inline(always)]
        #[allow(unsafe_code)]
        fn group(lanes: GroupLanes<'_, '_, 16>) -> Result<u32, TransformError> {
            // SAFETY: `Avx512` is only a path of `decode_avx512`, which `decode_row_fastest`
            // enters where `Isa::detect` found AVX-512F.
            unsafe { group_avx512(lanes) }
        }
    }

    /// The lights of the x86-64 paths' lane counts, compiled here for the dependants (see
    /// [`super::SHARED`]).
    #[used]
    static SHARED: (FindLights<8>, FindLights<16>) =
        (search::find_lights::<8>, search::find_lights::<16>);

    /// [`Avx2`]'s group, compiled once here for every crate (not generic).
    #[target_feature(enable = "avx2")]
    fn group_avx2(lanes: GroupLanes<'_, '_, 8>) -> Result<u32, TransformError> {
        group_with::<8, Avx2>(lanes)
    }

    /// [`Avx512`]'s group, compiled once here for every crate (not generic).
    #[target_feature(enable = "avx512f")]
    fn group_avx512(lanes: GroupLanes<'_, '_, 16>) -> Result<u32, TransformError> {
        group_with::<16, Avx512>(lanes)
    }

    /// The row's loop compiled for AVX2 (its groups' lane loops are [`group_avx2`]).
    #[target_feature(enable = "avx2")]
    pub(super) fn decode_avx2<const K: usize>(
        decoder: &Decoder<'_>,
        transform: &CosineTransform<'_>,
        row: &Row<'_>,
        scratch: &mut [f32],
        out: &mut [PixelCandidates<K>],
    ) {
        decode_row::<8, K, Avx2>(decoder, transform, row, scratch, out)
    }

    /// The row's loop compiled for AVX-512F (its groups' lane loops are [`group_avx512`]).
    #[target_feature(enable = "avx512f")]
    pub(super) fn decode_avx512<const K: usize>(
        decoder: &Decoder<'_>,
        transform: &CosineTransform<'_>,
        row: &Row<'_>,
        scratch: &mut [f32],
        out: &mut [PixelCandidates<K>],
    ) {
        decode_row::<16, K, Avx512>(decoder, transform, row, scratch, out)
    }
}

/// Decodes every pixel of a checked `row` into `out` with the widest instructions `isa`
/// says the CPU runs; `scratch` holds [`scratch_len`] floats of [`super::MAX_LANES`].
#[allow(unsafe_code)]
pub(super) fn decode_row_fastest<const K: usize>(
    decoder: &Decoder<'_>,
    transform: &CosineTransform<'_>,
    isa: Isa,
    row: &Row<'_>,
    scratch: &mut [f32],
    out: &mut [PixelCandidates<K>],
) {
    match isa {
        // SAFETY: `isa` is what `Isa::detect` found this CPU and OS to run.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 => unsafe { x86::decode_avx512(decoder, transform, row, scratch, out) },
        // SAFETY: as above.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { x86::decode_avx2(decoder, transform, row, scratch, out) },
        _ => decode_row::<{ super::DEFAULT_LANES }, K, Portable>(
            decoder, transform, row, scratch, out,
        ),
    }
}

/// Decodes every pixel of a checked `row` into `out`, `L` at a time, the transform taking
/// path `P`.
#[inline(always)]
pub(super) fn decode_row<const L: usize, const K: usize, P: Path<L>>(
    decoder: &Decoder<'_>,
    transform: &CosineTransform<'_>,
    row: &Row<'_>,
    scratch: &mut [f32],
    out: &mut [PixelCandidates<K>],
) {
    let mut state = RowState::new();
    for (x0, pixels) in (0..row.width).step_by(L).zip(out.chunks_mut(L)) {
        decode_pixels::<L, K, P>(decoder, transform, row, x0, scratch, &mut state, pixels);
    }
}

/// Decodes the pixels `x0..x0 + out.len()` (at most `L`) of a checked `row` into `out`.
#[inline(always)]
pub(super) fn decode_pixels<const L: usize, const K: usize, P: Path<L>>(
    decoder: &Decoder<'_>,
    transform: &CosineTransform<'_>,
    row: &Row<'_>,
    x0: usize,
    scratch: &mut [f32],
    state: &mut RowState,
    out: &mut [PixelCandidates<K>],
) {
    let RowState {
        search: state,
        lights,
    } = state;
    let plan = &decoder.plan;
    let span = transform.span();
    let (profile, work, background) = split::<L>(scratch, span);
    let lanes = out.len().min(L);
    let mut refs = [References::default(); L];
    for (l, (r, pixel)) in refs.iter_mut().zip(out.iter_mut()).enumerate() {
        *r = References::of(plan, row, x0 + l);
        pixel.clear();
        if r.saturated {
            pixel.flags.insert(PixelFlags::SATURATED);
        }
    }
    let mut troubled = [true; L];
    let noise: [f32; L] =
        core::array::from_fn(|l| profile_noise_dn(refs[l].sample_noise_dn, span as u16));
    let thresholds = noise.map(|n| plan.decoding.noise_factor * n);
    for group in plan.groups() {
        let lanes_of_group = GroupLanes {
            transform,
            row,
            x0,
            start: decoder.frames[group.index()].fringe_start,
            refs: &refs[..lanes],
            thresholds: &thresholds,
            profile: &mut *profile,
            work: &mut *work,
            search: &mut *state,
        };
        // The scratch was sized for this transform: it cannot refuse it.
        let Ok(saturated) = P::group(lanes_of_group) else {
            return;
        };
        for l in 0..lanes {
            let pixel = &mut out[l];
            if saturated & (1 << l) != 0 {
                pixel.flags.insert(PixelFlags::SATURATED);
            }
            search::find_lights(plan, profile, l, noise[l], state, background, lights);
            let group_troubled =
                decoder.add_group(row, x0 + l, group, lights, refs[l].sample_noise_dn, pixel);
            troubled[l] &= group_troubled;
        }
    }
    for (pixel, &t) in out.iter_mut().zip(troubled.iter()) {
        decoder.finish(t, pixel);
    }
}

/// The column profile of `group` at pixel `x` of a checked `row`, in `scratch`.
pub(super) fn profile<'s>(
    decoder: &Decoder<'_>,
    transform: &CosineTransform<'_>,
    row: &Row<'_>,
    x: usize,
    group: Group,
    scratch: &'s mut [f32],
) -> &'s [f32] {
    let span = transform.span();
    let (profile, work, _) = split::<1>(scratch, span);
    let refs = [References::of(&decoder.plan, row, x)];
    let start = decoder.frames[group.index()].fringe_start;
    Portable::load(row, x, start, &refs, profile);
    if transform.inverse::<1>(profile, work).is_err() {
        return &[];
    }
    profile.as_flattened()
}

/// The lights of `group` at pixel `x` of a checked `row`.
pub(super) fn lights(
    decoder: &Decoder<'_>,
    transform: &CosineTransform<'_>,
    row: &Row<'_>,
    x: usize,
    group: Group,
    scratch: &mut [f32],
    out: &mut PeakList,
) {
    let span = transform.span();
    let (profile, work, background) = split::<1>(scratch, span);
    let refs = [References::of(&decoder.plan, row, x)];
    let start = decoder.frames[group.index()].fringe_start;
    Portable::load(row, x, start, &refs, profile);
    out.peaks.clear();
    if transform.inverse::<1>(profile, work).is_ok() {
        let noise = profile_noise_dn(refs[0].sample_noise_dn, span as u16);
        let mut state = Search::new();
        Portable::find_lit(
            &mut state,
            profile,
            &[decoder.plan.decoding.noise_factor * noise],
        );
        search::find_lights(
            &decoder.plan,
            profile,
            0,
            noise,
            &mut state,
            background,
            out,
        );
    }
}
