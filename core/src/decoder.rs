//! The line decoder: one temporal row in, the candidates of every pixel out.
//!
//! Input is a row exactly as frames deliver it: sample-major, `frames[i·W + x]` is frame `i`
//! (in [`ScanPlan::pattern`] order, references included) at pixel `x`, as `u16` codes of an
//! 8- to 16-bit sensor. The caller owns every buffer: the plan's tables (built once per plan)
//! and a scratch area reused from row to row. Nothing but the plan carries over between rows,
//! and no input (zero, constant, saturated) makes the decoder panic.

use core::fmt;

use crate::block::{self, MaskLevels};
use crate::candidate::{Candidate, ColumnRange, GroupSet, PixelCandidates, PixelFlags};
use crate::peak::deconvolution::FitTable;
use crate::peak::PeakList;
use crate::plan::sequence::Group;
use crate::plan::{Method, PeakSearch, PlanError, ScanPlan, Window};
use crate::search::{clean, local_maxima};
use crate::transform::kernel::{self, Kernel};
use crate::transform::spectrum::{self, Spectrum};

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
    kernel: Kernel<'t>,
    fits: FitTable<'t>,
    window: &'t [f32],
    inverse_window_sum: f32,
    /// Sample noise RMS per unit of bin noise RMS: `Σh / sqrt(Σh²)`.
    bin_to_sample_noise: f32,
}

impl<'t> Decoder<'t> {
    /// Floats of table storage a decoder of `plan` needs: a header holding the plan's
    /// fingerprint, the kernel, the fit operators and the window.
    pub fn tables_len(plan: &ScanPlan) -> usize {
        TABLES_HEADER + Kernel::storage_len(plan) + FitTable::storage_len(plan) + window_len(plan)
    }

