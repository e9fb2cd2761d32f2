//! The cosine search's path (SPEC §2b), `L` adjacent pixels at a time: each group's fringes
//! and the reference frames → the column profile of every lane in one lane-parallel inverse
//! cosine transform → the lights of each lane → candidates.
//!
//! The loads and the transform are lane loops over `[f32; L]` with the same scalar operations
//! in every lane, which the compiler turns into vector instructions where the target has
//! them; the lights are read lane by lane. So `L` changes the speed, never the bits.

use super::{saturation_code, Decoder, Row};
use crate::candidate::{PixelCandidates, PixelFlags};
use crate::noise::{profile_noise_dn, sample_noise_dn};
use crate::peak::PeakList;
use crate::plan::sequence::Group;
use crate::plan::ScanPlan;
use crate::search::cosine::{self as search, LitColumns};
use crate::transform::{CosineTransform, Lanes};

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
struct References {
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

/// Loads `z_0..=z_span` of `group` for the pixels `x0..x0 + refs.len()` into `profile`, lanes
/// past them zero; returns which lanes saturated a fringe sample.
#[inline(always)]
fn load<const L: usize>(
    plan: &ScanPlan,
    row: &Row<'_>,
    x0: usize,
    group: Group,
    refs: &[References],
    profile: &mut [Lanes<L>],
) -> [bool; L] {
    let mut offset = [0.0f32; L];
    let mut zero = [0.0f32; L];
    for (l, r) in refs.iter().enumerate() {
        offset[l] = r.offset;
        zero[l] = r.zero_term;
    }
    profile[0] = zero;
    let start = plan.fringe_start(group);
    let w = row.width;
    let mut brightest = [0u16; L];
    // Fringe `h − 1` is harmonic `h` (a full band starts at the first harmonic).
    for (h, z) in profile.iter_mut().enumerate().skip(1) {
        let at = (start + h - 1) * w + x0;
        match row
            .frames
            .get(at..at + L)
            .and_then(|s| <&[u16; L]>::try_from(s).ok())
        {
            Some(samples) if refs.len() == L => {
                for l in 0..L {
                    z[l] = samples[l] as f32 - offset[l];
                    brightest[l] = brightest[l].max(samples[l]);
                }
            }
            // The row's last, partial chunk.
            _ => {
                *z = [0.0; L];
                for l in 0..refs.len() {
                    let s = row.frames[at + l];
                    z[l] = s as f32 - offset[l];
                    brightest[l] = brightest[l].max(s);
                }
            }
        }
    }
    let saturation = saturation_code(row.bit_depth);
    core::array::from_fn(|l| brightest[l] >= saturation)
}

/// Decodes the pixels `x0..x0 + out.len()` (at most `L`) of a checked `row` into `out`.
#[inline(always)]
pub(super) fn decode_pixels<const L: usize, const K: usize>(
    decoder: &Decoder<'_>,
    transform: &CosineTransform<'_>,
    row: &Row<'_>,
    x0: usize,
    scratch: &mut [f32],
    out: &mut [PixelCandidates<K>],
) {
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
    let mut lights = PeakList::default();
    for group in plan.groups() {
        let saturated = load::<L>(plan, row, x0, group, &refs[..lanes], profile);
        // The scratch was sized for this transform: it cannot refuse it.
        if transform.inverse::<L>(profile, work).is_err() {
            return;
        }
        let noise: [f32; L] =
            core::array::from_fn(|l| profile_noise_dn(refs[l].sample_noise_dn, span as u16));
        let thresholds = noise.map(|n| plan.decoding.noise_factor * n);
        let lit = LitColumns::find::<L>(profile, &thresholds);
        for l in 0..lanes {
            let pixel = &mut out[l];
            if saturated[l] {
                pixel.flags.insert(PixelFlags::SATURATED);
            }
            search::find_lights(plan, profile, l, noise[l], &lit, background, &mut lights);
            let group_troubled =
                decoder.add_group(row, x0 + l, group, &lights, refs[l].sample_noise_dn, pixel);
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
    load::<1>(&decoder.plan, row, x, group, &refs, profile);
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
    load::<1>(&decoder.plan, row, x, group, &refs, profile);
    out.peaks.clear();
    if transform.inverse::<1>(profile, work).is_ok() {
        let noise = profile_noise_dn(refs[0].sample_noise_dn, span as u16);
        let lit = LitColumns::find::<1>(profile, &[decoder.plan.decoding.noise_factor * noise]);
        search::find_lights(&decoder.plan, profile, 0, noise, &lit, background, out);
    }
}
