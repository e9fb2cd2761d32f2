//! Our calibration file (TOML, with the optional `[projector_response]` section), from bytes
//! as `CalibrationFile::read` reads them. Errors name the source; a file that reads writes
//! back to text that reads to the same file with the same checksum, and the geometry-only
//! reader agrees.
#![no_main]

use fsm_geometry::file::CalibrationFile;
use fsm_geometry::Calibration;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let file = match CalibrationFile::from_bytes(data, "fuzz.toml") {
        Ok(file) => file,
        Err(e) => {
            let message = e.to_string();
            let prefix = "calibration file fuzz.toml: ";
            assert!(
                message.starts_with(prefix),
                "error without the file: {message}"
            );
            assert!(message.len() > prefix.len(), "empty error: {message}");
            return;
        }
    };
    let text = std::str::from_utf8(data).expect("read as UTF-8");
    let geometry = Calibration::from_toml(text, "fuzz.toml").expect("geometry of a good file");
    assert_eq!(geometry, file.calibration);

    let written = file.to_toml();
    let back = CalibrationFile::from_toml(&written, "written")
        .unwrap_or_else(|e| panic!("written file does not read: {e}\n{written}"));
    assert_eq!(back, file);
    assert_eq!(back.checksum(), file.checksum());
    let stored = format!("checksum_crc32 = \"{:08x}\"", file.checksum());
    assert!(
        written.contains(&stored),
        "written file without its checksum"
    );
});
