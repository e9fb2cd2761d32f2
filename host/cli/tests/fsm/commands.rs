//! The real `fsm` binary end to end: plan → patterns → (flat-wall captures) → convert →
//! decode from the stack and from the dump (byte-identical candidate files) → inspect; and bad
//! input — wrong image count, size or bit depth, a foreign plan, a corrupted dump — exits
//! non-zero with a message naming what and where, leaving no output behind.

use std::path::PathBuf;

use crate::flat_wall::{entries, FlatWall};
use crate::run::{fails, ok, s};
use fsm_io::candidate_file::{CandidateReader, HostCandidates, CANDIDATE_FILE_NAME};

/// A scan folder: EFSM two groups, 3 camera rows, 12-bit flat-wall captures.
struct Scan {
    dir: tempfile::TempDir,
    plan: PathBuf,
    captures: PathBuf,
}

fn scan() -> Scan {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan.toml");
    ok(&["plan", "--preset", "paper-efsm-2", "--out", s(&plan)]);
    let patterns = dir.path().join("patterns");
    ok(&[
        "patterns",
        "--plan",
        s(&plan),
        "--height",
        "3",
        "--out",
        s(&patterns),
    ]);
    let captures = dir.path().join("captures");
    FlatWall::twelve_bit().capture(&patterns, &captures);
    Scan {
        dir,
        plan,
        captures,
    }
}

/// `fsm convert` of the scan's images into `scan.dump` beside them.
fn dump_of(scan: &Scan) -> PathBuf {
    let dump = scan.dir.path().join("scan.dump");
    ok(&[
        "convert",
        "--plan",
        s(&scan.plan),
        "--images",
        s(&scan.captures),
        "--bit-depth",
        "12",
        "--out",
        s(&dump),
    ]);
    dump
}

fn capture_file(scan: &Scan, frame: usize) -> PathBuf {
    scan.captures.join(format!("{frame:04}.png"))
}

#[test]
fn stack_and_dump_decode_to_identical_candidate_files() {
    let scan = scan();
    let dump = dump_of(&scan);
    let from_stack = scan.dir.path().join("from-stack");
    let from_dump = scan.dir.path().join("from-dump");
    // Different budgets and threads: banding and batching must not change a byte.
    ok(&[
        "decode",
        "--plan",
        s(&scan.plan),
        "--images",
        s(&scan.captures),
        "--bit-depth",
        "12",
        "--out",
        s(&from_stack),
        "--memory-budget",
        "1",
        "--threads",
        "1",
    ]);
    ok(&[
        "decode",
        "--plan",
        s(&scan.plan),
        "--dump",
        s(&dump),
        "--out",
        s(&from_dump),
        "--threads",
        "2",
    ]);
    let a = std::fs::read(from_stack.join(CANDIDATE_FILE_NAME)).unwrap();
    let b = std::fs::read(from_dump.join(CANDIDATE_FILE_NAME)).unwrap();
    assert_eq!(a, b, "candidate files differ");
    for name in ["column.tiff", "column.png"] {
        assert_eq!(
            std::fs::read(from_stack.join(name)).unwrap(),
            std::fs::read(from_dump.join(name)).unwrap(),
            "{name}"
        );
    }
    // And the decode is right: every pixel's strongest candidate is its own column.
    let mut reader = CandidateReader::open(&from_dump.join(CANDIDATE_FILE_NAME)).unwrap();
    let mut pixels = vec![HostCandidates::new(); 768];
    while let Some(y) = reader.next_row(&mut pixels).unwrap() {
        for (x, p) in pixels.iter().enumerate() {
            let c = p
                .strongest()
                .unwrap_or_else(|| panic!("({x}, {y}) has no candidate"))
                .column;
            assert!((c - x as f32).abs() <= 0.05, "({x}, {y}): {c}");
        }
    }
}

