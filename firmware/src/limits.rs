//! The largest plan and row the camera accepts, and the memory that takes.
//!
//! Every buffer is sized here, at compile time; nothing is allocated at run time. The camera
//! accepts:
//!
//! - **any valid plan of any method whose decoder tables fit [`MAX_TABLE_FLOATS`]** (6 MiB; the
//!   baselines, phase shift, Micro Phase Shifting, Code Ensemble and line scanning, need no
//!   tables and no scratch, only room for their rows, checked the same way): the paper's BFSM
//!   plan needs 184,320 floats, its EFSM plans (cB 64) 19,328; the largest valid plan found by
//!   a scan over power-of-two transforms and periods (BFSM, 8192 columns, N 4096, Hann window)
//!   1,445,888. A plan that needs more is refused (`DeviceError::PlanTooLarge`);
//! - **rows of at most [`MAX_WIDTH`] pixels and [`MAX_ROW_SAMPLES`] samples** (`W·M`): the paper's
//!   BFSM plan (770 frames with the dark and white references) and its EFSM plans (78 or 154
//!   frames) up to the full 4096 pixels. A row arrives whole (one record, in the receive
//!   buffer) but is decoded in slices of [`SLICE_SAMPLES`] samples (`scan::decode_row`): only
//!   the slice is unpacked, so a wide row costs its record's bytes, not twice them. Plans of
//!   more than [`MAX_FRAMES`] frames are refused (a slice holds at least [`LANES`] pixels);
//! - **up to [`CANDIDATE_CAPACITY`] candidates per pixel** (more are dropped weakest first and
//!   the pixel is flagged `TRUNCATED`, as on the host).
//!
//! `memory::MEMORY_BYTES` is the size of all buffers together (about 27 MB, in `.bss`; every
//! Zynq-7000 board has at least 256 MB of DDR, QEMU's model 128 MiB); the build prints the
//! image's text/data/bss (`scripts/build-arm.sh`).

use fsm_core::plan::MAX_TRANSFORM_SIZE;
use fsm_core::wire::candidates::{CANDIDATE_LEN, PIXEL_LEN, RECORD_OVERHEAD};
use fsm_core::PixelCandidates;
use fsm_protocol::frame::max_frame_len;

/// Most pixels per row.
pub const MAX_WIDTH: usize = 4096;
/// Most samples per row, `W·M`: 4096 pixels of the paper's BFSM plan (770 frames), 6.3 MB of
/// `u16` in a row record.
pub const MAX_ROW_SAMPLES: usize = MAX_WIDTH * 770;
/// Samples of the slice of a row unpacked at once (512 KiB of `u16`): 340 pixels of the
/// paper's BFSM plan, 1,702 of its two-group EFSM plan.
pub const SLICE_SAMPLES: usize = 1 << 18;
/// Most frames per row: a slice holds [`LANES`] pixels at least.
pub const MAX_FRAMES: usize = SLICE_SAMPLES / LANES;
/// Most candidates per pixel; the `capacity` of every candidate header the camera writes.
/// `fsm decode` must decode with the same capacity for its files to be byte-identical.
pub const CANDIDATE_CAPACITY: usize = 16;

/// Candidates of one pixel, as the camera stores them.
pub type Pixel = PixelCandidates<CANDIDATE_CAPACITY>;

/// Floats of decoder tables (`Decoder::tables_len`: kernel, fit operators, window) the camera
/// holds: 6 MiB.
pub const MAX_TABLE_FLOATS: usize = 3 << 19;
/// Pixels the camera decodes at once (`Decoder::decode_row_lanes`): the 4 lanes of a NEON
/// register on the Cortex-A9 (`fsm_core::decoder::DEFAULT_LANES`; NEON flushes subnormal floats,
/// which the decoder never meets, see `fsm_core`'s `transform/simd.rs`). Any lane count gives the
/// same candidates; the host decodes 4, 8 or 16 at once.
pub const LANES: usize = fsm_core::decoder::DEFAULT_LANES;
/// Floats of decoder scratch of the largest plan (`Decoder::scratch_len_lanes` with
/// [`LANES`]): the DFT searches' of `N = 4096`, or the cosine search's of an odd span of 4095
/// (its transform takes the longer route), whichever is larger.
pub const MAX_SCRATCH_FLOATS: usize = {
    let dft = (MAX_TRANSFORM_SIZE + 2) + (MAX_TRANSFORM_SIZE / 2 + 1);
    let span = MAX_TRANSFORM_SIZE - 1;
    let cosine = (span + 1 + 4 * span) * LANES + span + 1;
    if dft > cosine {
        dft
    } else {
        cosine
    }
};
/// Bytes of the largest row-dump record (`8 + 2·W·M`).
pub const MAX_ROW_RECORD: usize = 8 + 2 * MAX_ROW_SAMPLES;
/// Bytes of the largest candidate record.
pub const MAX_CANDIDATE_RECORD: usize =
    RECORD_OVERHEAD + MAX_WIDTH * (PIXEL_LEN + CANDIDATE_LEN * CANDIDATE_CAPACITY);
