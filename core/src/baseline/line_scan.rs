//! Line scanning ("LS", paper §VIII-F and Fig. 13): the projector lights one column per frame,
//! so a pixel's samples over the frames *are* its column profile, and each light is a temporal
//! peak located to a sub-column by a peak detector (Fisher & Naidu, the paper's refs. \[31\],
//! \[32\]). BFSM shows as many patterns; its profile (SPEC §2b) spreads each column's light over
//! every frame, so its noise per column is `√(2/span)` of a sample's, where LS's is a whole
//! sample's.
//!
//! Frames: dark, white, then frame `2 + j` lights column `j` alone.
//!
//! Choices the paper leaves open (`docs/comparison.md`): every temporal peak that stands out
//! of its surroundings is a candidate (strongest first, as FSM's), not only the brightest, so
//! the selection chooses the direct one as it does for FSM. A peak stands out when it exceeds
//! its surroundings by `noise_factor` times the noise of a sample (the sensor's, SPEC §2b): for
//! a narrow light the lowest samples within [`PEAK_SURROUNDINGS`] columns on each side (so a
//! direct light on a broad glossy lobe is measured above the lobe, and the lobe's noise makes
//! no light), for a wide one (a flat top several columns across) the columns past its half
//! height.

use core::fmt;

use super::{offer_light, PatternSequence, PixelDecoder};
use crate::candidate::{ColumnRange, PixelCandidates, PixelFlags};
use crate::math::{ln, sqrt};
use crate::noise::{amplitude_noise_dn, sample_noise_dn};
use crate::plan::SensorNoise;
use crate::search::cosine::RIPPLE_DEPTH;

/// Columns on each side of a temporal peak that it must stand out of, and that a stronger
/// sample suppresses it within: about two footprints of a focused pixel.
pub const PEAK_SURROUNDINGS: usize = 3;

/// Most columns on each side of a peak the [`LineDetector::Auto`] centre of mass takes.
pub const MAX_RUN: usize = 16;

/// A line-scanning plan.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct LineScanPlan {
    /// Projector columns `cmax`: one frame each.
    pub projector_columns: u16,
    /// Sub-column peak detector.
    pub detector: LineDetector,
    /// A peak must stand out of its surroundings by this many times a sample's noise RMS.
    pub noise_factor: f32,
    /// The camera's sensor: the noise a peak is judged against.
    pub sensor: SensorNoise,
}

/// Sub-column location of a temporal peak from the samples around it (Fisher & Naidu).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum LineDetector {
    /// The Gaussian for a light at most 3 columns wide at half its height; for a wider one
    /// (a camera pixel that sees several columns) the centre of mass of the run of columns
    /// around the peak above 3 noise RMS, which a 3-point fit on a flat top would bias.
    Auto,
    /// A Gaussian through the peak and its two neighbours (exact for a Gaussian spot); the
    /// centre of mass of the three where a neighbour is within 3 noise RMS of the
    /// surroundings (a light narrower than a column).
    Gaussian,
    /// Centre of mass of `points` samples around the peak (3, 5 or 7).
    CentreOfMass {
        /// Samples used, odd.
        points: u8,
    },
}

/// A violated line-scanning plan rule.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // each field is the value the variant reports
pub enum LineScanError {
    /// A peak needs a column on each side.
    Columns { projector_columns: u16 },
    /// The centre of mass takes 3, 5 or 7 samples.
    DetectorPoints { points: u8 },
    /// The noise factor must be positive and finite.
    NoiseFactor { noise_factor: f32 },
    /// The sensor's noise model: a finite full-scale charge above 0, a finite read noise not
    /// below 0.
    Sensor { field: &'static str, value: f32 },
}

impl fmt::Display for LineScanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            LineScanError::Columns { projector_columns } => write!(
                f,
                "projector_columns = {projector_columns}: line scanning needs at least 3 columns"
            ),
            LineScanError::DetectorPoints { points } => write!(
                f,
                "detector points = {points}: the centre of mass takes 3, 5 or 7 samples"
            ),
            LineScanError::NoiseFactor { noise_factor } => write!(
                f,
                "noise_factor = {noise_factor}: must be a positive number"
            ),
            LineScanError::Sensor { field, value } => {
                write!(f, "{field} = {value}: {}", SensorNoise::RULE)
            }
        }
    }
}

impl LineScanPlan {
    /// The paper's comparison (Fig. 13): one frame per column of its 768-column projector, as
    /// many patterns as BFSM; the Gaussian detector, or the centre of mass for wide lights.
    pub fn paper() -> Self {
        LineScanPlan {
            projector_columns: 768,
            detector: LineDetector::Auto,
            noise_factor: 6.0,
            sensor: SensorNoise::default(),
        }
    }

