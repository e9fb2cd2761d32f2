//! The round trip: `fsm patterns` images, captured as if by a camera looking at a flat
//! white wall (identity light transport plus noise, quantised to 10/12 bits in 16-bit PNGs),
//! decode to the projector column of every pixel within 0.05 column — BFSM and EFSM with two
//! groups — and the candidate file, the column map and the preview agree.

use crate::support;

use std::path::Path;

use fsm_core::{GroupCount, ScanPlan};
use fsm_io::candidate_file::{CandidateReader, HostCandidates, CANDIDATE_FILE_NAME};
use fsm_io::capture::Capture;
use fsm_io::column_map::{COLUMN_PREVIEW_NAME, COLUMN_TIFF_NAME};
use fsm_io::decode::{self, DecodeOptions};
use fsm_io::image_files::{self, ImageFormat};
use fsm_io::patterns::{write_pattern_set, PatternOptions};
use fsm_io::progress::Progress;
use support::FlatWall;

const TOLERANCE_COLUMNS: f32 = 0.05;

/// Writes the patterns, captures them, decodes; returns the worst error and the decoded folder.
fn round_trip(
    plan: &ScanPlan,
    wall: FlatWall,
    rows: u32,
    sixteen_bit_patterns: bool,
    dir: &Path,
) -> f32 {
    let patterns = dir.join("patterns");
    let options = PatternOptions {
        width: None,
        height: rows,
        sixteen_bit: sixteen_bit_patterns,
        format: ImageFormat::Png,
        response: None,
    };
    write_pattern_set(plan, &options, None, &patterns, false, &Progress::hidden()).unwrap();
    let captures = dir.join("captures");
    let (width, height) = wall.capture(&patterns, &captures);
    assert_eq!((width, height), (plan.projector_columns as u32, rows));

    let capture = Capture::open_stack(&captures, plan, Some(wall.bits)).unwrap();
    let out = dir.join("decoded");
    // A small budget forces several bands: banding must not change anything.
    let options = DecodeOptions {
        memory_budget_bytes: capture.row_len() as u64 * 2 * 2,
        threads: 2,
    };
    let summary =
        decode::decode_to_dir(plan, &capture, &out, false, &options, &Progress::hidden()).unwrap();
    assert_eq!(summary.rows_per_batch, 2);
    assert_eq!(summary.pixels(), width as u64 * height as u64);

    let mut reader = CandidateReader::open(&out.join(CANDIDATE_FILE_NAME)).unwrap();
    assert_eq!(reader.header().plan_fingerprint, plan.fingerprint());
    let (_, _, map) = image_files::read_tiff_f32(&out.join(COLUMN_TIFF_NAME)).unwrap();
    let preview = image_files::probe(&out.join(COLUMN_PREVIEW_NAME));
    assert!(
        preview.is_err(),
        "the preview is a colour PNG, not a grey capture"
    );
    let mut pixels = vec![HostCandidates::new(); width as usize];
    let mut worst = 0.0f32;
    while let Some(y) = reader.next_row(&mut pixels).unwrap() {
        for (x, p) in pixels.iter().enumerate() {
            let strongest = p.strongest().map(|c| c.column);
            let in_map = map[y as usize * width as usize + x];
            assert_eq!(
                strongest.unwrap_or(f32::NAN).to_bits(),
                in_map.to_bits(),
                "map at ({x}, {y})"
            );
            if x == 0 && matches!(plan.method, fsm_core::Method::Bfsm) {
                // BFSM cannot see projector column 0: cos(2π f·0) = 1 for every fringe, so the
                // pixel's samples are constant and carry no frequency (SPEC, core README).
                continue;
            }
            let required = match (plan.method, plan.group_count()) {
                // One EFSM group drops peaks within the border guard cg of a block border (the
                // fringes are discontinuous there; a second group covers them, SPEC §3). Near
                // the guard's edge noise decides; further inside a candidate is required.
                (fsm_core::Method::Efsm(coding), 1) => {
                    let (_, local) = plan.block_of(x as u32, fsm_core::Group::One);
                    fsm_core::block::border_margin(local as f32, &coding)
                        >= coding.border_guard + 0.5
                }
                _ => true,
            };
            let Some(column) = strongest else {
                assert!(!required, "pixel ({x}, {y}) has no candidate");
                continue;
            };
            let error = (column - x as f32).abs();
            assert!(
                error <= TOLERANCE_COLUMNS,
                "pixel ({x}, {y}): column {column}, expected {x}"
            );
            worst = worst.max(error);
        }
    }
    worst
}

#[test]
fn bfsm_flat_wall_decodes_every_column() {
    let dir = tempfile::tempdir().unwrap();
    let worst = round_trip(
        &ScanPlan::paper_bfsm(),
        FlatWall::twelve_bit(),
        3,
        false,
        dir.path(),
    );
    eprintln!("BFSM, 8-bit patterns, 12-bit captures: worst error {worst:.4} column");
}

#[test]
fn efsm_two_groups_flat_wall_decodes_every_column() {
    let dir = tempfile::tempdir().unwrap();
    let plan = ScanPlan::paper_efsm(GroupCount::Two);
    let worst = round_trip(&plan, FlatWall::ten_bit(), 3, false, dir.path());
    eprintln!("EFSM two groups, 8-bit patterns, 10-bit captures: worst error {worst:.4} column");
}

#[test]
fn efsm_one_group_sixteen_bit_patterns_decode_every_column() {
    let dir = tempfile::tempdir().unwrap();
    let plan = ScanPlan::paper_efsm(GroupCount::One);
    let worst = round_trip(&plan, FlatWall::twelve_bit(), 2, true, dir.path());
    eprintln!("EFSM one group, 16-bit patterns, 12-bit captures: worst error {worst:.4} column");
}
