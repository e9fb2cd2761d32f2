//! The scan plan: every parameter of one FSM scan, shared by pattern generation, the simulator,
//! the decoder and the camera (SPEC §2–§3).
//!
//! Frequencies are stored exactly, as harmonics of a base period `L` (in projector columns):
//! fringe `m` has `f_m = (n₁ + m) / L` cycles per column, so `Δf = 1/L` (paper eq. 5) and the
//! Nyquist rule of eq. 7, `Δf ≤ 1/(2·span)`, reads `L ≥ 2·span`, where the span is `cmax` for
//! BFSM and the block width `cB` for EFSM. Integer harmonics keep pattern values, the decoder's
//! kernel and the bin → column map exact and identical on every machine.

use core::fmt;

pub mod sequence;

use sequence::Group;

/// Smallest supported transform size `N`.
pub const MIN_TRANSFORM_SIZE: usize = 64;
/// Largest supported transform size `N`.
pub const MAX_TRANSFORM_SIZE: usize = 4096;
/// Largest kernel table (complex entries) a plan may need; see [`ScanPlan::kernel_table_len`].
pub const MAX_KERNEL_TABLE_LEN: usize = 16384;
/// Most peaks the decoder reports from one spectrum (one group of one pixel).
pub const MAX_PEAKS: usize = 8;
/// Most projector columns a plan may address.
pub const MAX_PROJECTOR_COLUMNS: u16 = 16384;
/// Fewest fringe patterns of a group: below this the noise estimate of a pixel is meaningless.
pub const MIN_FRINGE_COUNT: u16 = 16;
/// Fewest fringes of a plan decoded with the local-maximum search: with fewer, a light's main
/// lobe (four resolution steps with Hann) and its blur fill most of the spectrum, and no bins
/// beside it measure the noise.
pub const LOCAL_MAXIMA_MIN_FRINGES: u16 = 32;

/// One complete scan: what the projector shows and what the decoder assumes.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct ScanPlan {
    /// `cmax`: number of projector columns; columns are `0..cmax` (SPEC §1).
    pub projector_columns: u16,
    /// Fringe frequencies of each group (eqs. 5, 7, 8).
    pub band: FringeBand,
    /// `N`: size of the zero-padded real DFT, a power of two in `64..=4096`, `N ≥ M`.
    pub transform_size: u16,
    /// BFSM, or EFSM with its block coding.
    pub method: Method,
    /// Pattern offset `PA` and modulation `PB`, as fractions of full projector output.
    pub levels: PatternLevels,
    /// Which reference frames precede the patterns.
    pub references: References,
    /// How the decoder turns spectra into candidates.
    pub decoding: DecodeSettings,
}

/// The fringe frequencies of one group: `f_m = (first_harmonic + m) / period_columns`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct FringeBand {
    /// `L = 1/Δf` in projector columns; eq. 7 requires `L ≥ 2·span`.
    pub period_columns: u32,
    /// `n₁ ≥ 1`: the first frequency is `f₁ = n₁/L`.
    pub first_harmonic: u32,
    /// `M` (BFSM) or `M̃` (EFSM, per group): number of fringe patterns.
    pub count: u16,
}

/// Baseline or encoded FSM.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Method {
    /// Paper §III: fringes span all `cmax` columns.
    Bfsm,
    /// Paper §IV: fringes repeat every `cB` columns, mask patterns resolve the block.
    Efsm(BlockCoding),
}

/// EFSM parameters (paper §IV, SPEC §3).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct BlockCoding {
    /// `cB`: block width in columns, even.
    pub block_width: u16,
    /// One group, or two with the second shifted by `cB/2`.
    pub groups: GroupCount,
    /// `cg ∈ (0, cB/4]`: peaks with local column outside `[cg, cB − cg]` are discarded.
    pub border_guard: f32,
}

/// Number of EFSM pattern groups.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum GroupCount {
    /// Group 1 only (`M̃ + NB` patterns).
    One,
    /// Groups 1 and 2 (the second shifted by `cB/2`).
    Two,
}

/// `P(c) = PA + PB·cos(…)` (eqs. 4, 14), in fractions of the projector's full output.
/// `PB` is at least [`MIN_LEVEL_AMPLITUDE`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct PatternLevels {
    /// `PA`.
    pub offset: f32,
    /// `PB`.
    pub amplitude: f32,
}

/// Smallest `PB`: a fringe a millionth of the projector's output deep carries no signal, and
/// keeping every level normal keeps the decoder's values away from subnormal floats, which the
/// camera's NEON unit flushes to zero where the host keeps them
/// (`transform/simd.rs`).
pub const MIN_LEVEL_AMPLITUDE: f32 = 1e-6;

