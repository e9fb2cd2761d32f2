//! Every method's plan behind one type: FSM's ([`ScanPlan`]) and the baselines' the paper
//! compares it with ([`crate::baseline`]), so that a camera, a file or a command takes any of
//! them the one same way.
//!
//! | what | here |
//! |---|---|
//! | a plan of any method, its fingerprints, frames and rules | [`MethodPlan`] |
//! | its canonical bytes (FSM's 80, a baseline's 32 or 96) | [`wire`] |
//! | its decoder of rows (FSM's over tables, a baseline's per pixel) | [`MethodDecoder`] |

pub mod wire;

use core::fmt;

use crate::baseline::code_ensemble::{CodeEnsembleError, CodeEnsemblePlan};
use crate::baseline::line_scan::{LineScanError, LineScanPlan};
use crate::baseline::micro_phase_shift::{MicroPhaseShiftError, MicroPhaseShiftPlan};
use crate::baseline::phase_shift::{PhaseShiftError, PhaseShiftPlan};
use crate::baseline::{PatternSequence, PixelDecoder};
use crate::candidate::PixelCandidates;
use crate::decoder::{Decoder, DecoderError, Row, RowError};
use crate::plan::{Method, PlanError, ScanPlan};
use crate::wire::row_dump::RowDumpHeader;
use crate::wire::{PlanIdentity, WireError};

/// A plan of any method the toolkit knows: FSM's, or one of the baselines the paper compares
/// it with.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MethodPlan {
    /// BFSM or EFSM.
    Fsm(ScanPlan),
    /// Phase shift + Gray code.
    PhaseShift(PhaseShiftPlan),
    /// Micro Phase Shifting.
    MicroPhaseShift(MicroPhaseShiftPlan),
    /// Line scanning.
    LineScan(LineScanPlan),
    /// Code Ensemble.
    CodeEnsemble(CodeEnsemblePlan),
}

impl From<ScanPlan> for MethodPlan {
    fn from(plan: ScanPlan) -> Self {
        MethodPlan::Fsm(plan)
    }
}

impl From<&ScanPlan> for MethodPlan {
    fn from(plan: &ScanPlan) -> Self {
        MethodPlan::Fsm(*plan)
    }
}

impl From<&MethodPlan> for MethodPlan {
    fn from(plan: &MethodPlan) -> Self {
        *plan
    }
}

/// `MethodPlan::from(plan)` and `MethodPlan::from(&plan)` for each baseline's plan type.
macro_rules! from_baseline {
    ($($plan:ty => $variant:ident),*) => {$(
        impl From<$plan> for MethodPlan {
            fn from(plan: $plan) -> Self {
                MethodPlan::$variant(plan)
            }
        }

        impl From<&$plan> for MethodPlan {
            fn from(plan: &$plan) -> Self {
                MethodPlan::$variant(*plan)
            }
        }
    )*};
}

from_baseline!(
    PhaseShiftPlan => PhaseShift,
    MicroPhaseShiftPlan => MicroPhaseShift,
    LineScanPlan => LineScan,
    CodeEnsemblePlan => CodeEnsemble
);

/// The table names of the baselines' plan files, in [`MethodPlan`] order.
pub const BASELINE_TABLES: [&str; 4] = [
    "phase_shift",
    "micro_phase_shift",
    "line_scan",
    "code_ensemble",
];

/// A plan that breaks a rule of its method (each message names the field).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // each variant holds its method's error
pub enum MethodPlanError {
    Fsm(PlanError),
    PhaseShift(PhaseShiftError),
    MicroPhaseShift(MicroPhaseShiftError),
    LineScan(LineScanError),
    CodeEnsemble(CodeEnsembleError),
}

impl fmt::Display for MethodPlanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MethodPlanError::Fsm(e) => write!(f, "{e}"),
            MethodPlanError::PhaseShift(e) => write!(f, "{e}"),
            MethodPlanError::MicroPhaseShift(e) => write!(f, "{e}"),
            MethodPlanError::LineScan(e) => write!(f, "{e}"),
            MethodPlanError::CodeEnsemble(e) => write!(f, "{e}"),
        }
    }
}

