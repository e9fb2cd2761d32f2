//! What the two OpenCV targets share: parse one syntax, import for every tool, export and
//! import again.

use fsm_geometry::opencv::{self, Document, ImportOptions, LengthUnit, Syntax, Tool};

/// Options with the volume only (sizes must come from the file) and with everything given.
fn options() -> [ImportOptions; 2] {
    let volume = ImportOptions {
        near_mm: Some(300.0),
        far_mm: Some(700.0),
        ..ImportOptions::default()
    };
    [
        volume,
        ImportOptions {
            camera_size: Some((640, 480)),
            projector_size: Some((768, 1024)),
            ..volume
        },
    ]
}

/// Parses `data` as FileStorage text of `syntax` (prefixed with `header` when it does not
/// start like that syntax, so the target stays on its syntax) and imports it for every tool.
pub fn check(data: &[u8], syntax: Syntax, header: &str) {
    let Ok(text) = std::str::from_utf8(data) else {
        // The byte reader refuses it, naming the line of the bad byte.
        let e = opencv::from_bytes(data, "fuzz", Tool::SlStudio, &options()[1]).unwrap_err();
        assert!(e.to_string().contains("not UTF-8"), "{e}");
        return;
    };
    let owned;
    let text = if Syntax::of_text(text) == Some(syntax) {
        text
    } else {
        owned = format!("{header}{text}");
        owned.as_str()
    };
    let doc = match Document::parse(text) {
        Ok(doc) => doc,
        Err(e) => {
            assert!(!e.message.trim().is_empty(), "empty syntax error message");
            let lines = text.split('\n').count();
            assert!(
                (1..=lines).contains(&e.line),
                "syntax error at line {} of a {lines}-line text: {e}",
                e.line
            );
            return;
        }
    };
    assert_eq!(doc.syntax, syntax);
    for tool in Tool::ALL {
        for options in options() {
            let imported = match opencv::import_document(&doc, tool, &options) {
                Ok(imported) => imported,
                Err(e) => {
                    let message = opencv::OpenCvError {
                        source: "fuzz".into(),
                        kind: e,
                    }
                    .to_string();
                    assert!(message.len() > "fuzz: ".len(), "empty import error");
                    continue;
                }
            };
            // Export, then import with the sizes and the volume the export cannot carry: the
            // same calibration (numbers are written with 17 significant digits).
            let c = &imported.calibration;
            let exported = opencv::to_text(c, tool, syntax, LengthUnit::Mm);
            let again = ImportOptions {
                camera_size: Some((c.camera.width_px(), c.camera.height_px())),
                projector_size: Some((c.projector.width_px(), c.projector.height_px())),
                near_mm: Some(c.volume.near_mm()),
                far_mm: Some(c.volume.far_mm()),
                unit: LengthUnit::Mm,
            };
            let back = opencv::from_text(&exported, "export", tool, &again)
                .unwrap_or_else(|e| panic!("{tool} export does not import again: {e}\n{exported}"));
            assert_eq!(
                back.calibration, *c,
                "{tool} export changed the calibration"
            );
        }
    }
}