/// Reference frames shown before the patterns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct References {
    /// An all-off frame: the level `I_min` of the EFSM block decisions starts from it.
    pub dark: bool,
    /// An all-on frame: albedo and saturation of every pixel.
    pub white: bool,
}

/// Weighting of the fringe samples before the DFT.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Window {
    /// No window: narrowest peaks, sidelobes at −13 dB (removed by the peak search, SPEC §2).
    Rectangular,
    /// Symmetric Hann window: sidelobes at −31 dB, main lobe twice as wide.
    Hann,
}

/// Sub-pixel peak position estimator (SPEC §2).
///
/// The default is [`PeakEstimator::Deconvolution`], chosen by measurement
/// (`tests/estimators.rs`): on light a projector can produce — whole columns mixed by defocus and
/// the camera footprint — its RMS error is 0.0002–0.0013 column against 0.05–0.17 for the
/// magnitude estimators (BFSM and EFSM presets, 1 DN noise), because those see a mixture of two
/// columns as a lopsided peak. On pure tones at fractional columns (not physical) it is still
/// the most accurate with BFSM (0.006 against 0.066–0.19) and level with the Gaussian fit with
/// EFSM `cB = 64` (0.005 against 0.006).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum PeakEstimator {
    /// Local c-domain deconvolution: light-weighted column of the fitted column weights.
    Deconvolution,
    /// The paper's 3-point Gaussian fit on the magnitude.
    Gaussian,
    /// 3-point parabola on the magnitude.
    Parabolic,
    /// Blais–Rioux detector of order 4.
    BlaisRioux4,
    /// Blais–Rioux detector of order 8.
    BlaisRioux8,
}

/// How the decoder finds the lights of a pixel (SPEC §2 "Finding the candidates", §2b).
///
/// [`PeakSearch::Cosine`] is the default of every plan whose band is full (`Δf = 1/(2·span)`,
/// harmonics `1..=span`, dark and white frames): the samples are then exactly a cosine
/// transform of the pixel's column profile, and its inverse gives every column's light at once,
/// with no window, sidelobe or iteration (SPEC §2b). [`PeakSearch::Clean`] is for plans with a
/// partial band: it removes each peak's modelled spectrum from the zero-padded DFT.
/// [`PeakSearch::LocalMaxima`] is the paper's own detector, kept to compare with the paper; use
/// it with the Hann window ([`DecodeSettings::local_maxima`]), whose sidelobes (−31 dB) stay
/// under a relative floor of a few percent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum PeakSearch {
    /// Strongest peak, fit, subtract its modelled spectrum, repeat ([`crate::search::clean`]).
    Clean,
    /// Every local maximum of `|X_k|` above the noise and relative floors, one pass, nothing
    /// subtracted ([`crate::search::local_maxima`]).
    LocalMaxima,
    /// The exact inverse cosine transform of the full band, lights as runs of lit columns
    /// ([`crate::search::cosine`]).
    Cosine,
}

impl PeakSearch {
    /// What a plan file without a `search` field means: it was written before the field
    /// existed, when every plan was decoded by CLEAN.
    pub fn unstated() -> Self {
        PeakSearch::Clean
    }
}

/// The camera sensor's noise, from which the cosine search sets its threshold (SPEC §2b): read
/// noise and photon shot noise, in electrons, scaled to codes by the row's bit depth. A
/// datasheet (EMVA 1288) gives both; with analog gain, the full-scale charge is the full well
/// divided by the gain.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SensorNoise {
    /// Photo-electrons that reach the top code `2^bits − 1`.
    pub full_scale_electrons: f32,
    /// Read noise RMS, electrons.
    pub read_noise_electrons: f32,
}

impl SensorNoise {
    /// What [`SensorNoise::check`] asks of a field, for error messages.
    pub const RULE: &'static str =
        "must be a finite number (above 0 for the full-scale charge, not below 0 for the read noise)";

    /// Checks the model: a finite full-scale charge above 0 and a finite read noise not below 0;
    /// else the offending field (`sensor.…`) and its value.
    pub fn check(&self) -> Result<(), (&'static str, f32)> {
        let (full, read) = (self.full_scale_electrons, self.read_noise_electrons);
        if !(full.is_finite() && full > 0.0) {
            return Err(("sensor.full_scale_electrons", full));
        }
        if !(read.is_finite() && read >= 0.0) {
            return Err(("sensor.read_noise_electrons", read));
        }
        Ok(())
    }
}

impl Default for SensorNoise {
    /// A typical machine-vision CMOS sensor: 10 000 e⁻ at full scale, 6 e⁻ read noise. A
    /// smaller full-scale charge than the real one overstates the shot noise: a higher
    /// threshold, no false light.
    fn default() -> Self {
        SensorNoise {
            full_scale_electrons: 10_000.0,
            read_noise_electrons: 6.0,
        }
    }
}

