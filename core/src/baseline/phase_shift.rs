//! The comparison baseline of paper §VII: phase shift with Gray-code unwrapping ("PS": 6 phase
//! offsets + 7 Gray codes), with its own plan type, decoded into the same [`PixelCandidates`]
//! as FSM so both go through one triangulation and selection path.
//!
//! Frames: dark, white, then `steps` fringes `P_k(c) = ½ + ½cos(2πc/T − 2πk/steps)` (paper eq. 1),
//! then `bits` frames of the complementary Gray code (Zhang et al.): bit `b` (most significant
//! first) of the Gray code of the half-period index `V = floor(2c/T)`. Its top `bits − 1` bits are
//! the Gray code of the period index `K₁ = floor(c/T)`, whose edges fall on the phase wrap; all
//! bits give `K₂ = floor((V + 1)/2) = floor((c + T/2)/T)`, whose edges fall half a period away.
//! With the phase `u` in turns, the period is `K₂` if `u < ¼`, `K₂ − 1` if `u > ¾` and `K₁`
//! otherwise: the code is only read far from its own edges, where blur cannot flip a bit.
//!
//! A pixel lit by two columns (direct and indirect light) sees the sum of two cosines of the same
//! frequency: a single phase between them (paper eq. 3). That is the failure FSM removes.

use core::fmt;

use super::{offer_light, PatternSequence, PixelDecoder};
use crate::candidate::{ColumnRange, PixelCandidates, PixelFlags};
use crate::noise::{amplitude_noise_dn, sample_noise_dn};
use crate::plan::SensorNoise;

/// A phase-shift + Gray-code scan.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PhaseShiftPlan {
    /// Projector columns `cmax`.
    pub projector_columns: u16,
    /// Fringe period `T` in columns.
    pub period_columns: u16,
    /// Phase offsets, `≥ 3` (the paper uses 6).
    pub steps: u8,
    /// Complementary Gray-code frames (the paper uses 7).
    pub bits: u8,
    /// A pixel's fringe modulation must exceed this (sensor DN) to be decoded.
    pub min_modulation_dn: f32,
    /// The camera's sensor: the noise a point's quality is measured in (only the scan reads
    /// it; plan files written before it have the default).
    #[cfg_attr(feature = "serde", serde(default))]
    pub sensor: SensorNoise,
}

/// A violated phase-shift plan rule.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // each field is the value the variant reports
pub enum PhaseShiftError {
    /// Fewer than 3 phase offsets cannot determine a phase.
    Steps { steps: u8 },
    /// The period must be at least 2 columns.
    Period { period_columns: u16 },
    /// `2^bits` half periods must cover the `cmax` columns.
    Bits { bits: u8, needed: u8 },
    /// A threshold must be a finite number, not below 0.
    Threshold { field: &'static str, value: f32 },
    /// The sensor's noise model ([`SensorNoise::check`]).
    Sensor { field: &'static str, value: f32 },
}

impl fmt::Display for PhaseShiftError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            PhaseShiftError::Steps { steps } => {
                write!(f, "steps = {steps}: at least 3 phase offsets are needed")
            }
            PhaseShiftError::Period { period_columns } => {
                write!(f, "period_columns = {period_columns}: the fringe period must be at least 2 columns")
            }
            PhaseShiftError::Bits { bits, needed } => write!(
                f,
                "bits = {bits}: the Gray code must count every period of the projector, {needed} bits needed"
            ),
            PhaseShiftError::Threshold { field, value } => {
                write!(f, "{field} = {value}: must be a finite number, not below 0")
            }
            PhaseShiftError::Sensor { field, value } => {
                write!(f, "{field} = {value}: {}", SensorNoise::RULE)
            }
        }
    }
}

/// What one frame of a phase-shift scan shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PhaseShiftPattern {
    /// Projector off.
    Dark,
    /// Every column full on.
    White,
    /// Fringe with phase offset `2π·step/steps`.
    Fringe {
        /// Offset index.
        step: u8,
    },
    /// Complementary Gray-code bit `bit` (0 = most significant) of the half-period index.
    Gray {
        /// Bit index, most significant first.
        bit: u8,
    },
}

