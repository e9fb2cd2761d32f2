//! The projector's response (light out for code in) and the gamma pre-correction of pattern
//! images: FSM assumes the projected light is `PA + PB·cos(…)` (paper eq. 4); a projector with
//! gamma turns the cosine into a distorted wave whose harmonics show up as ghost peaks at
//! multiples of the column. Pre-correcting the codes with the inverse response restores it.
//!
//! A response file (TOML, documented in the host README, "Projector response files"):
//!
//! ```toml
//! format_version = 1
//! gamma = 2.2                    # light = code^gamma, code and light as fractions of full scale
//! ```
//!
//! or a measured table (`input` strictly increasing from 0 to 1, `output` in any unit,
//! strictly increasing; interpolated linearly):
//!
//! ```toml
//! format_version = 1
//! input = [0.0, 0.25, 0.5, 0.75, 1.0]
//! output = [0.8, 12.0, 48.0, 110.0, 200.0]
//! ```
//!
//! Measuring the response ([`estimate`], [`estimate_from_folder`]; `fsm calibrate response`):
//! the projector shows uniform grey images of codes from 0 to full ([`write_grey_level_set`]),
//! the camera captures each; per pixel the dark capture (code 0: projector black, ambient and
//! sensor offset) is subtracted and the result divided by the full-code capture's, so surface
//! albedo, vignetting and exposure cancel; each level's light is the interquartile mean of
//! those ratios over every usable pixel (pixels saturated or too dim in the dark or full
//! capture are excluded and counted, saturated samples of a level likewise). The measured
//! points form a table (refused if not strictly increasing, naming the level) and the best-fit
//! power law `light = code^gamma` (least squares in light, with its RMS residual).

use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, IoContext, Result};
use crate::image_files::{self, ImageFormat, ImageInfo};
use crate::outputs::{self, StagedDir};

/// Version of the response-file format.
pub const RESPONSE_FILE_VERSION: u64 = 1;

