//! Micro Phase Shifting ("MPS", Gupta & Nayar, CVPR 2012; the paper's ref. \[15\]): every
//! fringe has a high frequency, all within a narrow band, so that interreflected and defocused
//! light, which blur high frequencies alike, leave one offset and one amplitude for all of them.
//! With `F` frequencies that leaves `F + 2` unknowns, and `F + 2` frames: the first frequency
//! at three phase offsets, each other once.
//!
//! Decoding (their §4): the three frames of the first frequency give the offset `O`, the
//! amplitude `A` and the full phase `φ₁`; each other frame gives `cos φ_f = (I_f − O)/A`. The
//! column is `(φ₁/2π + k)·λ₁` for the period index `k` whose predicted `cos(2πc/λ_f)` match the
//! measured ones best: the Chinese-remainder unwrapping of the frequencies, done as a search
//! over the `cmax/λ₁` period indices so that it degrades gracefully with noise.
//!
//! Choices the published method leaves to the user: the paper's "16–15" group is read as a
//! mean period of 16 columns and 15 frequencies (17 frames); the periods are spread evenly over
//! 14–18 columns, the mean first (the widest band whose codes [`MicroPhaseShiftPlan::paper`]
//! checks stay apart, see the tests). A pixel whose measured cosines are off the best code by
//! more than `max_code_residual` RMS (a mixture of lights, the failure the paper shows in
//! Figs. 9–10) gets no candidate.

use core::fmt;

use super::{offer_light, PatternSequence, PixelDecoder};
use crate::candidate::{ColumnRange, PixelCandidates, PixelFlags};
use crate::math::{cos64, floor, sqrt};
use crate::noise::{amplitude_noise_dn, sample_noise_dn};
use crate::plan::SensorNoise;

/// Most frequencies a plan holds (the frames are `frequencies + 2`).
pub const MAX_FREQUENCIES: usize = 16;

/// A Micro Phase Shifting plan.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct MicroPhaseShiftPlan {
    /// Projector columns `cmax`.
    pub projector_columns: u16,
    /// Fringe periods in columns, the first `frequencies` used; the first is shown at three
    /// phase offsets, each other once.
    pub periods_columns: [f32; MAX_FREQUENCIES],
    /// Frequencies used, `2..=MAX_FREQUENCIES`.
    pub frequencies: u8,
    /// A pixel's fringe amplitude must exceed this (sensor DN) to be decoded.
    pub min_modulation_dn: f32,
    /// Largest RMS difference between the measured cosines and the best code's.
    pub max_code_residual: f32,
    /// The camera's sensor: the noise a point's quality is measured in (only the scan reads
    /// it; plan files written before it have the default).
    #[cfg_attr(feature = "serde", serde(default))]
    pub sensor: SensorNoise,
}

/// A violated Micro Phase Shifting plan rule.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // each field is the value the variant reports
pub enum MicroPhaseShiftError {
    /// Outside `2..=MAX_FREQUENCIES`.
    Frequencies { frequencies: u8 },
    /// A period of at least 2 columns, and no longer than the projector.
    Period { index: u8, period_columns: f32 },
    /// Two frequencies share a period: their frames say the same.
    RepeatedPeriod { index: u8 },
    /// A threshold must be a finite number, not below 0.
    Threshold { field: &'static str, value: f32 },
    /// The sensor's noise model ([`SensorNoise::check`]).
    Sensor { field: &'static str, value: f32 },
}

impl fmt::Display for MicroPhaseShiftError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            MicroPhaseShiftError::Frequencies { frequencies } => write!(
                f,
                "frequencies = {frequencies}: Micro Phase Shifting takes 2 to {MAX_FREQUENCIES}"
            ),
            MicroPhaseShiftError::Period {
                index,
                period_columns,
            } => write!(
                f,
                "periods_columns[{index}] = {period_columns}: a period is 2 columns or more and at most the projector's width"
            ),
            MicroPhaseShiftError::RepeatedPeriod { index } => write!(
                f,
                "periods_columns[{index}] repeats an earlier period: every frequency must differ"
            ),
            MicroPhaseShiftError::Threshold { field, value } => {
                write!(f, "{field} = {value}: must be a finite number, not below 0")
            }
            MicroPhaseShiftError::Sensor { field, value } => {
                write!(f, "{field} = {value}: {}", SensorNoise::RULE)
            }
        }
    }
}

impl MicroPhaseShiftPlan {
    /// The paper's "16–15" group for its 768-column projector: 15 periods spread evenly over
    /// 14–18 columns, the mean (16) first; 17 frames.
    pub fn paper() -> Self {
        Self::spread(768, 16.0, 4.0, 15)
    }