#[test]
fn inspect_draws_a_pixel_and_a_row() {
    let scan = scan();
    let pixel_png = scan.dir.path().join("pixel.png");
    let stdout = ok(&[
        "inspect",
        "--plan",
        s(&scan.plan),
        "--images",
        s(&scan.captures),
        "--bit-depth",
        "12",
        "--pixel",
        "300,1",
        "--out",
        s(&pixel_png),
    ]);
    assert!(
        stdout.contains("pixel (300, 1): column 300.0")
            || stdout.contains("pixel (300, 1): column 299.9"),
        "{stdout}"
    );
    let row_png = scan.dir.path().join("row.png");
    ok(&[
        "inspect",
        "--plan",
        s(&scan.plan),
        "--images",
        s(&scan.captures),
        "--bit-depth",
        "12",
        "--row",
        "2",
        "--group",
        "2",
        "--out",
        s(&row_png),
    ]);
    for png in [&pixel_png, &row_png] {
        let bytes = std::fs::read(png).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        assert!(bytes.len() > 10_000, "{} is a real picture", png.display());
    }
    let e = fails(&[
        "inspect",
        "--plan",
        s(&scan.plan),
        "--images",
        s(&scan.captures),
        "--pixel",
        "768,0",
        "--out",
        s(&pixel_png),
        "--force",
    ]);
    assert!(e.contains("pixel (768, 0) is outside"), "{e}");
}

/// A decode that must fail before writing anything: the message holds every `needle`.
fn decode_fails(scan: &Scan, extra: &[&str], needles: &[&str]) {
    let out = scan.dir.path().join("decoded");
    let before = entries(scan.dir.path());
    let mut args = vec!["decode", "--plan", s(&scan.plan), "--out", s(&out)];
    args.extend_from_slice(extra);
    let e = fails(&args);
    for needle in needles {
        assert!(e.contains(needle), "message lacks {needle:?}: {e}");
    }
    assert_eq!(
        entries(scan.dir.path()),
        before,
        "output or temporary left behind"
    );
}

#[test]
fn wrong_image_count_is_refused() {
    let scan = scan();
    let last = capture_file(&scan, 153);
    std::fs::remove_file(&last).unwrap();
    decode_fails(
        &scan,
        &["--images", s(&scan.captures)],
        &[
            s(&scan.captures),
            "153 numbered images",
            "154 frames",
            "frame 153 is the first missing",
        ],
    );
    // A gap is named too.
    std::fs::rename(capture_file(&scan, 40), &last).unwrap();
    decode_fails(
        &scan,
        &["--images", s(&scan.captures)],
        &["frame 40 is the first missing"],
    );
}

#[test]
fn wrong_image_size_or_depth_is_refused_naming_the_frame() {
    let scan = scan();
    let frame = capture_file(&scan, 77);
    let (info, data) = fsm_io::image_files::read_image(&frame).unwrap();
    // One row short.
    let file = std::fs::File::create(&frame).unwrap();
    let short = &data[..(info.width * (info.height - 1)) as usize];
    fsm_io::image_files::write_png_gray16(file, info.width, info.height - 1, short).unwrap();
    decode_fails(
        &scan,
        &["--images", s(&scan.captures)],
        &[s(&frame), "frame 77", "768x2 16-bit", "768x3 16-bit"],
    );
    // 8-bit among 16-bit images.
    let file = std::fs::File::create(&frame).unwrap();
    let bytes: Vec<u8> = data.iter().map(|&v| (v >> 4) as u8).collect();
    fsm_io::image_files::write_png_gray8(file, info.width, info.height, &bytes).unwrap();
    decode_fails(
        &scan,
        &["--images", s(&scan.captures)],
        &[s(&frame), "frame 77", "8-bit"],
    );
}

#[test]
fn a_bit_depth_too_small_for_the_samples_is_refused() {
    let scan = scan();
    // 12-bit data declared 10-bit: the white frame (1) exceeds 1023 at its first pixel.
    decode_fails(
        &scan,
        &["--images", s(&scan.captures), "--bit-depth", "10"],
        &[
            s(&capture_file(&scan, 1)),
            "frame 1",
            "exceeds the 10-bit range",
        ],
    );
}