/// Decoder thresholds and choices; they are part of the plan so that the camera and the host
/// produce the same candidates from the same plan.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct DecodeSettings {
    /// Peak search; plan files written before it existed mean [`PeakSearch::Clean`].
    #[cfg_attr(feature = "serde", serde(default = "PeakSearch::unstated"))]
    pub search: PeakSearch,
    /// Window applied to the fringe samples.
    pub window: Window,
    /// Sub-pixel estimator reported as the candidate column.
    pub estimator: PeakEstimator,
    /// Most peaks reported per spectrum, `1..=MAX_PEAKS`.
    pub max_peaks: u8,
    /// A peak must exceed this many times the RMS noise of a spectrum bin (eq. 21 with the
    /// pixel's own noise, estimated from the residual after the peak search).
    pub noise_factor: f32,
    /// A peak must exceed this fraction of the pixel's strongest peak.
    pub relative_floor: f32,
    /// A peak's amplitude (fringe modulation, sensor DN) must exceed this.
    pub min_amplitude_dn: f32,
    /// A mask lights the pixel if it exceeds the dark level by this many noise RMS.
    pub mask_noise_factor: f32,
    /// … and by this fraction of the brightest mask's excess over dark.
    pub mask_relative_floor: f32,
    /// EFSM: candidates of the two groups closer than this (columns) are one candidate: their
    /// mean where both groups see it well inside a block, else the view further from a border.
    pub merge_tolerance: f32,
    /// The sensor's noise: the cosine search's threshold. Plan files written before it
    /// existed mean the default.
    #[cfg_attr(feature = "serde", serde(default))]
    pub sensor: SensorNoise,
}

impl Default for DecodeSettings {
    /// The cosine search ([`DecodeSettings::cosine`]).
    fn default() -> Self {
        DecodeSettings::cosine()
    }
}

impl DecodeSettings {
    /// The exact decoder of a full band (SPEC §2b): every column's light from the inverse cosine
    /// transform, a light where the profile exceeds 5 times its noise RMS, which the sensor
    /// sets ([`SensorNoise`]). The profile has `span + 1` columns of white noise, so at 5 RMS
    /// a pixel in shadow shows a false light with probability `2.9·10⁻⁷·(span + 1)` (2·10⁻⁴
    /// for BFSM's 769 columns).
    pub fn cosine() -> Self {
        DecodeSettings {
            search: PeakSearch::Cosine,
            noise_factor: 5.0,
            ..DecodeSettings::clean()
        }
    }

    /// CLEAN on the zero-padded DFT (SPEC §2): the deconvolution estimator, a noise factor of
    /// 4 against the residual's own noise, a relative floor of 2%.
    pub fn clean() -> Self {
        DecodeSettings {
            search: PeakSearch::Clean,
            window: Window::Rectangular,
            estimator: PeakEstimator::Deconvolution,
            max_peaks: 4,
            noise_factor: 4.0,
            relative_floor: 0.02,
            min_amplitude_dn: 0.5,
            mask_noise_factor: 5.0,
            mask_relative_floor: 0.05,
            merge_tolerance: 0.5,
            sensor: SensorNoise::default(),
        }
    }

    /// The paper's decoder (§III-D): local maxima of the Hann-windowed spectrum, the 3-point
    /// Gaussian fit, a relative floor of 8%, a noise factor of 5; the other thresholds as
    /// [`DecodeSettings::clean`].
    ///
    /// The floor sits above the Hann window's −31 dB sidelobes (2.7%) and above the sidelobe a
    /// light one column from a block border shows where its peak meets its mirror image: 5%
    /// reported that sidelobe as light, 8% reports none (`tests/local_maxima.rs`). A weaker
    /// indirect light is not reported; CLEAN's floor is 2%. The noise median is taken over
    /// fewer bins than CLEAN's (about 13 with EFSM `cB = 64`), so it scatters more: at 4 noise
    /// RMS, 4 of 2000 EFSM pixels in shadow got a candidate, at 5 one did.
    pub fn local_maxima() -> Self {
        DecodeSettings {
            search: PeakSearch::LocalMaxima,
            window: Window::Hann,
            estimator: PeakEstimator::Gaussian,
            relative_floor: 0.08,
            noise_factor: 5.0,
            ..DecodeSettings::clean()
        }
    }
}

impl Default for PatternLevels {
    fn default() -> Self {
        PatternLevels {
            offset: 0.5,
            amplitude: 0.5,
        }
    }
}

