//! The line decoder: one temporal row in, the candidates of every pixel out.
//!
//! Input is a row exactly as frames deliver it: sample-major, `frames[i·W + x]` is frame `i`
//! (in [`ScanPlan::pattern`] order, references included) at pixel `x`, as `u16` codes of an
//! 8- to 16-bit sensor. The caller owns every buffer: the plan's tables (built once per plan)
//! and a scratch area reused from row to row. Nothing but the plan carries over between rows,
//! and no input (zero, constant, saturated) makes the decoder panic.
//!
//! Two paths, by the plan's search:
//! - `cosine`: the cosine search decodes `L` adjacent pixels at once, one lane each, through
//!   one lane-parallel inverse cosine transform (the host picks a wide `L`, the camera `L = 1`;
//!   the candidates are the same bits);
//! - `spectral`: CLEAN and the local-maximum search decode pixel by pixel from the
//!   zero-padded DFT.
//!
//! Both hand each group's peaks to `Decoder::add_group`, which turns them into candidates
//! (BFSM directly, EFSM with the block masks, [`crate::block`]).

mod cosine;
mod spectral;

use core::fmt;

use crate::block::{self, MaskLevels};
use crate::candidate::{Candidate, ColumnRange, GroupSet, PixelCandidates, PixelFlags};
use crate::peak::deconvolution::FitTable;
use crate::peak::PeakList;
use crate::plan::sequence::Group;
use crate::plan::{GroupFrames, Method, PeakSearch, PlanError, ScanPlan, Window};
use crate::transform::isa::Isa;
use crate::transform::kernel::{self, Kernel};
use crate::transform::spectrum::Spectrum;
use crate::transform::CosineTransform;

/// Pixels the build's own instructions decode at once: 4 in the SSE2 registers of the x86-64
/// baseline or the NEON registers of the camera's Cortex-A9 (built with `+neon`), else one
/// ([`Decoder::decode_row_lanes`]). [`Decoder::decode_row`] takes 8 or 16 where the CPU runs
/// AVX2 or AVX-512F.
#[cfg(any(
    target_arch = "x86_64",
    all(target_arch = "arm", target_feature = "neon")
))]
pub const DEFAULT_LANES: usize = 4;
/// Pixels the build's own instructions decode at once (one lane: no vector unit the build
/// may use).
#[cfg(not(any(
    target_arch = "x86_64",
    all(target_arch = "arm", target_feature = "neon")
)))]
pub const DEFAULT_LANES: usize = 1;
/// Most pixels [`Decoder::decode_row`] decodes at once (AVX-512F).
pub const MAX_LANES: usize = 16;

/// One temporal row of captured frames.
#[derive(Clone, Copy, Debug)]
pub struct Row<'a> {
    /// `frames[i·width + x]`: frame `i` at pixel `x`, every frame of the plan's sequence.
    pub frames: &'a [u16],
    /// Pixels in the row, `W`.
    pub width: usize,
    /// Sensor bit depth, 1–16: codes at `2^bits − 1` and above are saturated.
    pub bit_depth: u8,
    /// Optional per-pixel column range (length `W`), intersected with the projector's columns.
    pub column_limits: Option<&'a [ColumnRange]>,
}

impl Row<'_> {
    /// The checks every decoder (FSM's and the baselines') makes of a row of `frames` frames
    /// before it reads a sample: a width, a bit depth of 1–16, `frames × width` samples, and
    /// column limits (if any) for every pixel.
    pub(crate) fn check_shape(&self, frames: usize) -> Result<(), RowError> {
        if self.width == 0 {
            return Err(RowError::EmptyRow);
        }
        if !(1..=16).contains(&self.bit_depth) {
            return Err(RowError::BitDepth {
                bit_depth: self.bit_depth,
            });
        }
        let expected = frames.saturating_mul(self.width);
        if self.frames.len() != expected {
            return Err(RowError::FramesLength {
                expected,
                actual: self.frames.len(),
            });
        }
        if let Some(limits) = self.column_limits {
            if limits.len() != self.width {
                return Err(RowError::ColumnLimitsLength {
                    expected: self.width,
                    actual: limits.len(),
                });
            }
        }
        Ok(())
    }
}