    /// `frequencies` periods spread evenly over `mean ± band/2` columns, the mean first (it is
    /// the one shown at three offsets) and the others in increasing order.
    pub fn spread(projector_columns: u16, mean: f32, band: f32, frequencies: u8) -> Self {
        let n = (frequencies as usize).clamp(1, MAX_FREQUENCIES);
        let mut periods_columns = [0.0f32; MAX_FREQUENCIES];
        periods_columns[0] = mean;
        // The other n − 1 periods: n evenly spaced values over the band, the one nearest the
        // mean left out.
        let step = band / (n - 1).max(1) as f32;
        let nearest = ((n - 1) as f32 / 2.0 + 0.5) as usize;
        let mut at = 1;
        for k in 0..n {
            if k != nearest && at < n {
                periods_columns[at] = mean - band / 2.0 + step * k as f32;
                at += 1;
            }
        }
        MicroPhaseShiftPlan {
            projector_columns,
            periods_columns,
            frequencies: n as u8,
            min_modulation_dn: 2.0,
            max_code_residual: 0.35,
            sensor: SensorNoise::default(),
        }
    }

    /// Checks the plan's rules.
    pub fn validate(&self) -> Result<(), MicroPhaseShiftError> {
        if !(2..=MAX_FREQUENCIES as u8).contains(&self.frequencies) {
            return Err(MicroPhaseShiftError::Frequencies {
                frequencies: self.frequencies,
            });
        }
        let periods = self.periods();
        for (i, &p) in periods.iter().enumerate() {
            if !(p.is_finite() && p >= 2.0 && p <= self.projector_columns as f32) {
                return Err(MicroPhaseShiftError::Period {
                    index: i as u8,
                    period_columns: p,
                });
            }
            if periods[..i].contains(&p) {
                return Err(MicroPhaseShiftError::RepeatedPeriod { index: i as u8 });
            }
        }
        for (field, value) in [
            ("min_modulation_dn", self.min_modulation_dn),
            ("max_code_residual", self.max_code_residual),
        ] {
            if !(value.is_finite() && value >= 0.0) {
                return Err(MicroPhaseShiftError::Threshold { field, value });
            }
        }
        self.sensor
            .check()
            .map_err(|(field, value)| MicroPhaseShiftError::Sensor { field, value })
    }

    /// The periods in use.
    pub fn periods(&self) -> &[f32] {
        &self.periods_columns[..(self.frequencies as usize).min(MAX_FREQUENCIES)]
    }

    /// Frames in the sequence: `frequencies + 2` fringes, no reference frame.
    pub fn sequence_len(&self) -> usize {
        self.periods().len() + 2
    }

    /// `(frequency index, phase offset in turns)` of frame `frame`: what it shows is
    /// `½ + ½cos(2π(c/λ + offset))` with `λ = periods()[index]`.
    pub fn frame(&self, frame: usize) -> Option<(usize, f64)> {
        match frame {
            0..=2 => Some((0, frame as f64 / 3.0)),
            f if f < self.sequence_len() => Some((f - 2, 0.0)),
            _ => None,
        }
    }

    /// CRC-64/XZ of the plan's fields, little-endian after the tag `MP`: the identity candidate
    /// files of its decodes carry (distinct from every FSM plan's, whose bytes never start so).
    /// Not the sensor, which no candidate depends on (it only scales the points' quality).
    pub fn fingerprint(&self) -> u64 {
        let mut bytes = [0u8; 13 + 4 * MAX_FREQUENCIES];
        bytes[..2].copy_from_slice(b"MP");
        bytes[2..4].copy_from_slice(&self.projector_columns.to_le_bytes());
        bytes[4] = self.frequencies;
        bytes[5..9].copy_from_slice(&self.min_modulation_dn.to_le_bytes());
        bytes[9..13].copy_from_slice(&self.max_code_residual.to_le_bytes());
        for (i, p) in self.periods().iter().enumerate() {
            bytes[13 + 4 * i..17 + 4 * i].copy_from_slice(&p.to_le_bytes());
        }
        crate::wire::crc64(&bytes)
    }

    /// The fingerprint of the frames alone ([`crate::wire::pattern_fingerprint`], tag
    /// `MP`): the columns and the fringe periods; not the decoder's
    /// `min_modulation_dn` and `max_code_residual`, nor the sensor.
    pub fn pattern_fingerprint(&self) -> u64 {
        let mut fields = [0u8; 3 + 4 * MAX_FREQUENCIES];
        fields[..2].copy_from_slice(&self.projector_columns.to_le_bytes());
        fields[2] = self.frequencies;
        for (i, p) in self.periods().iter().enumerate() {
            fields[3 + 4 * i..7 + 4 * i].copy_from_slice(&p.to_le_bytes());
        }
        crate::wire::pattern_fingerprint(b"MP", &fields)
    }
}

