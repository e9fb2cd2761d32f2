//! Grey-level image files: PNG and TIFF, 8- or 16-bit, read by bands of rows and written whole;
//! 32-bit float TIFF for column maps; 8-bit RGB PNG for pictures.
//!
//! Reading a band decodes only what it must: a PNG is decoded row by row up to the band's last
//! row (the rows above it are decompressed and dropped, since PNG rows depend on their
//! predecessors), a stripped TIFF only the strips that overlap the band.

use std::fmt;
use std::fs::File;
use std::io::{BufRead, BufReader, Cursor, Seek, Write};
use std::ops::Range;
use std::path::Path;

/// Container format of an image file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// PNG.
    Png,
    /// TIFF.
    Tiff,
}

impl ImageFormat {
    /// TIFF if `tiff`, else PNG (the commands' `--tiff`).
    pub fn png_or_tiff(tiff: bool) -> Self {
        if tiff {
            ImageFormat::Tiff
        } else {
            ImageFormat::Png
        }
    }

    /// The format a file extension names (`png`, `tif`, `tiff`; any case).
    pub fn from_extension(ext: &str) -> Option<Self> {
        match ext.to_ascii_lowercase().as_str() {
            "png" => Some(ImageFormat::Png),
            "tif" | "tiff" => Some(ImageFormat::Tiff),
            _ => None,
        }
    }

    /// The format of `path`, from its extension.
    pub fn of(path: &Path) -> Option<Self> {
        Self::from_extension(path.extension()?.to_str()?)
    }
}

/// An image size `WxH` as the commands take it (`--camera 640x480`, `--camera-size`), both
/// sides at least `min` pixels; the errors say `expected WxH` or which side is not a size.
/// The commands' value syntaxes are parsed in the libraries, as `KEY=VALUE`
/// ([`crate::plan_file::parse_setting`]) and a board pose are: this one and [`parse_pixel`]
/// are the images'.
pub fn parse_size(s: &str, min: u32) -> Result<(u32, u32), String> {
    let what = format!("a size of {min} or more pixels");
    pair(s, 'x', "WxH, e.g. 1280x1024", &what, min)
}

/// A pixel `X,Y` (0-based) as `fsm inspect --pixel` takes it.
pub fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    pair(s, ',', "X,Y, e.g. 640,480", "a pixel coordinate", 0)
}

/// Two whole numbers of at least `min` separated by `sep`; the errors say `expected {form}`
/// or that a number is not `{what}`.
fn pair(s: &str, sep: char, form: &str, what: &str, min: u32) -> Result<(u32, u32), String> {
    let (a, b) = s
        .split_once(sep)
        .ok_or_else(|| format!("`{s}`: expected {form}"))?;
    let parse = |v: &str| {
        (v.trim().parse::<u32>().ok().filter(|&v| v >= min))
            .ok_or_else(|| format!("`{s}`: `{v}` is not {what}"))
    };
    Ok((parse(a)?, parse(b)?))
}

/// Size and sample depth of a grey image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageInfo {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Bits per sample of the container: 8 or 16.
    pub container_bits: u8,
}

/// Most pixels an image may have (2^27, 256 MiB of 16-bit samples): a header claiming more is
/// refused before anything is allocated for it, so a small file cannot make a reader exhaust
/// memory.
pub const MAX_PIXELS: u64 = 1 << 27;

/// Why an image could not be read or written (the caller adds the file name).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImageError(pub String);

impl fmt::Display for ImageError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for ImageError {}

fn err(message: impl fmt::Display) -> ImageError {
    ImageError(message.to_string())
}

fn open(path: &Path) -> Result<BufReader<File>, ImageError> {
    let file = File::open(path).map_err(err)?;
    Ok(BufReader::with_capacity(1 << 16, file))
}

fn format_of(path: &Path) -> Result<ImageFormat, ImageError> {
    ImageFormat::of(path).ok_or_else(|| err("not a .png, .tif or .tiff file"))
}

