//! # fsm-core: the Frequency Shift Method decoder
//!
//! `no_std`, allocation-free decoding of structured-light scans made with the Frequency Shift
//! Method (Djupkep Dizeu et al., IEEE TIM 2022). The method and its conventions are stated in
//! the repository's `docs/spec.md`, the "SPEC §n" these docs cite. The same code runs on the
//! camera's ARM core and on the host, and gives bit-identical candidates on both.
//!
//! The pipeline of one pixel, one module per stage:
//!
//! | stage | module | paper |
//! |---|---|---|
//! | what is projected, in which order | [`plan`], [`plan::sequence`] | eqs. 4–8, 14 |
//! | the exact inverse of the full band (DCT-I), lane-parallel | [`transform::cosine`], [`transform::fft`] | SPEC §2b |
//! | mean removal, window, zero padding, real DFT; modelled kernel | [`transform::spectrum`], [`transform::kernel`] | §III-D, eq. 9 |
//! | sensor noise through the transform; expected scatter | [`noise`] | eqs. 21–22 |
//! | sub-pixel column | [`peak`], [`peak::deconvolution`] | refs. \[31\], \[42\] |
//! | lights of a pixel: cosine search (default), CLEAN, local maxima | [`search`] | §III-D, SPEC §2, §2b |
//! | EFSM border guard, blocks, candidates | [`block`] | eqs. 16–20 |
//! | candidates of a pixel | [`candidate`] | eq. 18 |
//! | one temporal row → candidates of every pixel | [`decoder`] | §III-F, §IV-B |
//! | plans, row dumps, candidate rows as bytes | [`wire`] | SPEC §6 |
//! | the methods FSM is compared with (phase shift, Micro Phase Shifting, line scanning), same candidates | [`baseline`] | eqs. 1–3, §VII, §VIII-F |
//! | any method's plan, its bytes and its row decoder | [`methods`] | SPEC §6 |
//!
//! ```
//! use fsm_core::{Decoder, PixelCandidates, Row, ScanPlan};
//!
//! let plan = ScanPlan::paper_bfsm();
//! let mut tables = vec![0.0; Decoder::tables_len(&plan)];
//! let decoder = Decoder::new(&plan, &mut tables).unwrap();
//! // A row of 2 pixels; pixel 1 is lit by projector column 300 with modulation 100 DN.
//! let width = 2;
//! let mut frames = vec![0u16; plan.sequence_len() * width];
//! for (i, pattern) in plan.sequence().enumerate() {
//!     frames[i * width] = 20;
//!     frames[i * width + 1] = (20.0 + 200.0 * plan.intensity(pattern, 300)).round() as u16;
//! }
//! let row = Row { frames: &frames, width, bit_depth: 12, column_limits: None };
//! let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
//! let mut out = [PixelCandidates::<4>::new(), PixelCandidates::new()];
//! decoder.decode_row(&row, &mut scratch, &mut out).unwrap();
//! assert!(out[0].candidates.is_empty());
//! assert!((out[1].strongest().unwrap().column - 300.0).abs() < 0.05);
//! ```
#![no_std]
// The NEON intrinsics are stable on AArch64 only; the camera's ARMv7 build (Debian's rustc with
// `-Zbuild-std`, `firmware/scripts/build-arm.sh`) opts in. Host builds never see this line.
#![cfg_attr(
    all(target_arch = "arm", target_feature = "neon"),
    feature(stdarch_arm_neon_intrinsics)
)]
// One audited exception: `math::sqrt` on the ARM hard-float target (one VFP instruction).
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod baseline;
pub mod block;
pub mod candidate;
pub mod decoder;
pub mod math;
pub mod methods;
pub mod noise;
pub mod peak;
pub mod plan;
pub mod search;
pub mod transform;
pub mod wire;

pub use baseline::code_ensemble::CodeEnsemblePlan;
pub use baseline::line_scan::LineScanPlan;
pub use baseline::micro_phase_shift::MicroPhaseShiftPlan;
pub use baseline::phase_shift::PhaseShiftPlan;
pub use baseline::{PatternSequence, PixelDecoder};
pub use candidate::{Candidate, ColumnRange, GroupSet, PixelCandidates, PixelFlags};
pub use decoder::{Decoder, DecoderError, Row, RowError};
pub use methods::{MethodDecoder, MethodDecoderError, MethodPlan, MethodPlanError};
pub use peak::{Peak, PeakList};
pub use plan::sequence::{Group, Pattern};
pub use plan::{
    BlockCoding, DecodeSettings, FringeBand, GroupCount, Method, PatternLevels, PeakEstimator,
    PeakSearch, PlanError, References, ScanPlan, SensorNoise, Window,
};