    /// Checks the plan's rules.
    pub fn validate(&self) -> Result<(), LineScanError> {
        if self.projector_columns < 3 {
            return Err(LineScanError::Columns {
                projector_columns: self.projector_columns,
            });
        }
        if let LineDetector::CentreOfMass { points } = self.detector {
            if !matches!(points, 3 | 5 | 7) {
                return Err(LineScanError::DetectorPoints { points });
            }
        }
        if !(self.noise_factor.is_finite() && self.noise_factor > 0.0) {
            return Err(LineScanError::NoiseFactor {
                noise_factor: self.noise_factor,
            });
        }
        self.sensor
            .check()
            .map_err(|(field, value)| LineScanError::Sensor { field, value })?;
        Ok(())
    }

    /// Frames in the sequence: dark, white, one per column.
    pub fn sequence_len(&self) -> usize {
        2 + self.projector_columns as usize
    }

    /// CRC-64/XZ of the plan's fields, little-endian after the tag `LS`: the identity row dumps
    /// of its captures carry (distinct from every FSM plan's, whose bytes never start so).
    pub fn fingerprint(&self) -> u64 {
        let mut bytes = [0u8; 17];
        bytes[..2].copy_from_slice(b"LS");
        bytes[2..4].copy_from_slice(&self.projector_columns.to_le_bytes());
        bytes[4] = match self.detector {
            LineDetector::Gaussian => 0,
            LineDetector::CentreOfMass { points } => points,
            LineDetector::Auto => 1,
        };
        bytes[5..9].copy_from_slice(&self.noise_factor.to_le_bytes());
        bytes[9..13].copy_from_slice(&self.sensor.full_scale_electrons.to_le_bytes());
        bytes[13..17].copy_from_slice(&self.sensor.read_noise_electrons.to_le_bytes());
        crate::wire::crc64(&bytes)
    }

    /// The fingerprint of the frames alone ([`crate::wire::pattern_fingerprint`], tag
    /// `LS`): the columns (dark, white, one lit column per frame); not the
    /// detector or its noise settings.
    pub fn pattern_fingerprint(&self) -> u64 {
        crate::wire::pattern_fingerprint(b"LS", &self.projector_columns.to_le_bytes())
    }

    /// The sub-column offset of the peak at `j` (`v(j)` above the surroundings' level) of a
    /// light more than 3 columns wide at half height or not (`wide`); the Gaussian needs both
    /// neighbours above `floor` (a few noise RMS): the log of a neighbour lost in the noise
    /// would decide the offset, where the centre of mass weighs it little.
    fn offset(&self, v: impl Fn(usize) -> f32, j: usize, floor: f32, wide: bool) -> f32 {
        let last = self.projector_columns as usize - 1;
        let centre_of_mass = |half: usize| {
            let (mut sum, mut moment) = (0.0f32, 0.0f32);
            for k in j.saturating_sub(half)..=(j + half).min(last) {
                let w = v(k).max(0.0);
                sum += w;
                moment += w * (k as f32 - j as f32);
            }
            if sum > 0.0 {
                moment / sum
            } else {
                0.0
            }
        };
        let gaussian = || {
            if j > 0 && j < last {
                let (l, c, r) = (v(j - 1), v(j), v(j + 1));
                if l > floor && r > floor {
                    let (ll, lc, lr) = (ln(l), ln(c), ln(r));
                    let d = 2.0 * (ll - 2.0 * lc + lr);
                    if d < 0.0 {
                        return ((ll - lr) / d).clamp(-0.5, 0.5);
                    }
                }
            }
            centre_of_mass(1)
        };
        match self.detector {
            LineDetector::Gaussian => gaussian(),
            LineDetector::CentreOfMass { points } => centre_of_mass(points as usize / 2),
            LineDetector::Auto => {
                if !wide {
                    return gaussian();
                }
                // The run of columns above the floor, at most MAX_RUN on each side.
                let (mut lo, mut hi) = (j, j);
                while lo > 0 && j - lo < MAX_RUN && v(lo - 1) > floor {
                    lo -= 1;
                }
                while hi < last && hi - j < MAX_RUN && v(hi + 1) > floor {
                    hi += 1;
                }
                let (mut sum, mut moment) = (0.0f32, 0.0f32);
                for k in lo..=hi {
                    let w = v(k);
                    sum += w;
                    moment += w * (k as f32 - j as f32);
                }
                moment / sum
            }
        }
    }
}

impl PatternSequence for LineScanPlan {
    fn projector_columns(&self) -> u16 {
        self.projector_columns
    }

    fn frame_count(&self) -> usize {
        self.sequence_len()
    }

    fn pattern_count(&self) -> usize {
        self.projector_columns as usize
    }