impl PhaseShiftPlan {
    /// The paper's PS: 6 phase offsets and 7 Gray codes (6 for the 64 periods of 12 columns
    /// across 768 columns, and the complementary bit).
    pub fn paper() -> Self {
        PhaseShiftPlan {
            projector_columns: 768,
            period_columns: 12,
            steps: 6,
            bits: 7,
            min_modulation_dn: 2.0,
            sensor: SensorNoise::default(),
        }
    }

    /// The paper's fringes (period 12 columns, 6 offsets) on a projector of `columns` columns,
    /// with the Gray-code bits that count its half periods.
    pub fn for_projector(columns: u16) -> Self {
        let plan = PhaseShiftPlan {
            projector_columns: columns,
            ..Self::paper()
        };
        PhaseShiftPlan {
            bits: plan.bits_needed(),
            ..plan
        }
    }

    /// Gray-code bits that count every half period of the projector.
    pub fn bits_needed(&self) -> u8 {
        let half_periods =
            (2 * self.projector_columns as u32).div_ceil(self.period_columns.max(1) as u32);
        (u32::BITS - half_periods.saturating_sub(1).leading_zeros()) as u8
    }

    /// Checks the plan's rules.
    pub fn validate(&self) -> Result<(), PhaseShiftError> {
        if self.steps < 3 {
            return Err(PhaseShiftError::Steps { steps: self.steps });
        }
        if self.period_columns < 2 {
            return Err(PhaseShiftError::Period {
                period_columns: self.period_columns,
            });
        }
        let needed = self.bits_needed();
        if self.bits < needed || self.bits > 16 {
            return Err(PhaseShiftError::Bits {
                bits: self.bits,
                needed,
            });
        }
        let value = self.min_modulation_dn;
        if !(value.is_finite() && value >= 0.0) {
            return Err(PhaseShiftError::Threshold {
                field: "min_modulation_dn",
                value,
            });
        }
        self.sensor
            .check()
            .map_err(|(field, value)| PhaseShiftError::Sensor { field, value })
    }

    /// Frames in the sequence: dark, white, fringes, Gray codes.
    pub fn sequence_len(&self) -> usize {
        2 + self.steps as usize + self.bits as usize
    }

    /// The pattern of frame `index`.
    pub fn pattern(&self, index: usize) -> Option<PhaseShiftPattern> {
        let steps = self.steps as usize;
        match index {
            0 => Some(PhaseShiftPattern::Dark),
            1 => Some(PhaseShiftPattern::White),
            i if i < 2 + steps => Some(PhaseShiftPattern::Fringe {
                step: (i - 2) as u8,
            }),
            i if i < self.sequence_len() => Some(PhaseShiftPattern::Gray {
                bit: (i - 2 - steps) as u8,
            }),
            _ => None,
        }
    }

    /// Relative intensity of `pattern` at `column` (dark outside the projector).
    pub fn intensity(&self, pattern: PhaseShiftPattern, column: u32) -> f32 {
        if column >= self.projector_columns as u32 {
            return 0.0;
        }
        let t = self.period_columns as u64;
        match pattern {
            PhaseShiftPattern::Dark => 0.0,
            PhaseShiftPattern::White => 1.0,
            PhaseShiftPattern::Fringe { step } => {
                // 2π(c/T − k/steps), reduced exactly in integers: (c·steps − k·T) / (T·steps).
                let s = self.steps as u64;
                let turns =
                    ((column as u64 * s + (s - step as u64) * t) % (t * s)) as f64 / (t * s) as f64;
                (0.5 + 0.5 * libm::cos(core::f64::consts::TAU * turns)) as f32
            }
            PhaseShiftPattern::Gray { bit } => {
                let index = 2 * column as u64 / t;
                let gray = index ^ (index >> 1);
                let shift = self.bits - 1 - bit;
                ((gray >> shift) & 1) as f32
            }
        }
    }

    /// CRC-64/XZ of the plan's fields, little-endian after the tag `PS`: the identity candidate
    /// files of its decodes carry (distinct from every FSM plan's, whose bytes never start so).
    /// Not the sensor, which no candidate depends on (it only scales the points' quality).
    pub fn fingerprint(&self) -> u64 {
        let mut bytes = [0u8; 12];
        bytes[..2].copy_from_slice(b"PS");
        bytes[2..4].copy_from_slice(&self.projector_columns.to_le_bytes());
        bytes[4..6].copy_from_slice(&self.period_columns.to_le_bytes());
        bytes[6] = self.steps;
        bytes[7] = self.bits;
        bytes[8..12].copy_from_slice(&self.min_modulation_dn.to_le_bytes());
        crate::wire::crc64(&bytes)
    }