/// Why a decoder could not be built.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // each field is the value the variant reports
pub enum DecoderError {
    /// The plan breaks a rule.
    Plan(PlanError),
    /// The table storage is shorter than [`Decoder::tables_len`].
    TablesTooShort { needed: usize, got: usize },
    /// The tables were built for another plan.
    TablesOfAnotherPlan,
}

/// Why a row could not be decoded; nothing was written to the output.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // each field is the value the variant reports
pub enum RowError {
    /// `frames` does not hold `sequence_len × width` samples.
    FramesLength { expected: usize, actual: usize },
    /// Width 0.
    EmptyRow,
    /// Bit depth outside 1–16.
    BitDepth { bit_depth: u8 },
    /// The output does not have one entry per pixel.
    OutputLength { expected: usize, actual: usize },
    /// The column limits do not have one entry per pixel.
    ColumnLimitsLength { expected: usize, actual: usize },
    /// The scratch area is shorter than [`Decoder::scratch_len`].
    ScratchTooShort { needed: usize, got: usize },
    /// Pixel index past the row.
    Pixel { x: usize, width: usize },
}

impl fmt::Display for DecoderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DecoderError::Plan(e) => write!(f, "invalid plan: {e}"),
            DecoderError::TablesTooShort { needed, got } => {
                write!(f, "decoder tables need {needed} floats, got {got}")
            }
            DecoderError::TablesOfAnotherPlan => {
                write!(f, "the decoder tables were built for another plan")
            }
        }
    }
}

impl fmt::Display for RowError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            RowError::FramesLength { expected, actual } => write!(
                f,
                "row holds {actual} samples, the plan needs {expected} (frames x width)"
            ),
            RowError::EmptyRow => write!(f, "row width is 0"),
            RowError::BitDepth { bit_depth } => {
                write!(f, "bit depth {bit_depth} is outside 1..=16")
            }
            RowError::OutputLength { expected, actual } => {
                write!(f, "output has {actual} pixels, the row has {expected}")
            }
            RowError::ColumnLimitsLength { expected, actual } => {
                write!(
                    f,
                    "column limits have {actual} entries, the row has {expected} pixels"
                )
            }
            RowError::ScratchTooShort { needed, got } => {
                write!(f, "scratch needs {needed} floats, got {got}")
            }
            RowError::Pixel { x, width } => write!(f, "pixel {x} is outside a row of {width}"),
        }
    }
}

impl From<PlanError> for DecoderError {
    fn from(e: PlanError) -> Self {
        DecoderError::Plan(e)
    }
}

/// Decodes rows of one plan. Cheap to share between threads: it only reads its tables.
#[derive(Clone, Copy, Debug)]
pub struct Decoder<'t> {
    plan: ScanPlan,
    tables: Tables<'t>,
    /// The vector instructions this CPU runs ([`Decoder::decode_row`] picks its lanes by it).
    isa: Isa,
    /// Each group's frames ([`ScanPlan::group_frames`]).
    frames: [GroupFrames; 2],
}

/// The tables of the plan's search.
#[derive(Clone, Copy, Debug)]
enum Tables<'t> {
    /// CLEAN and local maxima: the column kernel, the fit operators, the window.
    Spectral(SpectralTables<'t>),
    /// The cosine search: the inverse cosine transform of the full band.
    Cosine(CosineTransform<'t>),
}

#[derive(Clone, Copy, Debug)]
struct SpectralTables<'t> {
    kernel: Kernel<'t>,
    fits: FitTable<'t>,
    window: &'t [f32],
    inverse_window_sum: f32,
    /// Sample noise RMS per unit of bin noise RMS: `Σh / sqrt(Σh²)`.
    bin_to_sample_noise: f32,
}

impl<'t> Decoder<'t> {
    /// Floats of table storage a decoder of `plan` needs: a header holding the plan's
    /// fingerprint, then the cosine transform (cosine search), or the kernel, the fit operators
    /// and the window (DFT searches).
    pub fn tables_len(plan: &ScanPlan) -> usize {
        TABLES_HEADER
            + match cosine_span(plan) {
                Some(span) => CosineTransform::tables_len(span as usize),
                None => Kernel::storage_len(plan) + FitTable::storage_len(plan) + window_len(plan),
            }
    }