#[test]
fn a_dump_decodes_under_other_decoder_settings_but_not_with_other_patterns() {
    let scan = scan();
    let dump = dump_of(&scan);
    // The same patterns decoded with another threshold and fewer lights per pixel: the dump
    // names the patterns shown, not the decoder, so it decodes, and the candidate file names
    // the plan that decoded it.
    let retuned = scan.dir.path().join("retuned.json");
    ok(&[
        "plan",
        "--preset",
        "paper-efsm-2",
        "--set",
        "decoding.noise_factor=6",
        "--set",
        "decoding.max_peaks=2",
        "--out",
        s(&retuned),
    ]);
    let decoded = scan.dir.path().join("retuned-decoded");
    ok(&[
        "decode",
        "--plan",
        s(&retuned),
        "--dump",
        s(&dump),
        "--out",
        s(&decoded),
    ]);
    let retuned_plan = fsm_io::plan_file::read_method_plan(&retuned).unwrap();
    let original = fsm_io::plan_file::read_method_plan(&scan.plan).unwrap();
    assert_ne!(retuned_plan.fingerprint(), original.fingerprint());
    assert_eq!(
        retuned_plan.pattern_fingerprint(),
        original.pattern_fingerprint()
    );
    let reader = CandidateReader::open(&decoded.join(CANDIDATE_FILE_NAME)).unwrap();
    assert_eq!(reader.header().plan_fingerprint, retuned_plan.fingerprint());

    // Other patterns (a lower modulation PB): refused, naming the dump and both fingerprints.
    let other = scan.dir.path().join("other.json");
    ok(&[
        "plan",
        "--preset",
        "paper-efsm-2",
        "--set",
        "levels.amplitude=0.4",
        "--out",
        s(&other),
    ]);
    let other_plan = fsm_io::plan_file::read_method_plan(&other).unwrap();
    let out = scan.dir.path().join("decoded");
    let e = fails(&[
        "decode",
        "--plan",
        s(&other),
        "--dump",
        s(&dump),
        "--out",
        s(&out),
    ]);
    for part in [
        s(&dump).to_owned(),
        "patterns".to_owned(),
        format!("{:016x}", original.pattern_fingerprint()),
        format!("{:016x}", other_plan.pattern_fingerprint()),
    ] {
        assert!(e.contains(&part), "{part} missing from: {e}");
    }
    assert!(!out.exists());
}

#[test]
fn a_damaged_dump_is_refused_naming_the_row() {
    let scan = scan();
    let dump = dump_of(&scan);
    // A flipped byte in row 2's record: the decode starts, fails naming the row, leaves nothing.
    let mut bytes = std::fs::read(&dump).unwrap();
    let record_len = (bytes.len() - 64) / 3;
    bytes[64 + 2 * record_len + 1000] ^= 0x40;
    std::fs::write(&dump, &bytes).unwrap();
    decode_fails(
        &scan,
        &["--dump", s(&dump)],
        &[s(&dump), "record 2", "row 2", "corrupted"],
    );
    // Cut short: refused before any work.
    std::fs::write(&dump, &bytes[..bytes.len() - 10]).unwrap();
    decode_fails(
        &scan,
        &["--dump", s(&dump)],
        &[s(&dump), "truncated", "record 2", "row 2"],
    );
}

#[test]
fn plan_errors_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan.toml");
    ok(&["plan", "--preset", "paper-bfsm", "--out", s(&plan)]);
    let stdout = ok(&["plan", "--check", s(&plan)]);
    assert!(
        stdout.contains("770 (dark, white, 768 fringes)"),
        "{stdout}"
    );
    let text = std::fs::read_to_string(&plan).unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, text.replace("count = 768", "count = \"many\"")).unwrap();
    let e = fails(&["plan", "--check", s(&bad)]);
    assert!(e.contains(s(&bad)) && e.contains("band.count"), "{e}");
    std::fs::write(
        &bad,
        text.replace("transform_size = 1024", "transform_size = 1000"),
    )
    .unwrap();
    let e = fails(&["plan", "--check", s(&bad)]);
    assert!(e.contains("transform_size = 1000"), "{e}");
    let e = fails(&[
        "plan",
        "--preset",
        "paper-bfsm",
        "--set",
        "decoding.noise=3",
    ]);
    assert!(e.contains("decoding.noise"), "{e}");
    let out = dir.path().join("x.toml");
    fails(&[
        "plan",
        "--preset",
        "paper-bfsm",
        "--set",
        "band.count=3",
        "--out",
        s(&out),
    ]);
    assert!(!out.exists());
}

/// A reader that closed the tool's standard output (`fsm … | head -1`) ends the run as SIGPIPE
/// ends a Unix tool: quietly, with exit status 141, not with a panic (which exited 101 with a
/// backtrace). The pipe's read end is closed before the run starts, so the first write fails.
#[test]
fn a_closed_standard_output_ends_the_run_quietly() {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let out = std::process::Command::new(assert_cmd::cargo::cargo_bin("fsm"))
        .args(["plan", "--preset", "paper-bfsm"])
        .stdout(writer)
        .stderr(std::process::Stdio::piped())
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(141), "{said}");
    assert!(said.is_empty(), "{said}");
}