/// A violated plan rule; the message names the rule and the values.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // each field is the value the variant reports
pub enum PlanError {
    /// `cmax` outside `2..=MAX_PROJECTOR_COLUMNS`.
    ProjectorColumns { columns: u16 },
    /// `cB` must be even (the second group shifts by `cB/2`).
    BlockWidthOdd { block_width: u16 },
    /// `cB` must be at least 4 and below `cmax`.
    BlockWidthRange {
        block_width: u16,
        projector_columns: u16,
    },
    /// `cg` must lie in `(0, cB/4]`.
    BorderGuard { border_guard: f32, max: f32 },
    /// `n₁ = 0` would make the first fringe a flat frame.
    FirstHarmonicZero,
    /// Eq. 7: `Δf = 1/L` is above Nyquist, `1/(2·span)`.
    FrequencyStepAboveNyquist {
        period_columns: u32,
        span_columns: u16,
    },
    /// The last fringe frequency exceeds 1/2 cycle per column (it would alias on the projector).
    LastFrequencyAboveHalf {
        last_harmonic: u32,
        period_columns: u32,
    },
    /// Fewer fringes than `MIN_FRINGE_COUNT`.
    TooFewFringes { count: u16, min: u16 },
    /// `N` is not a power of two in `64..=4096`.
    TransformSize { transform_size: u16 },
    /// `N < M`: the transform would drop samples.
    TransformShorterThanFringes { transform_size: u16, count: u16 },
    /// `N` and `L` need a kernel table larger than `MAX_KERNEL_TABLE_LEN`.
    KernelTable { entries: usize, max: usize },
    /// `PB ≤ 0`, or `PA ± PB` outside `[0, 1]`.
    PatternLevels { offset: f32, amplitude: f32 },
    /// EFSM decides blocks against the dark frame.
    EfsmNeedsDarkReference,
    /// `max_peaks` outside `1..=MAX_PEAKS`.
    MaxPeaks { max_peaks: u8 },
    /// A decoder threshold is negative or not finite.
    DecodeThreshold { field: &'static str, value: f32 },
    /// The local-maximum search needs [`LOCAL_MAXIMA_MIN_FRINGES`] fringes.
    LocalMaximaTooFewFringes { count: u16, min: u16 },
    /// The sensor's full-scale charge is not a positive number.
    SensorFullScale { value: f32 },
    /// The cosine search needs the full band: `n₁ = 1`, `M = L/2`.
    CosineNeedsFullBand {
        first_harmonic: u32,
        count: u16,
        period_columns: u32,
    },
    /// The cosine search takes its `h = 0` term from the dark and white frames.
    CosineNeedsReferences,
    /// The cosine search uses no window.
    CosineWindow,
    /// The cosine search measures a light by its column weights.
    CosineEstimator { estimator: PeakEstimator },
}

impl fmt::Display for PlanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            PlanError::ProjectorColumns { columns } => write!(
                f,
                "projector_columns = {columns}: must be in 2..={MAX_PROJECTOR_COLUMNS}"
            ),
            PlanError::BlockWidthOdd { block_width } => write!(
                f,
                "method.Efsm.block_width = {block_width}: cB must be even (group 2 is shifted by cB/2)"
            ),
            PlanError::BlockWidthRange { block_width, projector_columns } => write!(
                f,
                "method.Efsm.block_width = {block_width}: cB must be at least 4 and below projector_columns = {projector_columns} (use BFSM otherwise)"
            ),
            PlanError::BorderGuard { border_guard, max } => write!(
                f,
                "method.Efsm.border_guard = {border_guard}: cg must lie in (0, cB/4] = (0, {max}]"
            ),
            PlanError::FirstHarmonicZero => {
                write!(f, "band.first_harmonic = 0: f1 = 0 is a flat frame, use n1 >= 1")
            }
            PlanError::FrequencyStepAboveNyquist { period_columns, span_columns } => write!(
                f,
                "band.period_columns = {period_columns}: frequency step 1/{period_columns} is above Nyquist 1/(2*{span_columns}) (eq. 7 needs band.period_columns >= {})",
                2 * span_columns as u32
            ),
            PlanError::LastFrequencyAboveHalf { last_harmonic, period_columns } => write!(
                f,
                "last fringe frequency {last_harmonic}/{period_columns} is above 1/2 cycle per column; lower band.first_harmonic or band.count"
            ),
            PlanError::TooFewFringes { count, min } => {
                write!(f, "band.count = {count}: at least {min} fringe patterns are needed")
            }
            PlanError::TransformSize { transform_size } => write!(
                f,
                "transform_size = {transform_size}: N must be a power of two in {MIN_TRANSFORM_SIZE}..={MAX_TRANSFORM_SIZE}"
            ),
            PlanError::TransformShorterThanFringes { transform_size, count } => write!(
                f,
                "transform_size = {transform_size} is below band.count = {count}: N >= M is required"
            ),
            PlanError::KernelTable { entries, max } => write!(
                f,
                "transform_size and band.period_columns need a kernel table of {entries} entries (at most {max}); choose a period with a larger power-of-two factor"
            ),
            PlanError::PatternLevels { offset, amplitude } => write!(
                f,
                "levels.offset = {offset}, levels.amplitude = {amplitude}: need amplitude >= {MIN_LEVEL_AMPLITUDE:e} and 0 <= offset - amplitude, offset + amplitude <= 1"
            ),
            PlanError::EfsmNeedsDarkReference => write!(
                f,
                "references.dark = false: EFSM decides blocks against the dark frame"
            ),
            PlanError::MaxPeaks { max_peaks } => {
                write!(f, "decoding.max_peaks = {max_peaks}: must be in 1..={MAX_PEAKS}")
            }
            PlanError::DecodeThreshold { field, value } => {
                write!(f, "decoding.{field} = {value}: must be finite and not negative")
            }
            PlanError::SensorFullScale { value } => write!(
                f,
                "decoding.sensor.full_scale_electrons = {value}: must be finite and above 0"
            ),
            PlanError::CosineNeedsFullBand {
                first_harmonic,
                count,
                period_columns,
            } => write!(
                f,
                "band.first_harmonic = {first_harmonic}, band.count = {count}, band.period_columns = \
                 {period_columns}: decoding.search = Cosine needs the full band (first_harmonic = 1, \
                 count = period_columns / 2); use Clean for a partial band"
            ),
            PlanError::CosineNeedsReferences => write!(
                f,
                "references.dark and references.white must both be true: decoding.search = Cosine \
                 takes the transform's zero-frequency term from them"
            ),
            PlanError::CosineWindow => write!(
                f,
                "decoding.window = Hann: decoding.search = Cosine uses no window (set Rectangular)"
            ),
            PlanError::CosineEstimator { estimator } => write!(
                f,
                "decoding.estimator = {estimator:?}: decoding.search = Cosine measures a light by \
                 the centroid of its column weights (set Deconvolution)"
            ),
            PlanError::LocalMaximaTooFewFringes { count, min } => write!(
                f,
                "band.count = {count}: decoding.search = LocalMaxima needs at least {min} \
                 fringes to measure the noise beside a light (use Clean)"
            ),
        }
    }
}

const fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    a
}

impl ScanPlan {
    /// The paper's BFSM system (§VII): 768 columns, `f_m = m/1536`, `m = 1..=768`, `N = 1024`.
    ///
    /// The paper quotes `f ∈ [1/768, 1/2]` and "768 images"; with `Δf = 1/1536` that band holds
    /// 767 frequencies, so this preset starts at `1/1536` to keep 768 patterns within `f ≤ 1/2`.
    pub fn paper_bfsm() -> Self {
        Self::bfsm(768)
    }

    /// BFSM over `columns`: the full band `f_m = m/(2·cmax)`, `m = 1..=cmax` (one pattern per
    /// column, SPEC §2b), `N` the power of two at or above `cmax` (at least 64).
    pub fn bfsm(columns: u16) -> Self {
        let transform = (columns as u32)
            .next_power_of_two()
            .max(MIN_TRANSFORM_SIZE as u32);
        ScanPlan {
            projector_columns: columns,
            band: FringeBand {
                period_columns: 2 * columns as u32,
                first_harmonic: 1,
                count: columns,
            },
            transform_size: transform.min(u16::MAX as u32) as u16,
            method: Method::Bfsm,
            levels: PatternLevels::default(),
            references: References {
                dark: true,
                white: true,
            },
            decoding: DecodeSettings::default(),
        }
    }

    /// The paper's EFSM with `cB = 64`: one group is 64 fringes + 12 masks = 76 patterns,
    /// two groups 152. `N = 128 = 2·cB` puts every bin on an integer column.
    pub fn paper_efsm(groups: GroupCount) -> Self {
        Self::efsm(768, 64, groups)
    }

    /// EFSM over `columns` with block width `block_width`: full band `f ∈ [1/(2cB), 1/2]`,
    /// `M̃ = cB`, `N` the power of two at or above `2·cB` (at least 64; exactly `2·cB` puts every
    /// bin on an integer column), border guard 3 columns (at most `cB/4`): a projector defocus
    /// of up to 1 column spreads light about 3 columns, and a peak closer than that to a block
    /// border has part of its light in the next block.
    pub fn efsm(columns: u16, block_width: u16, groups: GroupCount) -> Self {
        let period = 2 * block_width as u32;
        let transform = period.next_power_of_two().max(MIN_TRANSFORM_SIZE as u32);
        ScanPlan {
            projector_columns: columns,
            band: FringeBand {
                period_columns: period,
                first_harmonic: 1,
                count: block_width,
            },
            transform_size: transform.min(u16::MAX as u32) as u16,
            method: Method::Efsm(BlockCoding {
                block_width,
                groups,
                border_guard: (block_width as f32 / 4.0).min(3.0),
            }),
            levels: PatternLevels::default(),
            references: References {
                dark: true,
                white: true,
            },
            decoding: DecodeSettings::default(),
        }
    }

