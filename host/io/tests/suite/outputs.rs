//! The checks an output passes before any work, and what the commands say they wrote.

use fsm_io::decode::files_written;
use fsm_io::outputs::check_file_target_not;
use fsm_io::projector_response::{capture_fractions, grey_level_fractions};
use fsm_io::projector_response::{write_grey_level_set, GREY_LEVELS_MANIFEST};

#[test]
fn an_output_may_not_be_its_input_even_with_force() {
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.yml");
    std::fs::write(&input, "x").unwrap();
    // The same file by another spelling is still the input.
    let same = dir.path().join(".").join("in.yml");
    let e = check_file_target_not(&same, &input, true, "the input file").unwrap_err();
    let e = e.to_string();
    assert_eq!(e, format!("--out {} is the input file", same.display()));
    // Another file follows check_file_target's rule: new is fine, existing needs replace.
    let other = dir.path().join("out.toml");
    check_file_target_not(&other, &input, false, "the input file").unwrap();
    std::fs::write(&other, "y").unwrap();
    let e = check_file_target_not(&other, &input, false, "the input file").unwrap_err();
    assert!(e.to_string().contains("file exists"), "{e}");
    check_file_target_not(&other, &input, true, "the input file").unwrap();
}

#[test]
fn decode_names_the_files_it_wrote() {
    let line = files_written(std::path::Path::new("decoded"));
    assert_eq!(
        line,
        "wrote decoded/{candidates.fsmc, column.tiff, column.png}"
    );
}

#[test]
fn the_captures_codes_come_from_the_manifest_else_from_the_levels() {
    let dir = tempfile::tempdir().unwrap();
    let set = dir.path().join("levels");
    let format = fsm_io::image_files::ImageFormat::Png;
    write_grey_level_set(&set, 5, 4, 2, true, format, false).unwrap();
    let manifest = set.join(GREY_LEVELS_MANIFEST);
    // The manifest's codes win over the levels given (16-bit codes here, not 9 8-bit ones).
    let from_manifest = capture_fractions(Some(&manifest), 9, false).unwrap();
    assert_eq!(from_manifest, grey_level_fractions(5, true).unwrap());
    assert_eq!(
        capture_fractions(None, 9, false).unwrap(),
        grey_level_fractions(9, false).unwrap()
    );
    assert!(capture_fractions(None, 2, false).is_err());
}

#[test]
fn optional_outputs_are_checked_together() {
    use fsm_io::outputs::check_file_targets;
    let dir = tempfile::tempdir().unwrap();
    let (new, old) = (dir.path().join("new.json"), dir.path().join("old.json"));
    std::fs::write(&old, "{}").unwrap();
    check_file_targets(None, false).unwrap();
    check_file_targets(Some(new.as_path()), false).unwrap();
    let e = check_file_targets([new.as_path(), old.as_path()], false).unwrap_err();
    assert!(
        e.to_string()
            .starts_with(&format!("{}: file exists", old.display())),
        "{e}"
    );
    check_file_targets([new.as_path(), old.as_path()], true).unwrap();
}

#[test]
fn image_sets_say_what_they_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let format = fsm_io::image_files::ImageFormat::Png;
    let set = dir.path().join("levels");
    let levels = write_grey_level_set(&set, 3, 4, 2, false, format, false).unwrap();
    assert_eq!(
        levels.written_to(&set),
        format!(
            "wrote 3 grey-level images of 4x2 (8-bit, codes 0, 128, 255) and levels.json to {}",
            set.display()
        )
    );
    let plan = fsm_io::plan_file::MethodPlan::Fsm(fsm_core::ScanPlan::paper_efsm(
        fsm_core::GroupCount::One,
    ));
    let options = fsm_io::patterns::PatternOptions {
        width: None,
        height: 2,
        sixteen_bit: false,
        format,
        response: None,
    };
    let out = dir.path().join("patterns");
    let progress = fsm_io::progress::Progress::hidden();
    let manifest =
        fsm_io::patterns::write_method_pattern_set(&plan, &options, None, &out, false, &progress)
            .unwrap();
    let frames = manifest.frames.len();
    assert_eq!(
        manifest.written_to(&out),
        format!(
            "wrote {frames} images of 768x2 (8-bit) and manifest.json to {}",
            out.display()
        )
    );
}