    /// The fingerprint of the frames alone ([`crate::wire::pattern_fingerprint`], tag
    /// `PS`): the columns, the fringe period, the steps and the Gray code bits; not
    /// `min_modulation_dn`, which only the decoder reads, nor the sensor, which only the scan
    /// reads.
    pub fn pattern_fingerprint(&self) -> u64 {
        let mut fields = [0u8; 6];
        fields[..2].copy_from_slice(&self.projector_columns.to_le_bytes());
        fields[2..4].copy_from_slice(&self.period_columns.to_le_bytes());
        fields[4] = self.steps;
        fields[5] = self.bits;
        crate::wire::pattern_fingerprint(b"PS", &fields)
    }

    /// `(sin θ_k, cos θ_k)` of offset `k`, `θ_k = 2πk/steps`.
    fn offset(&self, k: usize) -> (f32, f32) {
        let a = core::f64::consts::TAU * k as f64 / self.steps as f64;
        (libm::sin(a) as f32, libm::cos(a) as f32)
    }
}

impl PatternSequence for PhaseShiftPlan {
    fn projector_columns(&self) -> u16 {
        self.projector_columns
    }

    fn frame_count(&self) -> usize {
        self.sequence_len()
    }

    fn pattern_count(&self) -> usize {
        self.sequence_len() - 2
    }

    fn frame_intensity(&self, frame: usize, column: u32) -> f32 {
        self.pattern(frame)
            .map_or(0.0, |p| self.intensity(p, column))
    }

    fn fingerprint(&self) -> u64 {
        PhaseShiftPlan::fingerprint(self)
    }

    fn pattern_fingerprint(&self) -> u64 {
        PhaseShiftPlan::pattern_fingerprint(self)
    }
}

impl PixelDecoder for PhaseShiftPlan {
    /// The modulation of `steps` samples.
    fn dark_amplitude_noise_dn(&self, bit_depth: u8) -> f32 {
        let sample = sample_noise_dn(&self.sensor, bit_depth, 0.0);
        amplitude_noise_dn(sample, self.steps as usize)
    }

    /// One candidate (column, fringe modulation), or none when the modulation is below
    /// `min_modulation_dn` or the Gray code points outside `range`.
    fn decode_pixel<const K: usize>(
        &self,
        samples: impl Fn(usize) -> u16,
        saturation: u16,
        range: &ColumnRange,
        out: &mut PixelCandidates<K>,
    ) {
        out.clear();
        let steps = self.steps as usize;
        let (dark, white) = (samples(0) as f32, samples(1) as f32);
        let (mut re, mut im) = (0.0f32, 0.0f32);
        let mut saturated = samples(0) >= saturation || samples(1) >= saturation;
        for k in 0..steps {
            let s = samples(2 + k);
            saturated |= s >= saturation;
            let (sin, cos) = self.offset(k);
            re += s as f32 * cos;
            im += s as f32 * sin;
        }
        if saturated {
            out.flags.insert(PixelFlags::SATURATED);
        }
        // Σ I_k e^{iθ_k} = (steps/2)·B·e^{iφ}, φ = 2πc/T.
        let modulation = 2.0 * crate::math::sqrt(re * re + im * im) / steps as f32;
        if modulation <= self.min_modulation_dn {
            return;
        }
        let mut turns = libm::atan2f(im, re) / core::f32::consts::TAU;
        if turns < 0.0 {
            turns += 1.0;
        }
        let threshold = 0.5 * (dark + white);
        let mut gray = 0u32;
        for b in 0..self.bits as usize {
            let s = samples(2 + steps + b);
            gray = (gray << 1) | (s as f32 > threshold) as u32;
        }
        let mut half = gray;
        let mut shift = 1;
        while shift < 32 {
            half ^= half >> shift;
            shift <<= 1;
        }
        let (k1, k2) = ((half >> 1) as f32, ((half + 1) >> 1) as f32);
        let whole = if turns < 0.25 {
            k2
        } else if turns > 0.75 {
            k2 - 1.0
        } else {
            k1
        };
        let column = (whole + turns) * self.period_columns as f32;
        offer_light(out, range, column, modulation);
    }
}