/// Reads the size and depth of a grey image without decoding its pixels.
pub fn probe(path: &Path) -> Result<ImageInfo, ImageError> {
    let format = format_of(path)?;
    probe_from(open(path)?, format)
}

fn probe_from(input: impl BufRead + Seek, format: ImageFormat) -> Result<ImageInfo, ImageError> {
    match format {
        ImageFormat::Png => {
            let reader = png_reader(input)?;
            png_info(reader.info())
        }
        ImageFormat::Tiff => {
            let mut decoder = tiff_decoder(input)?;
            tiff_info(&mut decoder)
        }
    }
}

/// Decodes rows `rows` of a grey image, handing each to `row(y, samples)` in order. The image
/// must have the size and depth `expected` (checked first).
pub fn read_rows(
    path: &Path,
    expected: &ImageInfo,
    rows: Range<u32>,
    row: impl FnMut(u32, &[u16]) -> Result<(), ImageError>,
) -> Result<(), ImageError> {
    check_rows(expected, &rows)?;
    let format = format_of(path)?;
    read_rows_from(open(path)?, format, expected, rows, row)
}

fn check_rows(expected: &ImageInfo, rows: &Range<u32>) -> Result<(), ImageError> {
    if rows.end > expected.height || rows.start > rows.end {
        return Err(err(format!(
            "rows {}..{} are outside the image height {}",
            rows.start, rows.end, expected.height
        )));
    }
    Ok(())
}

fn read_rows_from(
    input: impl BufRead + Seek,
    format: ImageFormat,
    expected: &ImageInfo,
    rows: Range<u32>,
    mut row: impl FnMut(u32, &[u16]) -> Result<(), ImageError>,
) -> Result<(), ImageError> {
    check_rows(expected, &rows)?;
    let check = |info: ImageInfo| {
        if info != *expected {
            Err(err(format!(
                "is {}x{} {}-bit, the stack's first image is {}x{} {}-bit",
                info.width,
                info.height,
                info.container_bits,
                expected.width,
                expected.height,
                expected.container_bits
            )))
        } else {
            Ok(())
        }
    };
    check_size(expected)?;
    let mut samples = vec![0u16; expected.width as usize];
    match format {
        ImageFormat::Png => {
            let mut reader = png_reader(input)?;
            check(png_info(reader.info())?)?;
            let sixteen = expected.container_bits == 16;
            if reader.info().interlaced {
                // Adam7 rows arrive in passes: decode the whole image.
                let mut buf = vec![
                    0u8;
                    reader
                        .output_buffer_size()
                        .ok_or_else(|| err("image too large"))?
                ];
                reader.next_frame(&mut buf).map_err(err)?;
                let stride = buf.len() / expected.height as usize;
                for y in rows {
                    let line = &buf[y as usize * stride..(y as usize + 1) * stride];
                    unpack(line, sixteen, &mut samples);
                    row(y, &samples)?;
                }
                return Ok(());
            }
            for y in 0..rows.end {
                let line = reader
                    .next_row()
                    .map_err(err)?
                    .ok_or_else(|| err(format!("image data ends before row {y}")))?;
                if y >= rows.start {
                    unpack(line.data(), sixteen, &mut samples);
                    row(y, &samples)?;
                }
            }
            Ok(())
        }
        ImageFormat::Tiff => {
            let mut decoder = tiff_decoder(input)?;
            check(tiff_info(&mut decoder)?)?;
            let w = expected.width as usize;
            let (chunk_w, rows_per_strip) = decoder.chunk_dimensions();
            let stripped = matches!(decoder.get_chunk_type(), tiff::decoder::ChunkType::Strip)
                && chunk_w as usize == w
                && rows_per_strip > 0;
            if !stripped {
                let image = decoder.read_image().map_err(err)?;
                let data = tiff_samples(&image)?;
                for y in rows {
                    let line = &data[y as usize * w..(y as usize + 1) * w];
                    row(y, line)?;
                }
                return Ok(());
            }
            let mut y = rows.start;
            while y < rows.end {
                let strip = y / rows_per_strip;
                let chunk = decoder.read_chunk(strip).map_err(err)?;
                let data = tiff_samples(&chunk)?;
                let first = strip * rows_per_strip;
                let strip_rows = (data.len() / w) as u32;
                while y < rows.end && y < first + strip_rows {
                    let at = (y - first) as usize * w;
                    row(y, &data[at..at + w])?;
                    y += 1;
                }
                if strip_rows == 0 {
                    return Err(err(format!("strip {strip} is empty")));
                }
            }
            Ok(())
        }
    }
}