/// `cos(2π·turns)`, with `turns` reduced to `[0, 1)` in `f64` first so that large columns keep
/// their precision.
fn cos_turns(turns: f64) -> f32 {
    let t = turns - libm::floor(turns);
    cos64(core::f64::consts::TAU * t) as f32
}

impl PatternSequence for MicroPhaseShiftPlan {
    fn projector_columns(&self) -> u16 {
        self.projector_columns
    }

    fn frame_count(&self) -> usize {
        self.sequence_len()
    }

    /// `½ + ½cos(2πc/λ_f + 2π·offset)`.
    fn frame_intensity(&self, frame: usize, column: u32) -> f32 {
        if column >= self.projector_columns as u32 {
            return 0.0;
        }
        self.frame(frame).map_or(0.0, |(f, offset)| {
            let turns = column as f64 / self.periods()[f] as f64 + offset;
            0.5 + 0.5 * cos_turns(turns)
        })
    }

    fn fingerprint(&self) -> u64 {
        MicroPhaseShiftPlan::fingerprint(self)
    }

    fn pattern_fingerprint(&self) -> u64 {
        MicroPhaseShiftPlan::pattern_fingerprint(self)
    }
}

impl PixelDecoder for MicroPhaseShiftPlan {
    /// The amplitude of the first frequency's three phase steps.
    fn dark_amplitude_noise_dn(&self, bit_depth: u8) -> f32 {
        amplitude_noise_dn(sample_noise_dn(&self.sensor, bit_depth, 0.0), 3)
    }

    /// One candidate (column, fringe amplitude), or none when the amplitude is below
    /// `min_modulation_dn`, the best code is further than `max_code_residual`, or its column
    /// lies outside `range`.
    fn decode_pixel<const K: usize>(
        &self,
        samples: impl Fn(usize) -> u16,
        saturation: u16,
        range: &ColumnRange,
        out: &mut PixelCandidates<K>,
    ) {
        out.clear();
        let periods = self.periods();
        if (0..self.sequence_len()).any(|i| samples(i) >= saturation) {
            out.flags.insert(PixelFlags::SATURATED);
        }
        // Three offsets of the first frequency: I_k = O + A·cos(φ₁ + 2πk/3).
        let i = [samples(0) as f32, samples(1) as f32, samples(2) as f32];
        let offset = (i[0] + i[1] + i[2]) / 3.0;
        // Σ I_k·e^{−i2πk/3} = (3/2)·A·e^{iφ₁}; cos(2π/3) = −½, sin(2π/3) = √3/2.
        let half_root3 = 0.866_025_4f32;
        let re = i[0] - 0.5 * (i[1] + i[2]);
        let im = half_root3 * (i[2] - i[1]);
        let amplitude = 2.0 / 3.0 * sqrt(re * re + im * im);
        if amplitude <= self.min_modulation_dn {
            return;
        }
        let mut turns = libm::atan2f(im, re) / core::f32::consts::TAU;
        if turns < 0.0 {
            turns += 1.0;
        }
        let first = periods[0];
        let mut measured = [0.0f32; MAX_FREQUENCIES];
        for (f, m) in measured.iter_mut().enumerate().take(periods.len()).skip(1) {
            *m = ((samples(2 + f) as f32 - offset) / amplitude).clamp(-1.0, 1.0);
        }
        // Every period index whose column falls on the projector (from −1: a column just left
        // of 0 has a phase just under a whole turn), the best code kept.
        let indices = floor(self.projector_columns as f32 / first) as i32 + 1;
        let (mut best, mut best_cost) = (f32::NAN, f32::INFINITY);
        for k in -1..=indices {
            let column = (turns + k as f32) * first;
            if column < -0.5 {
                continue;
            }
            if column > self.projector_columns as f32 - 0.5 {
                break;
            }
            let mut cost = 0.0f32;
            for (f, &period) in periods.iter().enumerate().skip(1) {
                let d = measured[f] - cos_turns(column as f64 / period as f64);
                cost += d * d;
            }
            if cost < best_cost {
                (best, best_cost) = (column, cost);
            }
        }
        let residual = sqrt(best_cost / (periods.len() - 1) as f32);
        // A NaN residual (no period index on the projector) is no match either.
        let matched = residual
            .partial_cmp(&self.max_code_residual)
            .is_some_and(|o| o.is_le());
        if matched {
            offer_light(out, range, best, amplitude);
        }
    }
}