/// A projector's response, normalised so that code 0 gives light 0 and full code light 1.
#[derive(Clone, Debug, PartialEq)]
pub enum ProjectorResponse {
    /// `light = code^gamma`.
    Gamma(f64),
    /// Measured `(code, light)` points, both normalised to `[0, 1]`, strictly increasing.
    Table(Vec<(f64, f64)>),
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct ResponseFile {
    format_version: u64,
    gamma: Option<f64>,
    input: Option<Vec<f64>>,
    output: Option<Vec<f64>>,
}

impl ProjectorResponse {
    /// Reads a response file.
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).at(path)?;
        Self::parse(&text).map_err(|message| Error::ProjectorResponse {
            path: path.to_path_buf(),
            message,
        })
    }

    /// Parses the text of a response file; the error names the field.
    pub fn parse(text: &str) -> Result<Self, String> {
        let file: ResponseFile =
            toml::from_str(text).map_err(|e| e.to_string().trim().to_owned())?;
        if file.format_version != RESPONSE_FILE_VERSION {
            return Err(format!(
                "field format_version = {} is not supported (this build reads {RESPONSE_FILE_VERSION})",
                file.format_version
            ));
        }
        match (file.gamma, file.input, file.output) {
            (Some(g), None, None) => Self::from_gamma(g),
            (None, Some(input), Some(output)) => Self::from_table(&input, &output),
            _ => Err("give either field gamma, or both fields input and output".into()),
        }
    }

    /// A power law `light = code^gamma`; `gamma` must lie in `0.1..=10` (the error names the
    /// field `gamma`).
    pub fn from_gamma(gamma: f64) -> Result<Self, String> {
        if gamma.is_finite() && (0.1..=10.0).contains(&gamma) {
            Ok(ProjectorResponse::Gamma(gamma))
        } else {
            Err(format!("field gamma = {gamma}: must lie in 0.1..=10"))
        }
    }

    /// A measured table: `input` codes (fractions of full scale) strictly increasing from 0 to
    /// 1, `output` light in any unit, strictly increasing (normalised here to 0..1). The error
    /// names the field and the entry.
    pub fn from_table(input: &[f64], output: &[f64]) -> Result<Self, String> {
        if input.len() != output.len() || input.len() < 2 {
            return Err(format!(
                "fields input ({} values) and output ({} values) must have the same length, at least 2",
                input.len(),
                output.len()
            ));
        }
        if input[0] != 0.0 || input[input.len() - 1] != 1.0 {
            return Err("field input must run from 0 to 1 (fractions of the full code)".into());
        }
        for (name, values) in [("input", input), ("output", output)] {
            for (i, w) in values.windows(2).enumerate() {
                if w[1] <= w[0] || !w[0].is_finite() || !w[1].is_finite() {
                    return Err(format!(
                        "field {name}: values must be finite and strictly increasing (entry {} = {} after {})",
                        i + 1,
                        w[1],
                        w[0]
                    ));
                }
            }
        }
        let (lo, hi) = (output[0], output[output.len() - 1]);
        if !(hi - lo).is_finite() {
            return Err(format!(
                "field output: the range {lo} to {hi} is too wide (its span is not a finite number)"
            ));
        }
        let points: Vec<(f64, f64)> = input
            .iter()
            .zip(output)
            .map(|(&c, &l)| (c, (l - lo) / (hi - lo)))
            .collect();
        // Normalising rounds: entries far closer together than the range may become equal.
        for (i, w) in points.windows(2).enumerate() {
            if w[1].1 <= w[0].1 {
                return Err(format!(
                    "field output: entries {i} = {} and {} = {} are too close together to tell apart once normalised to 0..1",
                    output[i],
                    i + 1,
                    output[i + 1]
                ));
            }
        }
        Ok(ProjectorResponse::Table(points))
    }

    /// The text of a response file holding this response, with `comment` (one or more lines,
    /// each written as a `#` comment; control characters are replaced) at the top. Parses back
    /// to the same response.
    pub fn to_file_text(&self, comment: &str) -> String {
        // TOML comments may not hold control characters other than tab.
        let clean = |l: &str| -> String {
            l.chars()
                .map(|c| {
                    if c.is_control() && c != '\t' {
                        '\u{fffd}'
                    } else {
                        c
                    }
                })
                .collect()
        };
        let mut text: String = comment
            .lines()
            .map(|l| format!("# {}\n", clean(l)))
            .collect();
        text.push_str(&format!("format_version = {RESPONSE_FILE_VERSION}\n"));
        let list = |values: &mut dyn Iterator<Item = f64>| {
            values
                .map(|v| format!("{v:?}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        match self {
            ProjectorResponse::Gamma(g) => text.push_str(&format!("gamma = {g:?}\n")),
            ProjectorResponse::Table(points) => {
                text.push_str(&format!(
                    "input = [{}]\noutput = [{}]\n",
                    list(&mut points.iter().map(|p| p.0)),
                    list(&mut points.iter().map(|p| p.1))
                ));
            }
        }
        text
    }

    /// Writes a response file whole or not at all (temporary name, then rename).
    pub fn write(&self, path: &Path, comment: &str) -> Result<()> {
        outputs::write_file(path, self.to_file_text(comment).as_bytes())
    }

    /// The code (fraction of full scale) that makes the projector emit relative light `light`
    /// (clamped to `[0, 1]`).
    pub fn code_for(&self, light: f64) -> f64 {
        let light = light.clamp(0.0, 1.0);
        match self {
            ProjectorResponse::Gamma(g) => light.powf(1.0 / g),
            ProjectorResponse::Table(points) => {
                let i = points
                    .partition_point(|&(_, l)| l < light)
                    .clamp(1, points.len() - 1);
                let (c0, l0) = points[i - 1];
                let (c1, l1) = points[i];
                c0 + (c1 - c0) * (light - l0) / (l1 - l0)
            }
        }
    }

    /// Relative light for code `code` (fraction of full scale): the forward model.
    pub fn light_for(&self, code: f64) -> f64 {
        let code = code.clamp(0.0, 1.0);
        match self {
            ProjectorResponse::Gamma(g) => code.powf(*g),
            ProjectorResponse::Table(points) => {
                let i = points
                    .partition_point(|&(c, _)| c < code)
                    .clamp(1, points.len() - 1);
                let (c0, l0) = points[i - 1];
                let (c1, l1) = points[i];
                l0 + (l1 - l0) * (code - c0) / (c1 - c0)
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Measuring the response from captures of uniform grey levels.

/// Name of the manifest beside a grey-level set.
pub const GREY_LEVELS_MANIFEST: &str = "levels.json";
/// Version of the grey-level manifest.
pub const GREY_LEVELS_VERSION: u32 = 1;
/// The `kind` of a grey-level manifest.
pub const GREY_LEVELS_KIND: &str = "fsm-grey-levels";
/// A pixel is used only if its full-code capture exceeds its dark one by at least this many
/// sensor codes …
pub const MIN_CONTRAST_DN: f64 = 4.0;
/// … and by at least this fraction of the median pixel's (shadows and the background are
/// left out: their ratios are mostly noise).
pub const MIN_RELATIVE_CONTRAST: f64 = 0.25;
/// At least this many usable pixels are needed.
pub const MIN_USABLE_PIXELS: usize = 16;

/// The codes of `levels` grey levels evenly spaced from 0 to `max_code` (rounded to whole
/// codes), ascending. Needs `3 <= levels` (dark, full and one level between) and distinct codes.
pub fn grey_level_codes(levels: usize, max_code: u16) -> Result<Vec<u16>, String> {
    if levels < 3 || levels > max_code as usize + 1 {
        return Err(format!(
            "--levels {levels}: need 3..={} levels (code 0, full code {max_code} and at least one between, all distinct)",
            max_code as usize + 1
        ));
    }
    Ok((0..levels)
        .map(|k| (k as f64 * max_code as f64 / (levels - 1) as f64).round() as u16)
        .collect())
}

/// The full code of 8- or 16-bit projector images.
fn full_code(sixteen_bit: bool) -> u16 {
    if sixteen_bit {
        u16::MAX
    } else {
        u8::MAX as u16
    }
}

/// The codes of `levels` grey levels of 8- or 16-bit images as [`write_grey_level_set`] makes
/// them, as fractions of the full code: the captures' codes when no manifest is at hand.
pub fn grey_level_fractions(levels: usize, sixteen_bit: bool) -> Result<Vec<f64>> {
    let max_code = full_code(sixteen_bit);
    let codes = grey_level_codes(levels, max_code).map_err(Error::Usage)?;
    Ok(codes.iter().map(|&c| c as f64 / max_code as f64).collect())
}

/// The codes of a grey-level set's captures as fractions of the full code: those of its
/// `manifest` (`levels.json`) when given, else those [`write_grey_level_set`] makes for
/// `levels` levels of 8- or 16-bit images ([`grey_level_fractions`]). `fsm calibrate response
/// --images` takes either; the choice is the set's, so it is made here.
pub fn capture_fractions(
    manifest: Option<&Path>,
    levels: usize,
    sixteen_bit: bool,
) -> Result<Vec<f64>> {
    match manifest {
        Some(path) => Ok(GreyLevelManifest::read(path)?.fractions()),
        None => grey_level_fractions(levels, sixteen_bit),
    }
}

/// One image of a grey-level set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GreyLevel {
    /// Position in the set (and the capture's number).
    pub index: usize,
    /// File name in the set's folder.
    pub file: String,
    /// The code every pixel of the image holds.
    pub code: u16,
    /// `code / full code`, the response's input.
    pub fraction: f64,
}

/// The manifest of a grey-level set (`levels.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GreyLevelManifest {
    /// [`GREY_LEVELS_VERSION`].
    pub format_version: u32,
    /// [`GREY_LEVELS_KIND`].
    pub kind: String,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Bits per sample of the images: 8 or 16.
    pub bit_depth: u8,
    /// Every image, ascending codes from 0 to full.
    pub levels: Vec<GreyLevel>,
}

impl GreyLevelManifest {
    /// Reads and checks a manifest written by [`write_grey_level_set`].
    pub fn read(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).at(path)?;
        Self::parse(&text).map_err(|message| Error::ProjectorResponse {
            path: path.to_path_buf(),
            message,
        })
    }

    /// Parses and checks the text of a manifest (JSON); the error names the field.
    pub fn parse(text: &str) -> Result<Self, String> {
        let m: GreyLevelManifest =
            serde_json::from_str(text).map_err(|e| format!("not a grey-level manifest: {e}"))?;
        if m.kind != GREY_LEVELS_KIND || m.format_version != GREY_LEVELS_VERSION {
            return Err(format!(
                "kind {:?} version {}: expected kind {GREY_LEVELS_KIND:?} version {GREY_LEVELS_VERSION}",
                m.kind, m.format_version
            ));
        }
        check_fractions(&m.fractions())?;
        Ok(m)
    }

    /// The set in words, as `fsm calibrate response --write-patterns` reports it: `17
    /// grey-level images of 1024x768 (8-bit, codes 0, 16, …, 255)`.
    pub fn describe(&self) -> String {
        let codes: Vec<String> = self.levels.iter().map(|l| l.code.to_string()).collect();
        format!(
            "{} grey-level images of {}x{} ({}-bit, codes {})",
            self.levels.len(),
            self.width,
            self.height,
            self.bit_depth,
            codes.join(", ")
        )
    }

    /// What `fsm calibrate response --write-patterns` says once the set is in the folder
    /// `dir`: `wrote 17 grey-level images of … and levels.json to DIR`.
    pub fn written_to(&self, dir: &Path) -> String {
        let (what, name) = (self.describe(), GREY_LEVELS_MANIFEST);
        format!("wrote {what} and {name} to {}", dir.display())
    }

    /// The response inputs of the levels, in order.
    pub fn fractions(&self) -> Vec<f64> {
        self.levels.iter().map(|l| l.fraction).collect()
    }
}

/// The levels' codes must run from exactly 0 to exactly 1, strictly increasing, at least 3.
fn check_fractions(fractions: &[f64]) -> Result<(), String> {
    if fractions.len() < 3 {
        return Err(format!(
            "{} grey levels: at least 3 are needed (dark, full and one between)",
            fractions.len()
        ));
    }
    if fractions[0] != 0.0 || fractions[fractions.len() - 1] != 1.0 {
        return Err("the grey levels must start at code 0 and end at the full code".into());
    }
    for (i, w) in fractions.windows(2).enumerate() {
        if !w[0].is_finite() || !w[1].is_finite() || w[1] <= w[0] {
            return Err(format!(
                "level {}: code {} is not above level {}'s {}",
                i + 1,
                w[1],
                i,
                w[0]
            ));
        }
    }
    Ok(())
}

/// Writes `levels` uniform grey images (`0000.png`, …, ascending codes from 0 to full) of
/// `width × height` and their manifest into the folder `out`, whole or not at all.
pub fn write_grey_level_set(
    out: &Path,
    levels: usize,
    width: u32,
    height: u32,
    sixteen_bit: bool,
    format: ImageFormat,
    replace: bool,
) -> Result<GreyLevelManifest> {
    let max_code = full_code(sixteen_bit);
    let codes = grey_level_codes(levels, max_code).map_err(Error::Usage)?;
    if width == 0 || height == 0 {
        return Err(Error::Usage(format!(
            "grey-level images of {width}x{height}: width and height must be at least 1"
        )));
    }
    let staged = StagedDir::create(out, replace)?;
    let n = width as usize * height as usize;
    let entries = codes
        .par_iter()
        .enumerate()
        .map(|(index, &code)| {
            let file = crate::patterns::frame_file_name(index, codes.len(), format);
            let path = staged.file(&file);
            let encode_error = |e: image_files::ImageError| Error::Encode {
                path: path.clone(),
                message: e.0,
            };
            let f = std::fs::File::create(&path).at(&path)?;
            let mut w = std::io::BufWriter::new(f);
            if sixteen_bit {
                let image = vec![code; n];
                match format {
                    ImageFormat::Png => {
                        image_files::write_png_gray16(&mut w, width, height, &image)
                    }
                    ImageFormat::Tiff => {
                        image_files::write_tiff_gray16(&mut w, width, height, &image)
                    }
                }
            } else {
                let image = vec![code as u8; n];
                match format {
                    ImageFormat::Png => image_files::write_png_gray8(&mut w, width, height, &image),
                    ImageFormat::Tiff => {
                        image_files::write_tiff_gray8(&mut w, width, height, &image)
                    }
                }
            }
            .map_err(encode_error)?;
            std::io::Write::flush(&mut w).at(&path)?;
            Ok(GreyLevel {
                index,
                file,
                code,
                fraction: code as f64 / max_code as f64,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let manifest = GreyLevelManifest {
        format_version: GREY_LEVELS_VERSION,
        kind: GREY_LEVELS_KIND.into(),
        width,
        height,
        bit_depth: if sixteen_bit { 16 } else { 8 },
        levels: entries,
    };
    let json = serde_json::to_string_pretty(&manifest).expect("manifest serialises");
    outputs::write_file(&staged.file(GREY_LEVELS_MANIFEST), json.as_bytes())?;
    staged.commit()?;
    Ok(manifest)
}

/// What is wrong with grey-level captures; `level` says which (index into the set).
#[derive(Clone, Debug, PartialEq)]
pub struct EstimateError {
    /// The level concerned, if one.
    pub level: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl std::fmt::Display for EstimateError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.level {
            Some(level) => write!(f, "level {level}: {}", self.message),
            None => f.write_str(&self.message),
        }
    }
}

impl std::error::Error for EstimateError {}

fn level_error(level: usize, message: String) -> EstimateError {
    EstimateError {
        level: Some(level),
        message,
    }
}

/// The measurement at one grey level.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LevelEstimate {
    /// Index in the set.
    pub index: usize,
    /// Code, fraction of full scale.
    pub code: f64,
    /// Measured light, fraction of the full code's (dark subtracted): the interquartile mean of
    /// the usable pixels' ratios.
    pub light: f64,
    /// Standard deviation of the ratios within the interquartile range (noise and
    /// non-uniformity of the ratio across the image).
    pub spread: f64,
    /// Pixels that contributed.
    pub pixels: usize,
    /// Usable pixels whose sample at this level was saturated (left out).
    pub saturated: usize,
    /// `code^gamma` of the fit.
    pub fitted: f64,
}

/// A measured projector response.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ResponseEstimate {
    /// Best-fit `gamma` of `light = code^gamma` (least squares in light over the levels between
    /// dark and full).
    pub gamma: f64,
    /// RMS of `light − code^gamma` over those levels, fraction of full light.
    pub fit_rms: f64,
    /// Largest `|light − code^gamma|`, …
    pub fit_max: f64,
    /// … at this level.
    pub fit_max_level: usize,
    /// Pixels per image.
    pub pixels: usize,
    /// Pixels used (not saturated, not too dim).
    pub pixels_used: usize,
    /// Pixels left out: saturated in the dark or the full-code capture.
    pub pixels_saturated: usize,
    /// Pixels left out: full minus dark below the contrast threshold.
    pub pixels_dim: usize,
    /// Sensor code at which a sample counts as saturated (`2^bits − 1`).
    pub saturation_code: u16,
    /// Median full-minus-dark contrast of the used pixels, sensor codes.
    pub median_contrast_dn: f64,
    /// Every level, dark and full included (lights 0 and 1 by construction).
    pub levels: Vec<LevelEstimate>,
}

impl ResponseEstimate {
    /// The sensor's bit depth the captures were read with (of [`Self::saturation_code`]).
    pub fn bit_depth(&self) -> u8 {
        (self.saturation_code as u32 + 1).trailing_zeros() as u8
    }

    /// The estimate as the text `fsm calibrate response` prints for the captures in `images`:
    /// pixels used, the fit, and every level.
    pub fn table(&self, images: &std::path::Path) -> String {
        use std::fmt::Write;
        let (e, bits) = (self, self.bit_depth());
        let mut out = format!(
            "projector response from {} ({} levels, {bits}-bit sensor): {} of {} pixels used ({} saturated in the dark or full-code capture, {} too dim; median contrast {:.0} codes)\n",
            images.display(),
            e.levels.len(),
            e.pixels_used,
            e.pixels,
            e.pixels_saturated,
            e.pixels_dim,
            e.median_contrast_dn
        );
        let _ = writeln!(
            out,
            "best-fit gamma {:.4}, RMS residual {:.5} of full light (largest {:.5} at level {})",
            e.gamma, e.fit_rms, e.fit_max, e.fit_max_level
        );
        out.push_str("level    code    light   code^gamma   spread   pixels  saturated\n");
        for l in &e.levels {
            let _ = writeln!(
                out,
                "{:>5}  {:.4}  {:.5}  {:>10.5}  {:.5}  {:>7}  {:>9}",
                l.index, l.code, l.light, l.fitted, l.spread, l.pixels, l.saturated
            );
        }
        out
    }

    /// The power law fitted.
    pub fn gamma_response(&self) -> ProjectorResponse {
        ProjectorResponse::Gamma(self.gamma)
    }

    /// The measured table (strictly increasing: checked when estimated).
    pub fn table_response(&self) -> ProjectorResponse {
        ProjectorResponse::Table(self.levels.iter().map(|l| (l.code, l.light)).collect())
    }
}

/// Accumulates grey-level captures: built from the dark and full-code captures, then fed every
/// level between ([`ResponseEstimator::level`], any order, in parallel if wished).
#[derive(Clone, Debug)]
pub struct ResponseEstimator {
    codes: Vec<f64>,
    width: usize,
    saturation: u16,
    /// Per pixel: dark value and `1 / (full − dark)`, or `None` if not usable.
    pixels: Vec<Option<(f32, f32)>>,
    pixels_saturated: usize,
    pixels_dim: usize,
    median_contrast_dn: f64,
}

fn check_samples(
    level: usize,
    samples: &[u16],
    expected: usize,
    width: usize,
    saturation: u16,
) -> Result<(), EstimateError> {
    if samples.len() != expected {
        return Err(level_error(
            level,
            format!("{} samples, the dark capture has {expected}", samples.len()),
        ));
    }
    if let Some(i) = samples.iter().position(|&s| s > saturation) {
        return Err(level_error(
            level,
            format!(
                "pixel ({}, {}) = {} is above the sensor's top code {saturation} (wrong --bit-depth?)",
                i % width.max(1),
                i / width.max(1),
                samples[i]
            ),
        ));
    }
    Ok(())
}

impl ResponseEstimator {
    /// Starts an estimate. `codes`: every level's code (fraction of full scale), from exactly 0
    /// to exactly 1, strictly increasing; `dark`, `full`: the captures of the first and last
    /// level, row-major, `width` pixels per row; `saturation`: the sensor's top code.
    pub fn new(
        codes: &[f64],
        width: usize,
        dark: &[u16],
        full: &[u16],
        saturation: u16,
    ) -> Result<Self, EstimateError> {
        check_fractions(codes).map_err(|message| EstimateError {
            level: None,
            message,
        })?;
        let last = codes.len() - 1;
        if dark.is_empty() || width == 0 || !dark.len().is_multiple_of(width) {
            return Err(level_error(
                0,
                format!("{} samples are not whole rows of {width}", dark.len()),
            ));
        }
        check_samples(0, dark, dark.len(), width, saturation)?;
        check_samples(last, full, dark.len(), width, saturation)?;
        let mut saturated = 0;
        let mut contrasts = Vec::with_capacity(dark.len());
        for (&d, &f) in dark.iter().zip(full) {
            if d >= saturation || f >= saturation {
                saturated += 1;
            } else {
                contrasts.push(f as f64 - d as f64);
            }
        }
        let median = if contrasts.is_empty() {
            0.0
        } else {
            let mid = contrasts.len() / 2;
            *contrasts
                .select_nth_unstable_by(mid, |a, b| a.total_cmp(b))
                .1
        };
        let threshold = MIN_CONTRAST_DN.max(MIN_RELATIVE_CONTRAST * median);
        let mut dim = 0;
        let pixels: Vec<Option<(f32, f32)>> = dark
            .iter()
            .zip(full)
            .map(|(&d, &f)| {
                if d >= saturation || f >= saturation {
                    None
                } else if (f as f64 - d as f64) < threshold {
                    dim += 1;
                    None
                } else {
                    Some((d as f32, 1.0 / (f as f32 - d as f32)))
                }
            })
            .collect();
        let used = pixels.iter().filter(|p| p.is_some()).count();
        if used < MIN_USABLE_PIXELS {
            return Err(EstimateError {
                level: None,
                message: format!(
                    "only {used} of {} pixels are usable ({saturated} saturated in the dark or full-code capture, {dim} with full minus dark below {threshold:.1} codes; at least {MIN_USABLE_PIXELS} are needed): lower the exposure if saturated, raise it or aim at a white surface if dim",
                    dark.len()
                ),
            });
        }
        Ok(ResponseEstimator {
            codes: codes.to_vec(),
            width,
            saturation,
            pixels,
            pixels_saturated: saturated,
            pixels_dim: dim,
            median_contrast_dn: median,
        })
    }

    /// The measurement of level `index` (strictly between the dark and full levels) from its
    /// capture.
    pub fn level(&self, index: usize, samples: &[u16]) -> Result<LevelEstimate, EstimateError> {
        if index == 0 || index + 1 >= self.codes.len() {
            return Err(level_error(
                index,
                format!(
                    "not a level between dark (0) and full ({})",
                    self.codes.len() - 1
                ),
            ));
        }
        check_samples(
            index,
            samples,
            self.pixels.len(),
            self.width,
            self.saturation,
        )?;
        let mut saturated = 0;
        let mut ratios: Vec<f32> = Vec::with_capacity(self.pixels.len());
        for (p, &s) in self.pixels.iter().zip(samples) {
            if let Some((d, inv)) = *p {
                if s >= self.saturation {
                    saturated += 1;
                } else {
                    ratios.push((s as f32 - d) * inv);
                }
            }
        }
        if ratios.len() < MIN_USABLE_PIXELS {
            return Err(level_error(
                index,
                format!(
                    "only {} usable pixels are not saturated ({saturated} are): lower the exposure",
                    ratios.len()
                ),
            ));
        }
        ratios.sort_unstable_by(|a, b| a.total_cmp(b));
        let n = ratios.len();
        let middle = &ratios[n / 4..n - n / 4];
        let mean = middle.iter().map(|&r| r as f64).sum::<f64>() / middle.len() as f64;
        let var = middle
            .iter()
            .map(|&r| (r as f64 - mean).powi(2))
            .sum::<f64>()
            / middle.len() as f64;
        Ok(LevelEstimate {
            index,
            code: self.codes[index],
            light: mean,
            spread: var.sqrt(),
            pixels: n,
            saturated,
            fitted: f64::NAN,
        })
    }

    /// The estimate from the levels between dark and full (one each, any order): the table
    /// (refused unless strictly increasing, naming the first level that is not) and the
    /// best-fit gamma.
    pub fn finish(
        self,
        mut between: Vec<LevelEstimate>,
    ) -> Result<ResponseEstimate, EstimateError> {
        let last = self.codes.len() - 1;
        between.sort_by_key(|l| l.index);
        let indices: Vec<usize> = between.iter().map(|l| l.index).collect();
        if indices != (1..last).collect::<Vec<_>>() {
            return Err(EstimateError {
                level: None,
                message: format!("levels 1..{last} are needed once each, got {indices:?}"),
            });
        }
        let used = self.pixels.len() - self.pixels_saturated - self.pixels_dim;
        let end = |index: usize, light: f64| LevelEstimate {
            index,
            code: self.codes[index],
            light,
            spread: 0.0,
            pixels: used,
            saturated: 0,
            fitted: light,
        };
        let mut levels = Vec::with_capacity(self.codes.len());
        levels.push(end(0, 0.0));
        levels.extend(between);
        levels.push(end(last, 1.0));
        for i in 1..levels.len() {
            if !levels[i].light.is_finite() || levels[i].light <= levels[i - 1].light {
                return Err(level_error(
                    i,
                    format!(
                        "code {:.4} measured light {:.5}, not above level {}'s {:.5} (code {:.4}): the response must increase with the code (did the exposure or the ambient light change between captures, or does the projector clip its darkest or brightest codes?)",
                        levels[i].code,
                        levels[i].light,
                        i - 1,
                        levels[i - 1].light,
                        levels[i - 1].code
                    ),
                ));
            }
        }
        let points: Vec<(f64, f64)> = levels[1..last].iter().map(|l| (l.code, l.light)).collect();
        let gamma = fit_gamma(&points);
        let mut sum = 0.0;
        let (mut worst, mut worst_level) = (0.0f64, 0);
        for l in levels.iter_mut() {
            l.fitted = l.code.powf(gamma);
            let e = l.light - l.fitted;
            sum += e * e;
            if e.abs() > worst {
                worst = e.abs();
                worst_level = l.index;
            }
        }
        Ok(ResponseEstimate {
            gamma,
            fit_rms: (sum / points.len() as f64).sqrt(),
            fit_max: worst,
            fit_max_level: worst_level,
            pixels: self.pixels.len(),
            pixels_used: used,
            pixels_saturated: self.pixels_saturated,
            pixels_dim: self.pixels_dim,
            saturation_code: self.saturation,
            median_contrast_dn: self.median_contrast_dn,
            levels,
        })
    }
}

/// The `gamma` in `0.1..=10` minimising `Σ (light − code^gamma)²`: a scan in `ln gamma`, then
/// golden-section refinement around the best point.
fn fit_gamma(points: &[(f64, f64)]) -> f64 {
    let cost = |ln_g: f64| {
        let g = ln_g.exp();
        points
            .iter()
            .map(|&(c, l)| (l - c.powf(g)).powi(2))
            .sum::<f64>()
    };
    let (lo, hi) = (0.1f64.ln(), 10.0f64.ln());
    let steps = 400;
    let step = (hi - lo) / steps as f64;
    let best = (0..=steps)
        .map(|i| lo + i as f64 * step)
        .min_by(|&a, &b| cost(a).total_cmp(&cost(b)))
        .expect("non-empty scan");
    let (mut a, mut b) = ((best - step).max(lo), (best + step).min(hi));
    let r = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..100 {
        let (x1, x2) = (b - r * (b - a), a + r * (b - a));
        if cost(x1) <= cost(x2) {
            b = x2;
        } else {
            a = x1;
        }
    }
    ((a + b) / 2.0).exp()
}

/// The estimate from whole captures in level order (`images[i]` shows `codes[i]`), `width`
/// pixels per row, sensor top code `saturation`.
pub fn estimate(
    codes: &[f64],
    width: usize,
    images: &[&[u16]],
    saturation: u16,
) -> Result<ResponseEstimate, EstimateError> {
    if images.len() != codes.len() || images.len() < 3 {
        return Err(EstimateError {
            level: None,
            message: format!(
                "{} captures for {} levels: one capture per level, at least 3",
                images.len(),
                codes.len()
            ),
        });
    }
    let last = images.len() - 1;
    let estimator = ResponseEstimator::new(codes, width, images[0], images[last], saturation)?;
    let between = (1..last)
        .map(|i| estimator.level(i, images[i]))
        .collect::<Result<Vec<_>, _>>()?;
    estimator.finish(between)
}

/// The estimate from a folder of captures numbered like the grey-level set (`0000.png` shows
/// `codes[0]`, …; PNG or TIFF, 8 or 16-bit), sensor depth `bit_depth` (default: the
/// container's). Errors name the file and what is wrong with it.
pub fn estimate_from_folder(
    dir: &Path,
    codes: &[f64],
    bit_depth: Option<u8>,
) -> Result<ResponseEstimate> {
    check_fractions(codes).map_err(|message| Error::ProjectorResponse {
        path: dir.to_path_buf(),
        message,
    })?;
    let found = crate::stack::numbered_images(dir)?;
    if let Some(missing) = (0..codes.len()).find(|i| !found.contains_key(i)) {
        return Err(Error::Usage(format!(
            "{}: {} numbered images found, the grey-level set has {} (numbered 0 to {}); capture {missing} is missing",
            dir.display(),
            found.len(),
            codes.len(),
            codes.len() - 1
        )));
    }
    if found.len() != codes.len() {
        let extra = found.keys().find(|&&i| i >= codes.len()).copied();
        return Err(Error::Usage(format!(
            "{}: {} numbered images found, the grey-level set has {} (numbered 0 to {}); {} is not one of them",
            dir.display(),
            found.len(),
            codes.len(),
            codes.len() - 1,
            extra.map_or(String::new(), |i| found[&i].display().to_string())
        )));
    }
    let files: Vec<PathBuf> = found.into_values().collect();
    let at = |i: usize, message: String| Error::ProjectorResponse {
        path: files[i].clone(),
        message,
    };
    let info = image_files::probe(&files[0]).map_err(|e| at(0, e.0))?;
    let bits = bit_depth.unwrap_or(info.container_bits);
    if bits == 0 || bits > info.container_bits {
        return Err(at(
            0,
            format!(
                "--bit-depth {bits} does not fit the {}-bit image",
                info.container_bits
            ),
        ));
    }
    let saturation = ((1u32 << bits) - 1) as u16;
    let read = |i: usize| -> Result<Vec<u16>> {
        let (other, data): (ImageInfo, Vec<u16>) =
            image_files::read_image(&files[i]).map_err(|e| at(i, e.0))?;
        if other != info {
            return Err(at(
                i,
                format!(
                    "is {}x{} {}-bit, capture 0 ({}) is {}x{} {}-bit",
                    other.width,
                    other.height,
                    other.container_bits,
                    files[0].display(),
                    info.width,
                    info.height,
                    info.container_bits
                ),
            ));
        }
        Ok(data)
    };
    let from_estimate = |e: EstimateError| match e.level {
        Some(level) if level < files.len() => at(level, format!("level {level}: {}", e.message)),
        _ => Error::ProjectorResponse {
            path: dir.to_path_buf(),
            message: e.message,
        },
    };
    let last = codes.len() - 1;
    let (dark, full) = rayon::join(|| read(0), || read(last));
    let estimator = ResponseEstimator::new(codes, info.width as usize, &dark?, &full?, saturation)
        .map_err(from_estimate)?;
    let between = (1..last)
        .into_par_iter()
        .map(|i| {
            let data = read(i)?;
            estimator.level(i, &data).map_err(from_estimate)
        })
        .collect::<Result<Vec<_>>>()?;
    estimator.finish(between).map_err(from_estimate)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_default_codes_are_those_of_the_grey_level_set() {
        let dir = tempfile::tempdir().unwrap();
        for sixteen_bit in [false, true] {
            let out = dir.path().join(format!("levels-{sixteen_bit}"));
            let set = write_grey_level_set(&out, 5, 2, 2, sixteen_bit, ImageFormat::Png, false);
            let fractions = grey_level_fractions(5, sixteen_bit).unwrap();
            let set = set.unwrap();
            assert_eq!(fractions, set.fractions());
            let codes = if sixteen_bit {
                "0, 16384, 32768, 49151, 65535"
            } else {
                "0, 64, 128, 191, 255"
            };
            let bits = if sixteen_bit { 16 } else { 8 };
            let said = format!("5 grey-level images of 2x2 ({bits}-bit, codes {codes})");
            assert_eq!(set.describe(), said);
        }
        let e = grey_level_fractions(2, false).unwrap_err().to_string();
        assert!(e.contains("--levels 2"), "{e}");
    }

    #[test]
    fn pre_correction_inverts_the_response() {
        let gamma = ProjectorResponse::parse("format_version = 1\ngamma = 2.2").unwrap();
        let table = ProjectorResponse::parse(
            "format_version = 1\ninput = [0.0, 0.5, 1.0]\noutput = [2.0, 40.0, 202.0]",
        )
        .unwrap();
        for r in [gamma, table] {
            for i in 0..=20 {
                let light = i as f64 / 20.0;
                assert!(
                    (r.light_for(r.code_for(light)) - light).abs() < 1e-9,
                    "{r:?} {light}"
                );
            }
        }
    }

    #[test]
    fn a_table_that_cannot_be_normalised_is_refused() {
        // The span of output overflowed: the last normalised entry was NaN, so code_for gave
        // NaN and the written file ("NaN") did not parse back.
        let e = ProjectorResponse::parse(
            "format_version = 1\ninput = [0.0, 1.0]\noutput = [-1e308, 1e308]",
        )
        .unwrap_err();
        assert!(e.starts_with("field output: the range"), "{e}");
        // 0.5 and 0.7 above -1e16 round to the same normalised light: a flat step that
        // code_for divides by.
        let e = ProjectorResponse::parse(
            "format_version = 1\ninput = [0.0, 0.3, 0.6, 1.0]\noutput = [-1e16, 0.5, 0.7, 1.0]",
        )
        .unwrap_err();
        assert!(
            e.starts_with("field output: entries 1 = 0.5 and 2 = 0.7"),
            "{e}"
        );
        // A calibration file's [projector_response] table goes through from_table too.
        assert!(ProjectorResponse::from_table(&[0.0, 1.0], &[-1e308, 1e308]).is_err());
    }

    #[test]
    fn errors_name_the_field() {
        for (text, field) in [
            ("format_version = 1\ngamma = 0", "gamma"),
            (
                "format_version = 1\ninput = [0.0, 1.0]\noutput = [1.0, 1.0]",
                "output",
            ),
            (
                "format_version = 1\ninput = [0.0, 0.9]\noutput = [1.0, 2.0]",
                "input",
            ),
            ("format_version = 1\ngama = 2.2", "gama"),
            ("format_version = 3\ngamma = 2.2", "format_version"),
        ] {
            let e = ProjectorResponse::parse(text).unwrap_err();
            assert!(e.contains(field), "{text}: {e}");
        }
    }

    /// Captures of a projector `light = code^gamma` over a scene of varying albedo, with a dark
    /// offset, noise (deterministic, ±`noise` codes) and a `saturated` share of pixels that
    /// clip at the top code in the brighter levels.
    fn synthetic(
        codes: &[f64],
        gamma: f64,
        width: usize,
        height: usize,
        noise: f64,
        saturated_every: usize,
    ) -> Vec<Vec<u16>> {
        let top = 4095.0;
        let mut state = 12345u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        codes
            .iter()
            .map(|&c| {
                (0..width * height)
                    .map(|i| {
                        let albedo = 0.3 + 0.7 * ((i * 7919) % 1000) as f64 / 1000.0;
                        let gain = if saturated_every > 0 && i % saturated_every == 0 {
                            6000.0
                        } else {
                            3000.0 * albedo
                        };
                        let v = 64.0 + 20.0 * albedo + gain * c.powf(gamma) + noise * next();
                        v.round().clamp(0.0, top) as u16
                    })
                    .collect()
            })
            .collect()
    }

    fn fractions(levels: usize) -> Vec<f64> {
        grey_level_codes(levels, 255)
            .unwrap()
            .iter()
            .map(|&c| c as f64 / 255.0)
            .collect()
    }

    #[test]
    fn estimate_recovers_gamma_and_counts_saturated_pixels() {
        let codes = fractions(17);
        for gamma in [1.0, 1.8, 2.2, 2.6] {
            let images = synthetic(&codes, gamma, 64, 48, 3.0, 10);
            let refs: Vec<&[u16]> = images.iter().map(|v| v.as_slice()).collect();
            let e = estimate(&codes, 64, &refs, 4095).unwrap();
            assert!((e.gamma - gamma).abs() < 0.01, "{gamma}: {}", e.gamma);
            assert!(e.fit_rms < 2e-3, "{gamma}: rms {}", e.fit_rms);
            // Every 10th pixel clips at full code: left out, counted.
            assert_eq!(e.pixels_saturated, (64usize * 48).div_ceil(10));
            assert_eq!(e.pixels_used + e.pixels_saturated + e.pixels_dim, 64 * 48);
            assert_eq!(e.levels.len(), 17);
            let table = e.table_response();
            for l in &e.levels {
                assert!((l.light - l.code.powf(gamma)).abs() < 3e-3, "{l:?}");
                assert!((table.light_for(l.code) - l.light).abs() < 1e-12);
            }
            // The written files parse back to the same responses.
            for r in [e.gamma_response(), table] {
                let text = r.to_file_text("measured\nby a test");
                assert_eq!(ProjectorResponse::parse(&text).unwrap(), r, "{text}");
            }
        }
    }

    #[test]
    fn a_response_with_a_strong_non_power_shape_has_a_large_residual() {
        // An S-curve: the table follows it, the power law cannot.
        let codes = fractions(17);
        let s = |c: f64| (3.0 * c * c - 2.0 * c * c * c).max(0.0);
        let images: Vec<Vec<u16>> = codes
            .iter()
            .map(|&c| vec![(100.0 + 3000.0 * s(c)).round() as u16; 256])
            .collect();
        let refs: Vec<&[u16]> = images.iter().map(|v| v.as_slice()).collect();
        let e = estimate(&codes, 16, &refs, 4095).unwrap();
        assert!(e.fit_rms > 0.02, "{}", e.fit_rms);
        let table = e.table_response();
        for &c in &codes {
            assert!((table.light_for(c) - s(c)).abs() < 1e-3);
        }
    }

    #[test]
    fn non_monotone_data_is_refused_naming_the_level() {
        let codes = fractions(9);
        let mut images = synthetic(&codes, 2.2, 32, 16, 0.0, 0);
        images[5] = images[4].iter().map(|&v| v.saturating_sub(30)).collect();
        let refs: Vec<&[u16]> = images.iter().map(|v| v.as_slice()).collect();
        let e = estimate(&codes, 32, &refs, 4095).unwrap_err();
        assert_eq!(e.level, Some(5), "{e}");
        assert!(e.to_string().starts_with("level 5: code 0.6"), "{e}");
        // A sample above the sensor's range names the pixel.
        let mut images = synthetic(&codes, 2.2, 32, 16, 0.0, 0);
        images[3][32 * 2 + 7] = 5000;
        let refs: Vec<&[u16]> = images.iter().map(|v| v.as_slice()).collect();
        let e = estimate(&codes, 32, &refs, 4095).unwrap_err();
        assert!(
            e.to_string().contains("level 3: pixel (7, 2) = 5000"),
            "{e}"
        );
        // Nothing usable: every pixel saturated at full code.
        let images: Vec<Vec<u16>> = codes
            .iter()
            .map(|&c| vec![if c == 1.0 { 4095 } else { 100 }; 64])
            .collect();
        let refs: Vec<&[u16]> = images.iter().map(|v| v.as_slice()).collect();
        let e = estimate(&codes, 8, &refs, 4095).unwrap_err();
        assert!(e.to_string().contains("64 saturated"), "{e}");
    }

    #[test]
    fn grey_level_set_and_captures_round_trip_through_files() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("levels");
        let m = write_grey_level_set(&out, 9, 40, 30, false, ImageFormat::Png, false).unwrap();
        assert_eq!(m.levels.len(), 9);
        assert_eq!(m.levels[0].code, 0);
        assert_eq!(m.levels[8].code, 255);
        let back = GreyLevelManifest::read(&out.join(GREY_LEVELS_MANIFEST)).unwrap();
        assert_eq!(back, m);
        let (info, data) = image_files::read_image(&out.join(&m.levels[4].file)).unwrap();
        assert_eq!((info.width, info.height, info.container_bits), (40, 30, 8));
        assert!(data.iter().all(|&v| v == m.levels[4].code));
        // "Captures": 16-bit TIFFs of a gamma-2.0 projector, 12-bit sensor.
        let captures = dir.path().join("captures");
        std::fs::create_dir(&captures).unwrap();
        let codes = m.fractions();
        let images = synthetic(&codes, 2.0, 40, 30, 2.0, 0);
        for (i, image) in images.iter().enumerate() {
            let f = std::fs::File::create(captures.join(format!("{i:04}.tif"))).unwrap();
            image_files::write_tiff_gray16(std::io::BufWriter::new(f), 40, 30, image).unwrap();
        }
        let e = estimate_from_folder(&captures, &codes, Some(12)).unwrap();
        assert!((e.gamma - 2.0).abs() < 0.01, "{}", e.gamma);
        assert_eq!(e.saturation_code, 4095);
        // Wrong bit depth: the error names the file and the pixel.
        let err = estimate_from_folder(&captures, &codes, Some(10))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("captures/0000.tif") || err.contains("captures/0008.tif"),
            "{err}"
        );
        assert!(err.contains("above the sensor's top code 1023"), "{err}");
        // A missing capture is named.
        std::fs::remove_file(captures.join("0003.tif")).unwrap();
        let err = estimate_from_folder(&captures, &codes, Some(12))
            .unwrap_err()
            .to_string();
        assert!(err.contains("capture 3 is missing"), "{err}");
        // Too few levels.
        assert!(grey_level_codes(2, 255).is_err());
        assert!(grey_level_codes(257, 255).is_err());
    }
}