impl MethodPlan {
    /// The patterns the plan shows.
    pub fn patterns(&self) -> &dyn PatternSequence {
        match self {
            MethodPlan::Fsm(p) => p,
            MethodPlan::PhaseShift(p) => p,
            MethodPlan::MicroPhaseShift(p) => p,
            MethodPlan::LineScan(p) => p,
            MethodPlan::CodeEnsemble(p) => p,
        }
    }

    /// The method's short name in tables and summaries: BFSM, EFSM, PS, MPS, LS or CE.
    pub fn name(&self) -> &'static str {
        match self {
            MethodPlan::Fsm(p) => match p.method {
                Method::Bfsm => "BFSM",
                Method::Efsm(_) => "EFSM",
            },
            MethodPlan::PhaseShift(_) => "PS",
            MethodPlan::MicroPhaseShift(_) => "MPS",
            MethodPlan::LineScan(_) => "LS",
            MethodPlan::CodeEnsemble(_) => "CE",
        }
    }

    /// The plan file's table for a baseline; `None` for FSM (whose fields are top level).
    pub fn table(&self) -> Option<&'static str> {
        match self {
            MethodPlan::Fsm(_) => None,
            MethodPlan::PhaseShift(_) => Some(BASELINE_TABLES[0]),
            MethodPlan::MicroPhaseShift(_) => Some(BASELINE_TABLES[1]),
            MethodPlan::LineScan(_) => Some(BASELINE_TABLES[2]),
            MethodPlan::CodeEnsemble(_) => Some(BASELINE_TABLES[3]),
        }
    }

    /// The FSM plan, if it is one.
    pub fn as_fsm(&self) -> Option<&ScanPlan> {
        match self {
            MethodPlan::Fsm(p) => Some(p),
            _ => None,
        }
    }

    /// Checks the method's rules.
    pub fn check(&self) -> Result<(), MethodPlanError> {
        match self {
            MethodPlan::Fsm(p) => p.validate().map_err(MethodPlanError::Fsm),
            MethodPlan::PhaseShift(p) => p.validate().map_err(MethodPlanError::PhaseShift),
            MethodPlan::MicroPhaseShift(p) => {
                p.validate().map_err(MethodPlanError::MicroPhaseShift)
            }
            MethodPlan::LineScan(p) => p.validate().map_err(MethodPlanError::LineScan),
            MethodPlan::CodeEnsemble(p) => p.validate().map_err(MethodPlanError::CodeEnsemble),
        }
    }

    /// The fingerprint candidate files of its decodes carry (patterns and decoder settings).
    pub fn fingerprint(&self) -> u64 {
        self.patterns().fingerprint()
    }

    /// The fingerprint row dumps and image stacks of its captures carry (the patterns alone).
    pub fn pattern_fingerprint(&self) -> u64 {
        self.patterns().pattern_fingerprint()
    }

    /// Every fingerprint of the plan (an FSM plan's legacy one included).
    pub fn identity(&self) -> PlanIdentity {
        self.patterns().identity()
    }

    /// Frames in the sequence.
    pub fn frame_count(&self) -> usize {
        self.patterns().frame_count()
    }

    /// Projector columns.
    pub fn projector_columns(&self) -> u16 {
        self.patterns().projector_columns()
    }

    /// The noise RMS of the amplitude the method's decoder gives a dark pixel's light, sensor
    /// DN ([`Decoder::dark_column_noise_dn`] for FSM: one column of the light profile or one
    /// bin of the spectrum; [`PixelDecoder::dark_amplitude_noise_dn`] for the others): what a
    /// point's quality is measured in.
    pub fn dark_amplitude_noise_dn(&self, bit_depth: u8) -> f32 {
        match self {
            MethodPlan::Fsm(p) => Decoder::dark_column_noise_dn(p, bit_depth),
            MethodPlan::PhaseShift(p) => p.dark_amplitude_noise_dn(bit_depth),
            MethodPlan::MicroPhaseShift(p) => p.dark_amplitude_noise_dn(bit_depth),
            MethodPlan::CodeEnsemble(p) => p.dark_amplitude_noise_dn(bit_depth),
            MethodPlan::LineScan(p) => p.dark_amplitude_noise_dn(bit_depth),
        }
    }

    /// Whether each light the method decodes is measured, with a noise its amplitude is judged
    /// against (FSM, line scanning), rather than named by a code whose unwrapping or
    /// quantisation can be wrong by whole periods or codewords (phase shift, Micro Phase
    /// Shifting, Code Ensemble): the scan's confirmation of points by their neighbourhood is for
    /// the former; the comparison reports every point the codes decode.
    pub fn measures_lights(&self) -> bool {
        matches!(self, MethodPlan::Fsm(_) | MethodPlan::LineScan(_))
    }

    /// Floats of decoder tables the plan needs ([`Decoder::tables_len`]); the baselines need
    /// none.
    pub fn tables_len(&self) -> usize {
        match self {
            MethodPlan::Fsm(p) => Decoder::tables_len(p),
            _ => 0,
        }
    }

    /// Floats of scratch its decoder needs with `L` lanes ([`Decoder::scratch_len_lanes`]);
    /// the baselines need none.
    pub fn scratch_len_lanes<const L: usize>(&self) -> usize {
        match self {
            MethodPlan::Fsm(p) => Decoder::scratch_len_lanes::<L>(p),
            _ => 0,
        }
    }

    /// Checks the plan and builds its decoder tables in `tables` (nothing for a baseline): the
    /// costly part, once per plan ([`Decoder::build_tables`]).
    pub fn build_tables(&self, tables: &mut [f32]) -> Result<(), MethodDecoderError> {
        self.check().map_err(MethodDecoderError::Plan)?;
        match self {
            MethodPlan::Fsm(p) => {
                Decoder::build_tables(p, tables).map_err(MethodDecoderError::Tables)
            }
            _ => Ok(()),
        }
    }

    /// The header of a dump of this plan's frames.
    pub fn row_dump_header(&self, width: u32, height: u32, bit_depth: u8) -> RowDumpHeader {
        RowDumpHeader::for_patterns(
            self.pattern_fingerprint(),
            self.frame_count(),
            width,
            height,
            bit_depth,
        )
    }

    /// Checks that a dump was made with this plan's patterns (and frame count).
    pub fn check_row_dump(&self, header: &RowDumpHeader) -> Result<(), WireError> {
        header.check_identity(&self.identity(), self.frame_count())
    }
}