/// Decodes a whole grey image file: its info and its samples, row-major.
pub fn read_image(path: &Path) -> Result<(ImageInfo, Vec<u16>), ImageError> {
    let format = format_of(path)?;
    read_image_with(format, || open(path))
}

/// Decodes a whole grey image held in memory (the bytes of a `format` file): its info and its
/// samples, row-major. [`read_image`] reads a file the same way.
pub fn read_image_bytes(
    bytes: &[u8],
    format: ImageFormat,
) -> Result<(ImageInfo, Vec<u16>), ImageError> {
    read_image_with(format, || Ok(Cursor::new(bytes)))
}

/// Probes, then decodes every row: `open` gives the input once for each pass.
fn read_image_with<R: BufRead + Seek>(
    format: ImageFormat,
    open: impl Fn() -> Result<R, ImageError>,
) -> Result<(ImageInfo, Vec<u16>), ImageError> {
    let info = probe_from(open()?, format)?;
    // Grown with the rows that arrive, not reserved for the size the header claims.
    let mut data = Vec::new();
    read_rows_from(open()?, format, &info, 0..info.height, |_, samples| {
        data.extend_from_slice(samples);
        Ok(())
    })?;
    Ok((info, data))
}

fn unpack(line: &[u8], sixteen: bool, out: &mut [u16]) {
    if sixteen {
        for (o, b) in out.iter_mut().zip(line.chunks_exact(2)) {
            *o = u16::from_be_bytes([b[0], b[1]]);
        }
    } else {
        for (o, &b) in out.iter_mut().zip(line) {
            *o = b as u16;
        }
    }
}

fn png_reader<R: BufRead + Seek>(input: R) -> Result<png::Reader<R>, ImageError> {
    let mut decoder = png::Decoder::new(input);
    decoder.set_transformations(png::Transformations::IDENTITY);
    decoder.read_info().map_err(err)
}

/// Refuses an image of more than [`MAX_PIXELS`] pixels.
fn check_size(info: &ImageInfo) -> Result<(), ImageError> {
    let pixels = info.width as u64 * info.height as u64;
    if pixels > MAX_PIXELS {
        return Err(err(format!(
            "is {}x{} ({pixels} pixels): more than the {MAX_PIXELS} pixels an image may have",
            info.width, info.height
        )));
    }
    Ok(())
}

fn png_info(info: &png::Info<'_>) -> Result<ImageInfo, ImageError> {
    if info.color_type != png::ColorType::Grayscale {
        return Err(err(format!(
            "is a {:?} PNG; captures must be single-channel grey images",
            info.color_type
        )));
    }
    let container_bits = match info.bit_depth {
        png::BitDepth::Eight => 8,
        png::BitDepth::Sixteen => 16,
        d => {
            return Err(err(format!(
                "is a {}-bit PNG; only 8- and 16-bit samples are read",
                d as u8
            )))
        }
    };
    let info = ImageInfo {
        width: info.width,
        height: info.height,
        container_bits,
    };
    check_size(&info)?;
    Ok(info)
}