    fn frame_intensity(&self, frame: usize, column: u32) -> f32 {
        match frame {
            0 => 0.0,
            1 => (column < self.projector_columns as u32) as u32 as f32,
            f => (f - 2 == column as usize) as u32 as f32,
        }
    }

    fn fingerprint(&self) -> u64 {
        LineScanPlan::fingerprint(self)
    }

    fn pattern_fingerprint(&self) -> u64 {
        LineScanPlan::pattern_fingerprint(self)
    }
}

impl PixelDecoder for LineScanPlan {
    /// A peak's height: one sample over the lowest of its surroundings.
    fn dark_amplitude_noise_dn(&self, bit_depth: u8) -> f32 {
        amplitude_noise_dn(sample_noise_dn(&self.sensor, bit_depth, 0.0), 1)
    }

    /// Every temporal peak that stands out of its surroundings by `noise_factor` times a
    /// sample's noise (at the peak's level), its column from the detector, its amplitude the
    /// height above the surroundings (DN); strongest first, at most `K`.
    fn decode_pixel<const K: usize>(
        &self,
        samples: impl Fn(usize) -> u16,
        saturation: u16,
        range: &ColumnRange,
        out: &mut PixelCandidates<K>,
    ) {
        out.clear();
        let columns = self.projector_columns as usize;
        let dark = samples(0) as f32;
        let value = |j: usize| samples(2 + j) as f32 - dark;
        let saturated =
            samples(0) >= saturation || (0..columns).any(|j| samples(2 + j) >= saturation);
        if saturated {
            out.flags.insert(PixelFlags::SATURATED);
        }
        // The bit depth the noise model needs, from the saturation code `2^bits − 1`.
        let bit_depth = (u16::BITS - saturation.leading_zeros()) as u8;
        let dark_noise = sample_noise_dn(&self.sensor, bit_depth, 0.0);
        let r = PEAK_SURROUNDINGS;
        let low = |ks: core::ops::Range<usize>| ks.map(value).fold(f32::INFINITY, f32::min);
        // The levels around columns `a..=b`: the lowest samples within `r` columns on each
        // side (past the projector's edges, the dark level), lower first.
        let surroundings = |a: usize, b: usize| {
            let left = if a >= r { low(a - r..a) } else { 0.0 };
            let right = if b + r < columns {
                low(b + 1..b + r + 1)
            } else {
                0.0
            };
            (left.min(right).max(0.0), left.max(right).max(0.0))
        };
        for j in 0..columns {
            let peak = value(j);
            let (lo, hi) = (j.saturating_sub(r), (j + r).min(columns - 1));
            // A peak is the first of the largest samples within `r` columns.
            if (lo..j).any(|k| value(k) >= peak) || (j + 1..=hi).any(|k| value(k) > peak) {
                continue;
            }
            let noise = sqrt(
                dark_noise * dark_noise + {
                    let s = sample_noise_dn(&self.sensor, bit_depth, peak);
                    s * s
                },
            );
            let threshold = self.noise_factor * noise;
            // The columns next to `j` above half its height over `level`, on each side.
            let half_run = |level: f32| {
                let half = level + 0.5 * (peak - level);
                let a = (1..=MAX_RUN)
                    .take_while(|&d| j >= d && value(j - d) > half)
                    .count();
                let b = (1..=MAX_RUN)
                    .take_while(|&d| j + d < columns && value(j + d) > half)
                    .count();
                (j - a, j + b)
            };
            // A narrow light (at most 3 columns at half height over the lower side) stands out
            // of the columns next to it on both sides, also on a broad lobe; a wide one (a
            // flat top several columns across, whose edge would stand out of its own top on
            // one side) out of those past its half height over the dark level. A bump of less
            // than RIPPLE_DEPTH of the peak is the uneven top of a wide light, not a light.
            let (lower, higher) = surroundings(j, j);
            let (a, b) = half_run(lower);
            let wide = !(b - a < 3 && peak - higher > threshold.max(RIPPLE_DEPTH * peak));
            let base = if !wide {
                higher
            } else {
                let (a, b) = half_run(0.0);
                // The first of the light's largest samples is its peak.
                if (a..j).any(|k| value(k) >= peak) || (j + 1..=b).any(|k| value(k) > peak) {
                    continue;
                }
                surroundings(a, b).1
            };
            if peak - base <= threshold {
                continue;
            }
            let height = peak - base;
            let column = j as f32 + self.offset(|k| value(k) - base, j, 3.0 * noise, wide);
            offer_light(out, range, column, height);
        }
        out.sort();
        for (rank, c) in out.candidates.iter_mut().enumerate() {
            c.peak = rank.min(u8::MAX as usize) as u8;
        }
    }
}