/// Why a decoder could not be built.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum MethodDecoderError {
    /// The plan breaks a rule of its method.
    Plan(MethodPlanError),
    /// FSM's tables are too short or were built for another plan.
    Tables(DecoderError),
}

impl fmt::Display for MethodDecoderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MethodDecoderError::Plan(e) => write!(f, "invalid plan: {e}"),
            MethodDecoderError::Tables(e) => write!(f, "{e}"),
        }
    }
}

/// The decoder of rows of any method's plan: FSM's [`Decoder`] over its tables, or a
/// baseline's [`PixelDecoder`], which needs no tables and no scratch. Every method's rows give
/// the same candidate records.
// One per camera or per row loop, on the stack: boxing FSM's would need an allocator.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Copy, Debug)]
pub enum MethodDecoder<'t> {
    /// BFSM or EFSM.
    Fsm(Decoder<'t>),
    /// Phase shift + Gray code.
    PhaseShift(PhaseShiftPlan),
    /// Micro Phase Shifting.
    MicroPhaseShift(MicroPhaseShiftPlan),
    /// Line scanning.
    LineScan(LineScanPlan),
    /// Code Ensemble.
    CodeEnsemble(CodeEnsemblePlan),
}

impl<'t> MethodDecoder<'t> {
    /// Checks `plan`, builds its tables in `tables` (FSM) and borrows them.
    pub fn new(plan: &MethodPlan, tables: &'t mut [f32]) -> Result<Self, MethodDecoderError> {
        plan.build_tables(tables)?;
        Self::from_tables(plan, tables)
    }

