//! 32-bit float TIFFs (column maps), from bytes as `read_tiff_f32` reads a file. Errors have a
//! message; a map that reads has `width × height` samples and writes back to bytes that read
//! to the same bits.
#![no_main]

use std::io::Cursor;

use fsm_io::image_files;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let (w, h, samples) = match image_files::read_tiff_f32_bytes(data) {
        Ok(map) => map,
        Err(e) => {
            assert!(!e.to_string().trim().is_empty(), "empty error");
            return;
        }
    };
    assert_eq!(samples.len(), w as usize * h as usize, "{w}x{h}");
    let mut out = Cursor::new(Vec::new());
    image_files::write_tiff_f32(&mut out, w, h, &samples)
        .unwrap_or_else(|e| panic!("{w}x{h} map does not write: {e}"));
    let (w2, h2, back) = image_files::read_tiff_f32_bytes(out.get_ref())
        .unwrap_or_else(|e| panic!("written map does not read: {e}"));
    assert_eq!((w2, h2), (w, h));
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert!(bits(&back) == bits(&samples), "{w}x{h}: samples changed");
});
