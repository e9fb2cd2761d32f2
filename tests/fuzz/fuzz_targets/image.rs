//! Grey images (PNG and TIFF, 8 or 16-bit), from bytes as `read_image` reads a file: the bytes
//! are tried as either format. Errors have a message; an image that reads has `width ×
//! height` samples that fit its depth, and writes back (same format and depth) to bytes that
//! read to the same image.
#![no_main]

use std::io::Cursor;

use fsm_io::image_files::{self, ImageFormat};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    for format in [ImageFormat::Png, ImageFormat::Tiff] {
        let (info, samples) = match image_files::read_image_bytes(data, format) {
            Ok(image) => image,
            Err(e) => {
                assert!(!e.to_string().trim().is_empty(), "empty error");
                continue;
            }
        };
        let (w, h) = (info.width, info.height);
        assert_eq!(samples.len(), w as usize * h as usize, "{info:?}");
        let mut out = Cursor::new(Vec::new());
        let written = match info.container_bits {
            8 => {
                assert!(samples.iter().all(|&s| s <= 255), "8-bit image above 255");
                let bytes: Vec<u8> = samples.iter().map(|&s| s as u8).collect();
                match format {
                    ImageFormat::Png => image_files::write_png_gray8(&mut out, w, h, &bytes),
                    ImageFormat::Tiff => image_files::write_tiff_gray8(&mut out, w, h, &bytes),
                }
            }
            16 => match format {
                ImageFormat::Png => image_files::write_png_gray16(&mut out, w, h, &samples),
                ImageFormat::Tiff => image_files::write_tiff_gray16(&mut out, w, h, &samples),
            },
            bits => panic!("{bits}-bit container"),
        };
        written.unwrap_or_else(|e| panic!("{info:?} does not write: {e}"));
        let back = image_files::read_image_bytes(out.get_ref(), format)
            .unwrap_or_else(|e| panic!("written {format:?} does not read: {e}"));
        assert_eq!(back.0, info);
        assert!(back.1 == samples, "{format:?} {info:?}: samples changed");
    }
});