    /// The noise RMS, at a pixel that receives no light (read noise and code rounding only),
    /// of one column of the light profile (SPEC §2b; the cosine search) or of one bin of the
    /// spectrum (the DFT searches, eq. 21 with the window's noise gain), in the fringe
    /// modulation's sensor DN that amplitudes are given in: the scale a light's amplitude is
    /// judged against, and a point's quality measured in. A lit pixel's noise is higher (shot
    /// noise).
    pub fn dark_column_noise_dn(plan: &ScanPlan, bit_depth: u8) -> f32 {
        let sample = crate::noise::sample_noise_dn(&plan.decoding.sensor, bit_depth, 0.0);
        match cosine_span(plan) {
            Some(span) => crate::noise::profile_noise_dn(sample, span),
            // A bin's complex variance is `σ²·Σh²/(Σh)²` and an amplitude `2|X|`: per
            // component, `σ·√(2·Σh²)/Σh`, which is `σ·√(2/M)` without window.
            None => {
                let m = plan.band.count as usize;
                let sum = kernel::window_sum(plan.decoding.window, m);
                let squares = kernel::window_sum_of_squares(plan.decoding.window, m);
                sample * crate::math::sqrt((2.0 * squares) as f32) / sum as f32
            }
        }
    }

    /// Floats of scratch [`Decoder::decode_row`] and every other method need, on any CPU.
    pub fn scratch_len(plan: &ScanPlan) -> usize {
        Self::scratch_len_lanes::<MAX_LANES>(plan)
    }

    /// Floats of scratch [`Decoder::decode_row_lanes`] with `L` lanes needs (and enough for
    /// one pixel's spectrum, [`Decoder::spectrum`]).
    pub fn scratch_len_lanes<const L: usize>(plan: &ScanPlan) -> usize {
        let dft = spectral::scratch_len(plan);
        match cosine_span(plan) {
            Some(span) => {
                dft.max(cosine::scratch_len::<L>(span).max(cosine::scratch_len::<1>(span)))
            }
            None => dft,
        }
    }

    /// Validates `plan` and builds its tables in `tables`, then borrows them.
    pub fn new(plan: &ScanPlan, tables: &'t mut [f32]) -> Result<Self, DecoderError> {
        Self::build_tables(plan, tables)?;
        Self::from_tables(plan, tables)
    }

    /// Validates `plan` and builds its tables in `tables`: the costly part, once per plan (a
    /// camera does it when a plan is uploaded, then decodes with [`Decoder::from_tables`]).
    pub fn build_tables(plan: &ScanPlan, tables: &mut [f32]) -> Result<(), DecoderError> {
        plan.validate()?;
        let needed = Self::tables_len(plan);
        let too_short = DecoderError::TablesTooShort {
            needed,
            got: tables.len(),
        };
        let tables = tables.get_mut(..needed).ok_or(too_short)?;
        let (header, rest) = tables.split_at_mut(TABLES_HEADER);
        header.copy_from_slice(&fingerprint_floats(plan));
        if let Some(span) = cosine_span(plan) {
            return CosineTransform::build(span as usize, rest).map_err(|_| too_short);
        }
        let (kernel_storage, rest) = rest.split_at_mut(Kernel::storage_len(plan));
        Kernel::build(plan, kernel_storage).ok_or(too_short)?;
        let kernel = Kernel::view(plan, kernel_storage).ok_or(too_short)?;
        let (fit_storage, window) = rest.split_at_mut(FitTable::storage_len(plan));
        FitTable::build(plan, &kernel, fit_storage).ok_or(too_short)?;
        let m = plan.band.count as usize;
        for (i, h) in window.iter_mut().enumerate() {
            *h = kernel::hann(i, m) as f32;
        }
        Ok(())
    }