    /// This plan decoded by CLEAN on the zero-padded DFT ([`DecodeSettings::clean`]), as every
    /// plan was before the cosine search: the patterns and `N` are unchanged.
    pub fn with_clean(mut self) -> Self {
        self.decoding = DecodeSettings::clean();
        self
    }

    /// This plan decoded for speed: the paper's local-maximum search
    /// ([`DecodeSettings::local_maxima`]) on the spectrum without zero padding (`N` the power of
    /// two at or above `M`, at least 64). The patterns are unchanged; only the decoder's choices
    /// and so the fingerprint differ. `tests/local_maxima.rs` measures what it costs in accuracy.
    pub fn with_local_maxima(mut self) -> Self {
        self.decoding = DecodeSettings::local_maxima();
        let fringes = (self.band.count as u32).next_power_of_two();
        self.transform_size = fringes.max(MIN_TRANSFORM_SIZE as u32).min(u16::MAX as u32) as u16;
        self
    }

    /// Checks every rule of SPEC §2–§3; the error names the first rule broken.
    pub fn validate(&self) -> Result<(), PlanError> {
        let cmax = self.projector_columns;
        if !(2..=MAX_PROJECTOR_COLUMNS).contains(&cmax) {
            return Err(PlanError::ProjectorColumns { columns: cmax });
        }
        if let Method::Efsm(b) = self.method {
            if b.block_width % 2 != 0 {
                return Err(PlanError::BlockWidthOdd {
                    block_width: b.block_width,
                });
            }
            if b.block_width < 4 || b.block_width >= cmax {
                return Err(PlanError::BlockWidthRange {
                    block_width: b.block_width,
                    projector_columns: cmax,
                });
            }
            let max = b.block_width as f32 / 4.0;
            if !(b.border_guard > 0.0 && b.border_guard <= max) {
                return Err(PlanError::BorderGuard {
                    border_guard: b.border_guard,
                    max,
                });
            }
            if !self.references.dark {
                return Err(PlanError::EfsmNeedsDarkReference);
            }
        }
        let band = self.band;
        if band.first_harmonic == 0 {
            return Err(PlanError::FirstHarmonicZero);
        }
        let span = self.span_columns();
        if (band.period_columns as u64) < 2 * span as u64 {
            return Err(PlanError::FrequencyStepAboveNyquist {
                period_columns: band.period_columns,
                span_columns: span,
            });
        }
        if band.count < MIN_FRINGE_COUNT {
            return Err(PlanError::TooFewFringes {
                count: band.count,
                min: MIN_FRINGE_COUNT,
            });
        }
        let last = band.first_harmonic as u64 + band.count as u64 - 1;
        if 2 * last > band.period_columns as u64 {
            return Err(PlanError::LastFrequencyAboveHalf {
                last_harmonic: last.min(u32::MAX as u64) as u32,
                period_columns: band.period_columns,
            });
        }
        let n = self.transform_size as usize;
        if !n.is_power_of_two() || !(MIN_TRANSFORM_SIZE..=MAX_TRANSFORM_SIZE).contains(&n) {
            return Err(PlanError::TransformSize {
                transform_size: self.transform_size,
            });
        }
        if n < band.count as usize {
            return Err(PlanError::TransformShorterThanFringes {
                transform_size: self.transform_size,
                count: band.count,
            });
        }
        let entries = self.kernel_table_len();
        if self.decoding.search != PeakSearch::Cosine && entries > MAX_KERNEL_TABLE_LEN {
            return Err(PlanError::KernelTable {
                entries,
                max: MAX_KERNEL_TABLE_LEN,
            });
        }
        let l = self.levels;
        let levels_ok = l.amplitude >= MIN_LEVEL_AMPLITUDE
            && l.offset >= l.amplitude
            && l.offset + l.amplitude <= 1.0;
        if !levels_ok {
            return Err(PlanError::PatternLevels {
                offset: l.offset,
                amplitude: l.amplitude,
            });
        }
        let d = self.decoding;
        if d.max_peaks == 0 || d.max_peaks as usize > MAX_PEAKS {
            return Err(PlanError::MaxPeaks {
                max_peaks: d.max_peaks,
            });
        }
        let thresholds = [
            ("noise_factor", d.noise_factor),
            ("relative_floor", d.relative_floor),
            ("min_amplitude_dn", d.min_amplitude_dn),
            ("mask_noise_factor", d.mask_noise_factor),
            ("mask_relative_floor", d.mask_relative_floor),
            ("merge_tolerance", d.merge_tolerance),
            ("sensor.read_noise_electrons", d.sensor.read_noise_electrons),
        ];
        for (field, value) in thresholds {
            if !(value.is_finite() && value >= 0.0) {
                return Err(PlanError::DecodeThreshold { field, value });
            }
        }
        let full_scale = d.sensor.full_scale_electrons;
        if !(full_scale.is_finite() && full_scale > 0.0) {
            return Err(PlanError::SensorFullScale { value: full_scale });
        }
        let min = LOCAL_MAXIMA_MIN_FRINGES;
        if d.search == PeakSearch::LocalMaxima && band.count < min {
            return Err(PlanError::LocalMaximaTooFewFringes {
                count: band.count,
                min,
            });
        }
        if d.search == PeakSearch::Cosine {
            if self.full_band_span().is_none() {
                return Err(PlanError::CosineNeedsFullBand {
                    first_harmonic: band.first_harmonic,
                    count: band.count,
                    period_columns: band.period_columns,
                });
            }
            if !(self.references.dark && self.references.white) {
                return Err(PlanError::CosineNeedsReferences);
            }
            if d.window != Window::Rectangular {
                return Err(PlanError::CosineWindow);
            }
            if d.estimator != PeakEstimator::Deconvolution {
                return Err(PlanError::CosineEstimator {
                    estimator: d.estimator,
                });
            }
        }
        Ok(())
    }