fn tiff_decoder<R: BufRead + Seek>(input: R) -> Result<tiff::decoder::Decoder<R>, ImageError> {
    tiff::decoder::Decoder::new(input).map_err(err)
}

fn tiff_info<R: BufRead + Seek>(
    decoder: &mut tiff::decoder::Decoder<R>,
) -> Result<ImageInfo, ImageError> {
    let (width, height) = decoder.dimensions().map_err(err)?;
    let container_bits = match decoder.colortype().map_err(err)? {
        tiff::ColorType::Gray(8) => 8,
        tiff::ColorType::Gray(16) => 16,
        c => {
            return Err(err(format!(
                "is a {c:?} TIFF; captures must be 8- or 16-bit single-channel grey images"
            )))
        }
    };
    let info = ImageInfo {
        width,
        height,
        container_bits,
    };
    check_size(&info)?;
    Ok(info)
}

fn tiff_samples(
    result: &tiff::decoder::DecodingResult,
) -> Result<std::borrow::Cow<'_, [u16]>, ImageError> {
    use tiff::decoder::DecodingResult;
    match result {
        DecodingResult::U16(v) => Ok(std::borrow::Cow::Borrowed(v)),
        DecodingResult::U8(v) => Ok(std::borrow::Cow::Owned(
            v.iter().map(|&b| b as u16).collect(),
        )),
        _ => Err(err("TIFF samples are neither 8- nor 16-bit unsigned")),
    }
}

/// Writes an 8-bit grey PNG.
pub fn write_png_gray8(
    out: impl Write,
    width: u32,
    height: u32,
    samples: &[u8],
) -> Result<(), ImageError> {
    write_png(
        out,
        width,
        height,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        samples,
    )
}

/// Writes a 16-bit grey PNG.
pub fn write_png_gray16(
    out: impl Write,
    width: u32,
    height: u32,
    samples: &[u16],
) -> Result<(), ImageError> {
    let bytes: Vec<u8> = samples.iter().flat_map(|s| s.to_be_bytes()).collect();
    write_png(
        out,
        width,
        height,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        &bytes,
    )
}

/// Writes an 8-bit RGB PNG (pictures, previews).
pub fn write_png_rgb8(
    out: impl Write,
    width: u32,
    height: u32,
    rgb: &[u8],
) -> Result<(), ImageError> {
    write_png(
        out,
        width,
        height,
        png::ColorType::Rgb,
        png::BitDepth::Eight,
        rgb,
    )
}

fn write_png(
    out: impl Write,
    width: u32,
    height: u32,
    color: png::ColorType,
    depth: png::BitDepth,
    bytes: &[u8],
) -> Result<(), ImageError> {
    let mut encoder = png::Encoder::new(out, width, height);
    encoder.set_color(color);
    encoder.set_depth(depth);
    encoder.set_compression(png::Compression::Fast);
    let mut writer = encoder.write_header().map_err(err)?;
    writer.write_image_data(bytes).map_err(err)?;
    writer.finish().map_err(err)
}

/// Writes a 16-bit grey TIFF.
pub fn write_tiff_gray16(
    out: impl Write + Seek,
    width: u32,
    height: u32,
    samples: &[u16],
) -> Result<(), ImageError> {
    let mut encoder = tiff::encoder::TiffEncoder::new(out).map_err(err)?;
    encoder
        .write_image::<tiff::encoder::colortype::Gray16>(width, height, samples)
        .map_err(err)
}

/// Writes an 8-bit grey TIFF.
pub fn write_tiff_gray8(
    out: impl Write + Seek,
    width: u32,
    height: u32,
    samples: &[u8],
) -> Result<(), ImageError> {
    let mut encoder = tiff::encoder::TiffEncoder::new(out).map_err(err)?;
    encoder
        .write_image::<tiff::encoder::colortype::Gray8>(width, height, samples)
        .map_err(err)
}