    /// A decoder reading tables that [`Decoder::build_tables`] built for the same plan; the
    /// plan's fingerprint in the tables' header must match.
    pub fn from_tables(plan: &ScanPlan, tables: &'t [f32]) -> Result<Self, DecoderError> {
        plan.validate()?;
        let needed = Self::tables_len(plan);
        let tables = tables.get(..needed).ok_or(DecoderError::TablesTooShort {
            needed,
            got: tables.len(),
        })?;
        let (header, rest) = tables.split_at(TABLES_HEADER);
        if header != fingerprint_floats(plan) {
            return Err(DecoderError::TablesOfAnotherPlan);
        }
        if let Some(span) = cosine_span(plan) {
            let transform = CosineTransform::view(span as usize, rest)
                .map_err(|_| DecoderError::TablesOfAnotherPlan)?;
            return Ok(Decoder {
                plan: *plan,
                tables: Tables::Cosine(transform),
                isa: Isa::detect(),
                frames: group_frames(plan),
            });
        }
        let too_short = DecoderError::TablesTooShort {
            needed,
            got: needed,
        };
        let (kernel_storage, rest) = rest.split_at(Kernel::storage_len(plan));
        let kernel = Kernel::view(plan, kernel_storage).ok_or(too_short)?;
        let (fit_storage, window) = rest.split_at(FitTable::storage_len(plan));
        let fits = FitTable::view(plan, fit_storage).ok_or(too_short)?;
        let m = plan.band.count as usize;
        // The sums the spectrum is scaled by come from the f32 weights actually applied.
        let (sum, sum_sq) = if window.is_empty() {
            (m as f64, m as f64)
        } else {
            window.iter().fold((0.0f64, 0.0f64), |(s, q), &h| {
                (s + h as f64, q + (h * h) as f64)
            })
        };
        Ok(Decoder {
            plan: *plan,
            tables: Tables::Spectral(SpectralTables {
                kernel,
                fits,
                window,
                inverse_window_sum: (1.0 / sum) as f32,
                bin_to_sample_noise: (sum / libm::sqrt(sum_sq)) as f32,
            }),
            isa: Isa::detect(),
            frames: group_frames(plan),
        })
    }

    /// The plan this decoder decodes.
    pub fn plan(&self) -> &ScanPlan {
        &self.plan
    }