    /// `L/2` when the band is full (`n₁ = 1`, `M = L/2`: harmonics `1..=L/2` of `1/L`): the
    /// fringes and the dark and white frames are then exactly a cosine transform of `L/2 + 1`
    /// columns, `0..=L/2` (SPEC §2b).
    pub fn full_band_span(&self) -> Option<u16> {
        let band = self.band;
        let half = band.period_columns / 2;
        (band.first_harmonic == 1
            && band.period_columns.is_multiple_of(2)
            && band.count as u32 == half)
            .then_some(band.count)
    }

    /// The columns one fringe period covers: `cmax` (BFSM) or `cB` (EFSM).
    pub fn span_columns(&self) -> u16 {
        match self.method {
            Method::Bfsm => self.projector_columns,
            Method::Efsm(b) => b.block_width,
        }
    }

    /// 1 for BFSM and one-group EFSM, 2 for two-group EFSM.
    pub fn group_count(&self) -> usize {
        match self.method {
            Method::Efsm(BlockCoding {
                groups: GroupCount::Two,
                ..
            }) => 2,
            _ => 1,
        }
    }

    /// Fringe frequency `f_m` in cycles per column (eq. 5).
    pub fn frequency(&self, m: u16) -> f64 {
        (self.band.first_harmonic as f64 + m as f64) / self.band.period_columns as f64
    }

    /// `Δc = 1/(M·Δf)` in columns (eq. 9): the resolution of the c-domain; two columns closer
    /// than `2Δc` are not separable (§IV-C).
    pub fn column_resolution(&self) -> f32 {
        self.band.period_columns as f32 / self.band.count as f32
    }

    /// Column distance between adjacent DFT bins, `L/N` (SPEC §2 with zero padding).
    pub fn bin_width(&self) -> f32 {
        self.band.period_columns as f32 / self.transform_size as f32
    }

    /// Column (BFSM) or local column `c̃` (EFSM) of bin `k`: `c(k) = k·L/N` (SPEC §2).
    pub fn bin_column(&self, bin: f32) -> f32 {
        bin * self.bin_width()
    }

    /// Number of bins `N/2 + 1` of the real spectrum.
    pub fn bin_count(&self) -> usize {
        self.transform_size as usize / 2 + 1
    }

    /// Entries of the decoder's kernel table: `N·q` with `q = L/gcd(N, L)`, since model offsets
    /// between a column and a bin are multiples of `1/q` bin.
    pub fn kernel_table_len(&self) -> usize {
        let n = self.transform_size as u64;
        let l = self.band.period_columns as u64;
        if n == 0 || l == 0 {
            return 0;
        }
        (n * (l / gcd(n, l))) as usize
    }

    /// EFSM block coding, or `None` for BFSM.
    pub fn block_coding(&self) -> Option<BlockCoding> {
        match self.method {
            Method::Bfsm => None,
            Method::Efsm(b) => Some(b),
        }
    }