/// Writes a 32-bit float grey TIFF.
pub fn write_tiff_f32(
    out: impl Write + Seek,
    width: u32,
    height: u32,
    samples: &[f32],
) -> Result<(), ImageError> {
    let mut encoder = tiff::encoder::TiffEncoder::new(out).map_err(err)?;
    encoder
        .write_image::<tiff::encoder::colortype::Gray32Float>(width, height, samples)
        .map_err(err)
}

/// Reads a 32-bit float grey TIFF file (column maps): width, height, samples row-major.
pub fn read_tiff_f32(path: &Path) -> Result<(u32, u32, Vec<f32>), ImageError> {
    tiff_f32_from(open(path)?)
}

/// Decodes a 32-bit float grey TIFF held in memory, as [`read_tiff_f32`] does a file.
pub fn read_tiff_f32_bytes(bytes: &[u8]) -> Result<(u32, u32, Vec<f32>), ImageError> {
    tiff_f32_from(Cursor::new(bytes))
}

fn tiff_f32_from(input: impl BufRead + Seek) -> Result<(u32, u32, Vec<f32>), ImageError> {
    let mut decoder = tiff_decoder(input)?;
    let (w, h) = decoder.dimensions().map_err(err)?;
    // One sample per pixel: a multi-channel float TIFF decodes to more than `w·h` samples.
    match decoder.colortype().map_err(err)? {
        tiff::ColorType::Gray(32) => {}
        c => {
            return Err(err(format!(
                "is a {c:?} TIFF; a column map is a single-channel 32-bit float image"
            )))
        }
    }
    match decoder.read_image().map_err(err)? {
        tiff::decoder::DecodingResult::F32(v) if v.len() as u64 == w as u64 * h as u64 => {
            Ok((w, h, v))
        }
        tiff::decoder::DecodingResult::F32(v) => Err(err(format!(
            "{w}x{h} TIFF holds {} samples, not one per pixel",
            v.len()
        ))),
        _ => Err(err("not a 32-bit float TIFF")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PNG of `width × height` 8-bit grey whose data is a few bytes of zlib.
    fn png_claiming(width: u32, height: u32) -> Vec<u8> {
        let chunk = |out: &mut Vec<u8>, kind: &[u8], data: &[u8]| {
            out.extend_from_slice(&(data.len() as u32).to_be_bytes());
            let start = out.len();
            out.extend_from_slice(kind);
            out.extend_from_slice(data);
            let crc = fsm_core::wire::crc32(&out[start..]);
            out.extend_from_slice(&crc.to_be_bytes());
        };
        let mut ihdr = Vec::new();
        ihdr.extend_from_slice(&width.to_be_bytes());
        ihdr.extend_from_slice(&height.to_be_bytes());
        ihdr.extend_from_slice(&[8, 0, 0, 0, 0]);
        let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
        chunk(&mut out, b"IHDR", &ihdr);
        chunk(
            &mut out,
            b"IDAT",
            &[0x78, 0x9c, 0x63, 0x60, 0, 0, 0, 2, 0, 1],
        );
        chunk(&mut out, b"IEND", &[]);
        out
    }

    /// A little-endian TIFF of `width × height` 32-bit floats, `samples_per_pixel` per pixel,
    /// one strip.
    fn float_tiff(width: u32, height: u32, samples_per_pixel: u16, data: &[f32]) -> Vec<u8> {
        let tags: [(u16, u16, u32); 10] = [
            (256, 4, width),
            (257, 4, height),
            (258, 3, 32),
            (259, 3, 1),
            (262, 3, 1),
            (273, 4, 8 + 2 + 10 * 12 + 4),
            (277, 3, samples_per_pixel as u32),
            (278, 4, height),
            (279, 4, data.len() as u32 * 4),
            (339, 3, 3),
        ];
        let mut out = b"II*\0".to_vec();
        out.extend_from_slice(&8u32.to_le_bytes());
        out.extend_from_slice(&(tags.len() as u16).to_le_bytes());
        for (tag, kind, value) in tags {
            out.extend_from_slice(&tag.to_le_bytes());
            out.extend_from_slice(&kind.to_le_bytes());
            out.extend_from_slice(&1u32.to_le_bytes());
            out.extend_from_slice(&value.to_le_bytes());
        }
        out.extend_from_slice(&0u32.to_le_bytes());
        data.iter()
            .for_each(|v| out.extend_from_slice(&v.to_le_bytes()));
        out
    }

    #[test]
    fn a_column_map_has_one_sample_per_pixel() {
        let data: Vec<f32> = (0..6).map(|i| i as f32 + 0.5).collect();
        assert_eq!(
            read_tiff_f32_bytes(&float_tiff(3, 2, 1, &data)).unwrap(),
            (3, 2, data)
        );
        // Found by tests/fuzz (tiff_f32): 11 samples per pixel decoded to 66 samples for a 3x2
        // map, which callers index as 6.
        let e = read_tiff_f32_bytes(&float_tiff(3, 2, 11, &[0.0; 66])).unwrap_err();
        assert!(e.0.contains("single-channel 32-bit float"), "{e}");
    }

    #[test]
    fn a_header_claiming_a_huge_image_is_refused_before_allocating() {
        // Found by tests/fuzz (image): a 81-byte PNG claiming 3 x 1006632962 pixels made
        // read_image reserve 6 GB for its samples.
        let bytes = png_claiming(3, 1_006_632_962);
        let e = read_image_bytes(&bytes, ImageFormat::Png).unwrap_err();
        assert!(
            e.0.contains("3x1006632962") && e.0.contains("pixels"),
            "{e}"
        );
        // At the limit the header is accepted, and the missing data is the error.
        let e = read_image_bytes(&png_claiming(1 << 14, 1 << 13), ImageFormat::Png).unwrap_err();
        assert!(!e.0.contains("pixels an image may have"), "{e}");
    }

    #[test]
    fn bands_of_every_format_read_back() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (7u32, 23u32);
        let data16: Vec<u16> = (0..w * h).map(|i| (i * 2731 % 65536) as u16).collect();
        let data8: Vec<u8> = (0..w * h).map(|i| (i * 37 % 256) as u8).collect();
        let cases: Vec<(&str, Vec<u16>)> = vec![
            ("a16.png", data16.clone()),
            ("a8.png", data8.iter().map(|&b| b as u16).collect()),
            ("a16.tif", data16.clone()),
            ("a8.tiff", data8.iter().map(|&b| b as u16).collect()),
        ];
        for (name, expected) in cases {
            let path = dir.path().join(name);
            let mut f = std::fs::File::create(&path).unwrap();
            match (name.contains("16"), ImageFormat::of(&path).unwrap()) {
                (true, ImageFormat::Png) => write_png_gray16(&mut f, w, h, &data16).unwrap(),
                (false, ImageFormat::Png) => write_png_gray8(&mut f, w, h, &data8).unwrap(),
                (true, ImageFormat::Tiff) => write_tiff_gray16(&mut f, w, h, &data16).unwrap(),
                (false, ImageFormat::Tiff) => write_tiff_gray8(&mut f, w, h, &data8).unwrap(),
            }
            drop(f);
            let info = probe(&path).unwrap();
            assert_eq!((info.width, info.height), (w, h));
            for band in [0..1, 3..9, 20..23, 0..23] {
                let mut got = Vec::new();
                read_rows(&path, &info, band.clone(), |y, s| {
                    assert_eq!(y as usize, band.start as usize + got.len() / w as usize);
                    got.extend_from_slice(s);
                    Ok(())
                })
                .unwrap();
                let range = band.start as usize * w as usize..band.end as usize * w as usize;
                assert_eq!(got, expected[range], "{name} {band:?}");
            }
        }
    }
}
