//! The remaining readers under arbitrary input: captured images (PNG/TIFF headers and data) and
//! projector-response files never panic; damage is an error.

use fsm_io::image_files;
use fsm_io::projector_response::{GreyLevelManifest, ProjectorResponse};
use proptest::prelude::*;

fn valid_png(width: u32, height: u32) -> Vec<u8> {
    let data: Vec<u16> = (0..width * height)
        .map(|i| (i * 977 % 4096) as u16)
        .collect();
    let mut out = Vec::new();
    image_files::write_png_gray16(&mut out, width, height, &data).unwrap();
    out
}

fn valid_tiff(width: u32, height: u32) -> Vec<u8> {
    let data: Vec<u16> = (0..width * height)
        .map(|i| (i * 977 % 4096) as u16)
        .collect();
    let mut out = std::io::Cursor::new(Vec::new());
    image_files::write_tiff_gray16(&mut out, width, height, &data).unwrap();
    out.into_inner()
}

fn read_everything(path: &std::path::Path) -> Result<(), String> {
    let info = image_files::probe(path).map_err(|e| e.0)?;
    // Bound the work a forged header can ask for.
    if info.width as u64 * info.height as u64 > 1 << 20 {
        return Ok(());
    }
    image_files::read_rows(path, &info, 0..info.height, |_, _| Ok(())).map_err(|e| e.0)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn damaged_images_never_panic(at in 0usize..4000, xor in 1u8..=255, cut in any::<bool>(), tiff in any::<bool>()) {
        let dir = tempfile::tempdir().unwrap();
        let (name, mut bytes) = if tiff { ("0000.tif", valid_tiff(17, 9)) } else { ("0000.png", valid_png(17, 9)) };
        let at = at % bytes.len();
        if cut { bytes.truncate(at) } else { bytes[at] ^= xor }
        let path = dir.path().join(name);
        std::fs::write(&path, &bytes).unwrap();
        let _ = read_everything(&path);
    }

    #[test]
    fn arbitrary_bytes_as_images_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300), tiff in any::<bool>()) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(if tiff { "1.tiff" } else { "1.png" });
        std::fs::write(&path, &bytes).unwrap();
        prop_assert!(read_everything(&path).is_err());
    }

    #[test]
    fn arbitrary_response_files_never_panic(text in ".{0,200}") {
        if let Err(e) = ProjectorResponse::parse(&text) {
            prop_assert!(!e.is_empty());
        }
    }

    #[test]
    fn arbitrary_response_tables_are_accepted_only_if_invertible(
        input in proptest::collection::vec(0.0f64..1.0, 0..6),
        output in proptest::collection::vec(-10.0f64..10.0, 0..6),
    ) {
        let list = |v: &[f64]| v.iter().map(|x| format!("{x:?}")).collect::<Vec<_>>().join(", ");
        let text = format!("format_version = 1\ninput = [0.0, {}, 1.0]\noutput = [{}]", list(&input), list(&output));
        if let Ok(r) = ProjectorResponse::parse(&text) {
            for i in 0..=10 {
                let light = i as f64 / 10.0;
                prop_assert!((r.light_for(r.code_for(light)) - light).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn written_response_files_parse_back_to_the_same_response(
        gamma in 0.1f64..=10.0,
        steps in proptest::collection::vec((1e-6f64..1.0, 1e-6f64..1.0), 1..20),
        comment in "(.|\n|\r){0,80}",
    ) {
        // A strictly increasing table from the steps, normalised to 0..1 like a measured one.
        let (sx, sy): (f64, f64) = steps.iter().fold((0.0, 0.0), |a, s| (a.0 + s.0, a.1 + s.1));
        let mut points = vec![(0.0, 0.0)];
        let (mut x, mut y) = (0.0, 0.0);
        for s in &steps {
            x += s.0;
            y += s.1;
            points.push((x / sx, y / sy));
        }
        let last = points.len() - 1;
        points[last] = (1.0, 1.0);
        let input: Vec<f64> = points.iter().map(|p| p.0).collect();
        let output: Vec<f64> = points.iter().map(|p| p.1).collect();
        for r in [ProjectorResponse::Gamma(gamma), ProjectorResponse::from_table(&input, &output).unwrap()] {
            let text = r.to_file_text(&comment);
            prop_assert_eq!(ProjectorResponse::parse(&text), Ok(r), "{}", text);
        }
    }

    #[test]
    fn arbitrary_grey_level_manifests_never_panic(text in ".{0,200}") {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("levels.json");
        std::fs::write(&path, &text).unwrap();
        if let Err(e) = GreyLevelManifest::read(&path) {
            prop_assert!(e.to_string().contains("levels.json"));
        }
    }
}

/// Found by the `grey_levels` fuzz target in a 10-minute run: a fraction of
/// 5.019615686220002e-66 came back from the manifest's own JSON as ...001e-66 until serde_json
/// parsed floats with `float_roundtrip`.
#[test]
fn a_grey_level_manifest_reads_back_the_fractions_it_was_written_with() {
    let text =
        include_str!("../../../../tests/fuzz/seeds/grey_levels/tiny-fraction-round-trip.json");
    let manifest = GreyLevelManifest::parse(text).unwrap();
    let json = serde_json::to_string_pretty(&manifest).unwrap();
    let back = GreyLevelManifest::parse(&json).unwrap();
    for (a, b) in back.levels.iter().zip(&manifest.levels) {
        assert_eq!(a.fraction.to_bits(), b.fraction.to_bits(), "{json}");
    }
    assert_eq!(back, manifest);
}

#[test]
fn sizes_and_pixels_are_two_whole_numbers() {
    use fsm_io::image_files::{parse_pixel, parse_size};
    assert_eq!(parse_size("1280x1024", 1), Ok((1280, 1024)));
    assert_eq!(parse_size(" 8 x 8 ", 8), Ok((8, 8)));
    assert_eq!(
        parse_size("7x8", 8),
        Err("`7x8`: `7` is not a size of 8 or more pixels".to_owned())
    );
    assert_eq!(
        parse_size("1280,1024", 1),
        Err("`1280,1024`: expected WxH, e.g. 1280x1024".to_owned())
    );
    assert_eq!(parse_pixel("0,479"), Ok((0, 479)));
    assert_eq!(
        parse_pixel("3,-1"),
        Err("`3,-1`: `-1` is not a pixel coordinate".to_owned())
    );
    assert_eq!(
        parse_pixel("3x4"),
        Err("`3x4`: expected X,Y, e.g. 640,480".to_owned())
    );
}

proptest! {
    #[test]
    fn size_and_pixel_parsers_never_panic(s in ".{0,24}") {
        let _ = fsm_io::image_files::parse_size(&s, 8);
        let _ = fsm_io::image_files::parse_pixel(&s);
    }
}