    /// Column shift `s_g` of a group: 0, or `cB/2` for group 2 (SPEC §3).
    pub fn group_shift(&self, group: Group) -> u16 {
        match (group, self.method) {
            (Group::Two, Method::Efsm(b)) => b.block_width / 2,
            _ => 0,
        }
    }

    /// `NB_g = ceil((cmax + s_g)/cB)` blocks of a group (SPEC §3); 0 for BFSM.
    pub fn block_count(&self, group: Group) -> u16 {
        match self.method {
            Method::Bfsm => 0,
            Method::Efsm(b) => {
                let reach = self.projector_columns as u32 + self.group_shift(group) as u32;
                reach.div_ceil(b.block_width as u32) as u16
            }
        }
    }

    /// Whether group 2's first block (local columns `[cB/2, cB)`) and last block (local columns
    /// `[0, r)` with `r ≤ cB/2`) share one mask pattern. Their local columns never overlap, so
    /// one mask lights both and the column range decides which one a peak belongs to: this is
    /// what keeps two groups at `2·(M̃ + ceil(cmax/cB))` patterns, the paper's count, whenever
    /// `cmax` is a multiple of `cB`.
    pub fn shares_edge_mask(&self, group: Group) -> bool {
        match (group, self.method) {
            (Group::Two, Method::Efsm(b)) => {
                let nb = self.block_count(group) as u32;
                nb >= 2 && (nb - 1) * b.block_width as u32 >= self.projector_columns as u32
            }
            _ => false,
        }
    }

    /// Number of mask patterns of a group.
    pub fn mask_count(&self, group: Group) -> u16 {
        self.block_count(group) - self.shares_edge_mask(group) as u16
    }

    /// The blocks mask `mask` of `group` lights: one block, or two for a shared edge mask.
    pub fn mask_blocks(&self, group: Group, mask: u16) -> MaskBlocks {
        self.group_frames(group).mask_blocks(mask)
    }

    /// Where `group`'s frames are in the sequence and what its masks light, worked out once:
    /// the decoder reads them at every pixel, and the camera's core divides in software.
    pub fn group_frames(&self, group: Group) -> GroupFrames {
        GroupFrames {
            fringe_start: self.fringe_start(group),
            mask_start: self.mask_start(group),
            mask_count: self.mask_count(group),
            last_block: self.block_count(group).saturating_sub(1),
            shares_edge_mask: self.shares_edge_mask(group),
        }
    }

    /// Block `b` and local column `c̃` of projector column `column` in `group`:
    /// `c̃ = (c + s_g) mod cB`, `b = floor((c + s_g)/cB)` (SPEC §3). BFSM: block 0, `c̃ = c`.
    pub fn block_of(&self, column: u32, group: Group) -> (u16, u32) {
        match self.method {
            Method::Bfsm => (0, column),
            Method::Efsm(b) => {
                let shifted = column + self.group_shift(group) as u32;
                let w = b.block_width as u32;
                ((shifted / w) as u16, shifted % w)
            }
        }
    }

    /// Projector column of local column `c̃` in block `b` of `group`: `c = c̃ + b·cB − s_g`
    /// (eqs. 19–20 in 0-based form).
    pub fn column_of(&self, local_column: f32, block: u16, group: Group) -> f32 {
        match self.method {
            Method::Bfsm => local_column,
            Method::Efsm(b) => {
                local_column + block as f32 * b.block_width as f32 - self.group_shift(group) as f32
            }
        }
    }
}

/// Where one group's frames are in the sequence and what its masks light
/// ([`ScanPlan::group_frames`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GroupFrames {
    /// Frame index of fringe 0.
    pub fringe_start: usize,
    /// Frame index of mask 0.
    pub mask_start: usize,
    /// Mask patterns of the group.
    pub mask_count: u16,
    /// `NB_g − 1`, the group's last block (0 for BFSM).
    pub last_block: u16,
    /// Whether mask 0 also lights the last block ([`ScanPlan::shares_edge_mask`]).
    pub shares_edge_mask: bool,
}

impl GroupFrames {
    /// The blocks mask `mask` lights: one block, or two for a shared edge mask.
    pub fn mask_blocks(&self, mask: u16) -> MaskBlocks {
        MaskBlocks {
            first: mask,
            second: (mask == 0 && self.shares_edge_mask).then_some(self.last_block),
        }
    }
}

/// The blocks one mask pattern lights.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MaskBlocks {
    /// The mask's own block.
    pub first: u16,
    /// The last block, when group 2 shares its edge mask.
    pub second: Option<u16>,
}

impl MaskBlocks {
    /// Whether the mask lights block `block`.
    pub fn contains(&self, block: u16) -> bool {
        self.first == block || self.second == Some(block)
    }
}