    /// The plan's kernel (modelled spectrum of one column), for the DFT searches.
    pub fn kernel(&self) -> Option<&Kernel<'t>> {
        match &self.tables {
            Tables::Spectral(t) => Some(&t.kernel),
            Tables::Cosine(_) => None,
        }
    }

    /// Decodes every pixel of `row` into `out` (one entry per pixel), as many pixels at a time
    /// as this CPU's widest vector instructions hold (16 with AVX-512F, 8 with AVX2, else
    /// [`DEFAULT_LANES`]): the same bits as any [`Decoder::decode_row_lanes`]. `scratch`
    /// needs [`Decoder::scratch_len`] floats.
    pub fn decode_row<const K: usize>(
        &self,
        row: &Row<'_>,
        scratch: &mut [f32],
        out: &mut [PixelCandidates<K>],
    ) -> Result<(), RowError> {
        match &self.tables {
            Tables::Cosine(transform) => {
                self.check_row(row, scratch, Self::scratch_len(&self.plan), out.len())?;
                cosine::decode_row_fastest::<K>(self, transform, self.isa, row, scratch, out);
                Ok(())
            }
            Tables::Spectral(_) => self.decode_row_lanes::<1, K>(row, scratch, out),
        }
    }

    /// The vector instructions [`Decoder::decode_row`] uses on this CPU.
    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// Decodes every pixel of `row` into `out`, `L` adjacent pixels at a time (the cosine
    /// search; the DFT searches go pixel by pixel whatever `L`). Every `L` gives the same
    /// bits: each lane runs the same scalar operations in the same order. `scratch` needs
    /// [`Decoder::scratch_len_lanes`] floats.
    ///
    /// Inlined, so that a caller compiled for wider vectors (`#[target_feature]`) gets its
    /// row loop in them; the lane loops of a group (loads, transform, lit columns) are one
    /// function of this crate per lane count, compiled for the build's own instructions.
    #[inline(always)]
    pub fn decode_row_lanes<const L: usize, const K: usize>(
        &self,
        row: &Row<'_>,
        scratch: &mut [f32],
        out: &mut [PixelCandidates<K>],
    ) -> Result<(), RowError> {
        self.check_row(
            row,
            scratch,
            Self::scratch_len_lanes::<L>(&self.plan),
            out.len(),
        )?;
        match &self.tables {
            Tables::Cosine(transform) => {
                cosine::decode_row::<L, K, cosine::Portable>(self, transform, row, scratch, out)
            }
            Tables::Spectral(tables) => {
                // One peak list for the row: creating one per pixel clears 600 bytes each time.
                let mut peaks = PeakList::default();
                for (x, pixel) in out.iter_mut().enumerate() {
                    spectral::decode_pixel(self, tables, row, x, scratch, &mut peaks, pixel);
                }
            }
        }
        Ok(())
    }

    /// Decodes pixel `x` of `row` into `out` (the same bits as [`Decoder::decode_row`]).
    pub fn decode_pixel<const K: usize>(
        &self,
        row: &Row<'_>,
        x: usize,
        scratch: &mut [f32],
        out: &mut PixelCandidates<K>,
    ) -> Result<(), RowError> {
        self.check_pixel(row, x, scratch)?;
        match &self.tables {
            Tables::Cosine(transform) => cosine::decode_pixels::<1, K, cosine::Portable>(
                self,
                transform,
                row,
                x,
                scratch,
                &mut cosine::RowState::new(),
                core::slice::from_mut(out),
            ),
            Tables::Spectral(tables) => {
                spectral::decode_pixel(self, tables, row, x, scratch, &mut PeakList::default(), out)
            }
        }
        Ok(())
    }

    /// The zero-padded DFT of `group`'s fringes at pixel `x`, in `scratch` (for inspection:
    /// the c-domain of paper Figs. 3, 4e and 8; every search).
    pub fn spectrum<'s>(
        &self,
        row: &Row<'_>,
        x: usize,
        group: Group,
        scratch: &'s mut [f32],
    ) -> Result<Spectrum<'s>, RowError> {
        self.check_pixel(row, x, scratch)?;
        let (window, inverse_window_sum) = match &self.tables {
            Tables::Spectral(t) => (t.window, t.inverse_window_sum),
            Tables::Cosine(_) => (&[][..], 1.0 / self.plan.band.count as f32),
        };
        spectral::load(
            &self.plan,
            window,
            inverse_window_sum,
            row,
            x,
            group,
            scratch,
        );
        Ok(Spectrum::new(scratch, self.plan.transform_size as usize))
    }

    /// The light of every column `0..=span` of `group` at pixel `x` (SPEC §2b: the inverse
    /// cosine transform), in `scratch`; `None` for a plan decoded by a DFT search.
    pub fn profile<'s>(
        &self,
        row: &Row<'_>,
        x: usize,
        group: Group,
        scratch: &'s mut [f32],
    ) -> Result<Option<&'s [f32]>, RowError> {
        self.check_pixel(row, x, scratch)?;
        Ok(match &self.tables {
            Tables::Cosine(transform) => {
                Some(cosine::profile(self, transform, row, x, group, scratch))
            }
            Tables::Spectral(_) => None,
        })
    }

    /// The peaks (DFT searches) or lights (cosine search) of `group` at pixel `x`, in the
    /// span domain's columns.
    pub fn peaks(
        &self,
        row: &Row<'_>,
        x: usize,
        group: Group,
        scratch: &mut [f32],
    ) -> Result<PeakList, RowError> {
        self.check_pixel(row, x, scratch)?;
        let mut peaks = PeakList::default();
        match &self.tables {
            Tables::Cosine(transform) => {
                cosine::lights(self, transform, row, x, group, scratch, &mut peaks)
            }
            Tables::Spectral(tables) => {
                spectral::load(
                    &self.plan,
                    tables.window,
                    tables.inverse_window_sum,
                    row,
                    x,
                    group,
                    scratch,
                );
                spectral::search(&self.plan, tables, scratch, &mut peaks);
            }
        }
        Ok(peaks)
    }

    fn check_row(
        &self,
        row: &Row<'_>,
        scratch: &[f32],
        needed: usize,
        pixels: usize,
    ) -> Result<(), RowError> {
        self.check(row, scratch, needed)?;
        if pixels != row.width {
            return Err(RowError::OutputLength {
                expected: row.width,
                actual: pixels,
            });
        }
        Ok(())
    }

    fn check_pixel(&self, row: &Row<'_>, x: usize, scratch: &[f32]) -> Result<(), RowError> {
        self.check(row, scratch, Self::scratch_len_lanes::<1>(&self.plan))?;
        if x >= row.width {
            return Err(RowError::Pixel {
                x,
                width: row.width,
            });
        }
        Ok(())
    }

    fn check(&self, row: &Row<'_>, scratch: &[f32], needed: usize) -> Result<(), RowError> {
        row.check_shape(self.plan.sequence_len())?;
        if scratch.len() < needed {
            return Err(RowError::ScratchTooShort {
                needed,
                got: scratch.len(),
            });
        }
        Ok(())
    }

    /// The columns pixel `x`'s candidates may take: the projector's, within the row's limits.
    fn column_range(&self, row: &Row<'_>, x: usize) -> ColumnRange {
        let range = ColumnRange::projector(self.plan.projector_columns);
        match row.column_limits {
            Some(limits) => range.intersect(&limits[x]),
            None => range,
        }
    }

    /// Adds the candidates of `group`'s `peaks` at pixel `x` (span-domain columns; the
    /// pixel's sample noise `noise_dn`) to `out`; returns whether the group's view is aliased
    /// (EFSM) or unresolved (BFSM).
    fn add_group<const K: usize>(
        &self,
        row: &Row<'_>,
        x: usize,
        group: Group,
        peaks: &PeakList,
        noise_dn: f32,
        out: &mut PixelCandidates<K>,
    ) -> bool {
        let plan = &self.plan;
        let range = self.column_range(row, x);
        out.noise_dn = out.noise_dn.max(noise_dn);
        let sample = |frame: usize| row.frames[frame * row.width + x];
        match plan.method {
            Method::Bfsm => {
                for (rank, peak) in peaks.peaks.iter().enumerate() {
                    if range.contains(peak.column) {
                        let candidate = Candidate {
                            column: peak.column,
                            amplitude: peak.amplitude,
                            groups: GroupSet::only(group),
                            group,
                            peak: rank as u8,
                            block: 0,
                        };
                        out.offer(candidate, plan.decoding.merge_tolerance, |old, _| *old);
                    }
                }
                peaks.unresolved
            }
            Method::Efsm(_) => {
                let frames = &self.frames[group.index()];
                let start = frames.mask_start;
                // EFSM plans always carry a dark frame (validated).
                let dark = plan.dark_index().map_or(0, sample);
                let masks = MaskLevels::new(
                    |i: u16| sample(start + i as usize),
                    frames.mask_count,
                    dark,
                    noise_dn,
                );
                let saturation = saturation_code(row.bit_depth);
                if masks.saturated(saturation) || dark >= saturation {
                    out.flags.insert(PixelFlags::SATURATED);
                }
                block::recover(plan, group, frames, peaks, &masks, &range, out)
            }
        }
    }

    /// Flags and orders a pixel whose groups have all been added; `troubled` tells whether
    /// every group was aliased (EFSM) or the one group unresolved (BFSM).
    fn finish<const K: usize>(&self, troubled: bool, out: &mut PixelCandidates<K>) {
        if troubled {
            out.flags.insert(match self.plan.method {
                Method::Bfsm => PixelFlags::UNRESOLVED,
                Method::Efsm(_) => PixelFlags::ALIASED,
            });
        }
        out.sort();
    }
}