    /// Floats of scratch [`Decoder::decode_row`] needs: one spectrum and one bin per power.
    pub fn scratch_len(plan: &ScanPlan) -> usize {
        let n = plan.transform_size as usize;
        (n + 2) + (n / 2 + 1)
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
            kernel,
            fits,
            window,
            inverse_window_sum: (1.0 / sum) as f32,
            bin_to_sample_noise: (sum / libm::sqrt(sum_sq)) as f32,
        })
    }

    /// The plan this decoder decodes.
    pub fn plan(&self) -> &ScanPlan {
        &self.plan
    }

    /// The plan's kernel (modelled spectrum of one column).
    pub fn kernel(&self) -> &Kernel<'t> {
        &self.kernel
    }

    /// Decodes every pixel of `row` into `out` (one entry per pixel).
    pub fn decode_row<const K: usize>(
        &self,
        row: &Row<'_>,
        scratch: &mut [f32],
        out: &mut [PixelCandidates<K>],
    ) -> Result<(), RowError> {
        self.check(row, scratch)?;
        if out.len() != row.width {
            return Err(RowError::OutputLength {
                expected: row.width,
                actual: out.len(),
            });
        }
        // One peak list for the row: creating one per pixel clears 600 bytes each time.
        let mut peaks = PeakList::default();
        for (x, pixel) in out.iter_mut().enumerate() {
            self.decode_checked(row, x, scratch, &mut peaks, pixel);
        }
        Ok(())
    }

    /// Decodes pixel `x` of `row` into `out`.
    pub fn decode_pixel<const K: usize>(
        &self,
        row: &Row<'_>,
        x: usize,
        scratch: &mut [f32],
        out: &mut PixelCandidates<K>,
    ) -> Result<(), RowError> {
        self.check(row, scratch)?;
        if x >= row.width {
            return Err(RowError::Pixel {
                x,
                width: row.width,
            });
        }
        self.decode_checked(row, x, scratch, &mut PeakList::default(), out);
        Ok(())
    }

    /// The spectrum of `group`'s fringes at pixel `x`, in `scratch` (for inspection: the
    /// c-domain of paper Figs. 3, 4e and 8).
    pub fn spectrum<'s>(
        &self,
        row: &Row<'_>,
        x: usize,
        group: Group,
        scratch: &'s mut [f32],
    ) -> Result<Spectrum<'s>, RowError> {
        self.check(row, scratch)?;
        if x >= row.width {
            return Err(RowError::Pixel {
                x,
                width: row.width,
            });
        }
        self.load(row, x, group, scratch);
        Ok(Spectrum::new(scratch, self.plan.transform_size as usize))
    }

    /// The peaks of `group`'s spectrum at pixel `x` (span-domain columns).
    pub fn peaks(
        &self,
        row: &Row<'_>,
        x: usize,
        group: Group,
        scratch: &mut [f32],
    ) -> Result<PeakList, RowError> {
        self.check(row, scratch)?;
        if x >= row.width {
            return Err(RowError::Pixel {
                x,
                width: row.width,
            });
        }
        self.load(row, x, group, scratch);
        let mut peaks = PeakList::default();
        self.search(scratch, &mut peaks);
        Ok(peaks)
    }

    fn check(&self, row: &Row<'_>, scratch: &[f32]) -> Result<(), RowError> {
        if row.width == 0 {
            return Err(RowError::EmptyRow);
        }
        if !(1..=16).contains(&row.bit_depth) {
            return Err(RowError::BitDepth {
                bit_depth: row.bit_depth,
            });
        }
        let expected = self.plan.sequence_len().saturating_mul(row.width);
        if row.frames.len() != expected {
            return Err(RowError::FramesLength {
                expected,
                actual: row.frames.len(),
            });
        }
        if let Some(limits) = row.column_limits {
            if limits.len() != row.width {
                return Err(RowError::ColumnLimitsLength {
                    expected: row.width,
                    actual: limits.len(),
                });
            }
        }
        let needed = Self::scratch_len(&self.plan);
        if scratch.len() < needed {
            return Err(RowError::ScratchTooShort {
                needed,
                got: scratch.len(),
            });
        }
        Ok(())
    }

    /// Loads the spectrum of `group` at pixel `x` into `scratch`; returns whether a fringe
    /// sample saturated.
    fn load(&self, row: &Row<'_>, x: usize, group: Group, scratch: &mut [f32]) -> bool {
        let start = self.plan.fringe_start(group);
        let w = row.width;
        // Frame `start + m` at pixel `x`, every `w` samples (the row's length is checked).
        let stats = spectrum::compute(
            &self.plan,
            row.frames.get(start * w + x..).unwrap_or(&[]),
            w,
            self.window,
            self.inverse_window_sum,
            saturation_code(row.bit_depth),
            scratch,
        );
        stats.saturated
    }

    /// The peaks of the spectrum in `scratch`, written to `out` (a `PeakList` is 600 bytes:
    /// returning it would copy it on the camera).
    fn search(&self, scratch: &mut [f32], out: &mut PeakList) {
        let n = self.plan.transform_size as usize;
        let (spectrum, rest) = scratch.split_at_mut(n + 2);
        let mut residual = Spectrum::new(spectrum, n);
        let (plan, kernel, fits) = (&self.plan, &self.kernel, &self.fits);
        match self.plan.decoding.search {
            PeakSearch::Clean => clean::find_peaks(plan, kernel, fits, &mut residual, rest, out),
            PeakSearch::LocalMaxima => {
                local_maxima::find_peaks(plan, kernel, fits, &residual, rest, out)
            }
        }
    }

    fn decode_checked<const K: usize>(
        &self,
        row: &Row<'_>,
        x: usize,
        scratch: &mut [f32],
        peaks: &mut PeakList,
        out: &mut PixelCandidates<K>,
    ) {
        out.clear();
        let plan = &self.plan;
        let saturation = saturation_code(row.bit_depth);
        let mut range = ColumnRange::projector(plan.projector_columns);
        if let Some(limits) = row.column_limits {
            range = range.intersect(&limits[x]);
        }
        let sample = |frame: usize| row.frames[frame * row.width + x];
        let mut aliased_in_every_group = true;
        for group in plan.groups() {
            if self.load(row, x, group, scratch) {
                out.flags.insert(PixelFlags::SATURATED);
            }
            self.search(scratch, peaks);
            let noise_dn = peaks.bin_noise * self.bin_to_sample_noise;
            out.noise_dn = out.noise_dn.max(noise_dn);
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
                }
                Method::Efsm(coding) => {
                    let start = plan.mask_start(group);
                    // EFSM plans always carry a dark frame (validated).
                    let dark = plan.dark_index().map_or(0, sample);
                    let masks = MaskLevels::new(
                        |i: u16| sample(start + i as usize),
                        plan.mask_count(group),
                        dark,
                        noise_dn,
                    );
                    if masks.saturated(saturation) || dark >= saturation {
                        out.flags.insert(PixelFlags::SATURATED);
                    }
                    aliased_in_every_group &=
                        block::recover(plan, &coding, group, peaks, &masks, &range, out);
                }
            }
        }
        if matches!(plan.method, Method::Efsm(_)) && aliased_in_every_group {
            out.flags.insert(PixelFlags::ALIASED);
        }
        out.sort();
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