    /// A decoder reading tables [`MethodPlan::build_tables`] built for the same plan (FSM's
    /// [`Decoder::from_tables`]; a baseline reads none).
    pub fn from_tables(plan: &MethodPlan, tables: &'t [f32]) -> Result<Self, MethodDecoderError> {
        plan.check().map_err(MethodDecoderError::Plan)?;
        Ok(match *plan {
            MethodPlan::Fsm(p) => MethodDecoder::Fsm(
                Decoder::from_tables(&p, tables).map_err(MethodDecoderError::Tables)?,
            ),
            MethodPlan::PhaseShift(p) => MethodDecoder::PhaseShift(p),
            MethodPlan::MicroPhaseShift(p) => MethodDecoder::MicroPhaseShift(p),
            MethodPlan::LineScan(p) => MethodDecoder::LineScan(p),
            MethodPlan::CodeEnsemble(p) => MethodDecoder::CodeEnsemble(p),
        })
    }

    /// The plan this decoder decodes.
    pub fn plan(&self) -> MethodPlan {
        match self {
            MethodDecoder::Fsm(d) => MethodPlan::Fsm(*d.plan()),
            MethodDecoder::PhaseShift(p) => MethodPlan::PhaseShift(*p),
            MethodDecoder::MicroPhaseShift(p) => MethodPlan::MicroPhaseShift(*p),
            MethodDecoder::LineScan(p) => MethodPlan::LineScan(*p),
            MethodDecoder::CodeEnsemble(p) => MethodPlan::CodeEnsemble(*p),
        }
    }

    /// Decodes every pixel of `row` into `out` ([`Decoder::decode_row`] or
    /// [`PixelDecoder::decode_row`]); `scratch` needs [`MethodPlan::scratch_len_lanes`] of
    /// [`crate::decoder::MAX_LANES`] floats.
    pub fn decode_row<const K: usize>(
        &self,
        row: &Row<'_>,
        scratch: &mut [f32],
        out: &mut [PixelCandidates<K>],
    ) -> Result<(), RowError> {
        match self {
            MethodDecoder::Fsm(d) => d.decode_row(row, scratch, out),
            MethodDecoder::PhaseShift(p) => p.decode_row(row, out),
            MethodDecoder::MicroPhaseShift(p) => p.decode_row(row, out),
            MethodDecoder::LineScan(p) => p.decode_row(row, out),
            MethodDecoder::CodeEnsemble(p) => p.decode_row(row, out),
        }
    }

    /// Decodes every pixel of `row` into `out`, an FSM plan `L` pixels at a time
    /// ([`Decoder::decode_row_lanes`]; the same bits for every `L`), a baseline pixel by pixel.
    #[inline(always)]
    pub fn decode_row_lanes<const L: usize, const K: usize>(
        &self,
        row: &Row<'_>,
        scratch: &mut [f32],
        out: &mut [PixelCandidates<K>],
    ) -> Result<(), RowError> {
        match self {
            MethodDecoder::Fsm(d) => d.decode_row_lanes::<L, K>(row, scratch, out),
            MethodDecoder::PhaseShift(p) => p.decode_row(row, out),
            MethodDecoder::MicroPhaseShift(p) => p.decode_row(row, out),
            MethodDecoder::LineScan(p) => p.decode_row(row, out),
            MethodDecoder::CodeEnsemble(p) => p.decode_row(row, out),
        }
    }

    /// Decodes pixel `x` of `row` into `out`: the same bits as the whole row gives it.
    pub fn decode_pixel<const K: usize>(
        &self,
        row: &Row<'_>,
        x: usize,
        scratch: &mut [f32],
        out: &mut PixelCandidates<K>,
    ) -> Result<(), RowError> {
        match self {
            MethodDecoder::Fsm(d) => d.decode_pixel(row, x, scratch, out),
            MethodDecoder::PhaseShift(p) => p.decode_row_pixel(row, x, out),
            MethodDecoder::MicroPhaseShift(p) => p.decode_row_pixel(row, x, out),
            MethodDecoder::LineScan(p) => p.decode_row_pixel(row, x, out),
            MethodDecoder::CodeEnsemble(p) => p.decode_row_pixel(row, x, out),
        }
    }
}