/// Both groups' frames (group 2's are group 1's where the plan has one group).
fn group_frames(plan: &ScanPlan) -> [GroupFrames; 2] {
    let one = plan.group_frames(Group::One);
    [
        one,
        plan.groups().nth(1).map_or(one, |g| plan.group_frames(g)),
    ]
}

/// `L/2`, the span of the inverse cosine transform, for a plan decoded by the cosine search.
fn cosine_span(plan: &ScanPlan) -> Option<u16> {
    match plan.decoding.search {
        PeakSearch::Cosine => plan.full_band_span(),
        PeakSearch::Clean | PeakSearch::LocalMaxima => None,
    }
}

/// Floats of the tables' header: the plan fingerprint as four 16-bit pieces (exact in `f32`).
const TABLES_HEADER: usize = 4;

fn fingerprint_floats(plan: &ScanPlan) -> [f32; TABLES_HEADER] {
    let f = plan.fingerprint();
    core::array::from_fn(|i| ((f >> (16 * i)) & 0xffff) as f32)
}

/// Floats of window table: `M` for the Hann window, none for the rectangular one.
fn window_len(plan: &ScanPlan) -> usize {
    match plan.decoding.window {
        Window::Rectangular => 0,
        Window::Hann => plan.band.count as usize,
    }
}

/// The lowest saturated code of a `bits`-bit sensor.
fn saturation_code(bits: u8) -> u16 {
    ((1u32 << bits) - 1) as u16
}
