//! The checkerboard target definition (TOML), from bytes as `Checkerboard::read` reads them.
//! Errors name the file; a board that reads is valid and writes back to the same board.
#![no_main]

use fsm_calibrate::board::Checkerboard;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    match Checkerboard::from_bytes(data, "fuzz.toml") {
        Ok(board) => {
            assert_eq!(board.validate(), Ok(()));
            assert_eq!(board.corner_count(), board.corners_mm().len());
            let written = board.to_toml();
            let back = Checkerboard::from_toml(&written, "written")
                .unwrap_or_else(|e| panic!("written board does not read: {e}\n{written}"));
            assert_eq!(back, board);
        }
        Err(e) => {
            let message = e.to_string();
            let prefix = "target file fuzz.toml: ";
            assert!(
                message.starts_with(prefix),
                "error without the file: {message}"
            );
            assert!(message.len() > prefix.len(), "empty error: {message}");
        }
    }
});