/// Bytes of the record buffer: a candidate record, or a row-dump record for raw output.
pub const MAX_RECORD: usize = if MAX_ROW_RECORD > MAX_CANDIDATE_RECORD {
    MAX_ROW_RECORD
} else {
    MAX_CANDIDATE_RECORD
};
/// Bytes a message adds around a record: tag and length varints (at most 1 + 5).
const MESSAGE_OVERHEAD: usize = 8;
/// Longest request frame (a `Row` of the largest record), delimiters included.
pub const MAX_REQUEST_FRAME: usize = max_frame_len(MAX_ROW_RECORD + MESSAGE_OVERHEAD);
/// Longest response frame (a record of [`MAX_RECORD`] bytes).
pub const MAX_RESPONSE_FRAME: usize = max_frame_len(MAX_RECORD + MESSAGE_OVERHEAD);

// Sizes travel as u32 in the protocol.
const _: () = assert!(MAX_WIDTH <= MAX_ROW_SAMPLES && MAX_ROW_SAMPLES <= u32::MAX as usize);
const _: () = assert!(MAX_FRAMES >= 1 && MAX_FRAMES * LANES <= SLICE_SAMPLES);
const _: () = assert!(CANDIDATE_CAPACITY <= u8::MAX as usize);

#[cfg(test)]
mod tests {
    use super::*;
    use fsm_core::{Decoder, GroupCount, ScanPlan};

    #[test]
    fn presets_fit() {
        for plan in [
            ScanPlan::paper_bfsm(),
            ScanPlan::paper_efsm(GroupCount::One),
            ScanPlan::paper_efsm(GroupCount::Two),
        ] {
            for plan in [plan, plan.with_clean()] {
                assert!(Decoder::tables_len(&plan) <= MAX_TABLE_FLOATS);
                assert!(Decoder::scratch_len_lanes::<LANES>(&plan) <= MAX_SCRATCH_FLOATS);
            }
        }
        // The widths and slices the module docs promise.
        let bfsm = ScanPlan::paper_bfsm().sequence_len();
        assert_eq!(MAX_ROW_SAMPLES / bfsm, 4096);
        assert_eq!(SLICE_SAMPLES / bfsm, 340);
        let efsm2 = ScanPlan::paper_efsm(GroupCount::Two).sequence_len();
        assert!(MAX_WIDTH * efsm2 <= MAX_ROW_SAMPLES);
        assert_eq!(SLICE_SAMPLES / efsm2, 1702);
        assert!(bfsm <= MAX_FRAMES);
    }

    #[test]
    fn largest_plans_fit() {
        // The largest plan the module docs name: BFSM over 8192 columns, N = 4096, Hann.
        let mut plan = ScanPlan::paper_bfsm();
        plan.projector_columns = 8192;
        plan.band.period_columns = 16384;
        plan.band.count = 4096;
        plan.transform_size = 4096;
        let cosine = plan;
        let mut plan = plan.with_clean();
        plan.decoding.window = fsm_core::Window::Hann;
        assert_eq!(plan.validate(), Ok(()));
        assert!(Decoder::tables_len(&plan) <= MAX_TABLE_FLOATS);
        assert!(Decoder::scratch_len_lanes::<LANES>(&plan) <= MAX_SCRATCH_FLOATS);
        // The cosine search over the same band, and over the largest odd span.
        assert!(Decoder::tables_len(&cosine) <= MAX_TABLE_FLOATS);
        assert!(Decoder::scratch_len_lanes::<LANES>(&cosine) <= MAX_SCRATCH_FLOATS);
        let mut odd = cosine;
        odd.projector_columns = 4095;
        odd.band.period_columns = 8190;
        odd.band.count = 4095;
        assert_eq!(odd.validate(), Ok(()));
        assert!(Decoder::tables_len(&odd) <= MAX_TABLE_FLOATS);
        assert_eq!(
            Decoder::scratch_len_lanes::<LANES>(&odd),
            MAX_SCRATCH_FLOATS
        );
    }
}
