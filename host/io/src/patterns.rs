//! Pattern sets: the projector images of a plan's whole sequence, numbered in sequence order
//! (`0000.png`, `0001.png`, …), with a manifest that says what each image is.
//!
//! Every value comes from the one pattern function, [`ScanPlan::intensity`] (paper eqs. 4, 14;
//! SPEC §2–§3), or a baseline's [`PatternSequence::frame_intensity`], so the images, the
//! simulator and the decoder cannot disagree. An optional
//! projector response ([`ProjectorResponse`]) pre-corrects the codes so that the emitted light,
//! not the code, follows the cosine.

use std::path::Path;

use fsm_core::baseline::phase_shift::PhaseShiftPattern;
use fsm_core::{Pattern, PatternSequence, ScanPlan};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::image_files::{self, ImageFormat};
use crate::outputs::{self, StagedDir};
use crate::plan_file::{MethodPlan, MethodPlanText};
use crate::progress::Progress;
use crate::projector_response::ProjectorResponse;

/// Name of the manifest written beside the images.
pub const MANIFEST_NAME: &str = "manifest.json";
/// Version of the manifest format (2: `plan` is the plan file's form, so that a baseline's
/// plan fits; the frames of baselines).
pub const MANIFEST_VERSION: u32 = 2;

/// How to render a pattern set.
#[derive(Clone, Debug)]
pub struct PatternOptions {
    /// Projector width in pixels; at least the plan's `projector_columns` (columns beyond
    /// `cmax` stay dark). `None`: exactly `cmax`.
    pub width: Option<u32>,
    /// Projector height in pixels (every row is the same: patterns vary along columns only).
    pub height: u32,
    /// 16-bit images instead of 8-bit.
    pub sixteen_bit: bool,
    /// PNG (default) or TIFF.
    pub format: ImageFormat,
    /// Gamma pre-correction.
    pub response: Option<ProjectorResponse>,
}

/// The projector codes of one row of `pattern`, `width` pixels, full scale `max_code`.
pub fn pattern_row(
    plan: &ScanPlan,
    pattern: Pattern,
    width: u32,
    max_code: u16,
    response: Option<&ProjectorResponse>,
) -> Vec<u16> {
    codes(
        |column| plan.intensity(pattern, column),
        width,
        max_code,
        response,
    )
}

/// The projector codes of one row of frame `frame` of any method's `patterns`.
pub fn frame_row(
    patterns: &dyn PatternSequence,
    frame: usize,
    width: u32,
    max_code: u16,
    response: Option<&ProjectorResponse>,
) -> Vec<u16> {
    codes(
        |column| patterns.frame_intensity(frame, column),
        width,
        max_code,
        response,
    )
}

/// Codes of the light `light(column)` over `width` columns, pre-corrected by `response`.
fn codes(
    light: impl Fn(u32) -> f32,
    width: u32,
    max_code: u16,
    response: Option<&ProjectorResponse>,
) -> Vec<u16> {
    (0..width)
        .map(|column| {
            let light = light(column) as f64;
            let code = response.map_or(light, |r| r.code_for(light));
            (code * max_code as f64).round().clamp(0.0, max_code as f64) as u16
        })
        .collect()
}

/// File name of frame `index` of a sequence of `frames`: zero-padded to at least 4 digits.
pub fn frame_file_name(index: usize, frames: usize, format: ImageFormat) -> String {
    let digits = frames.saturating_sub(1).to_string().len().max(4);
    let ext = match format {
        ImageFormat::Png => "png",
        ImageFormat::Tiff => "tif",
    };
    format!("{index:0digits$}.{ext}")
}

/// What one image of a pattern set shows.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ManifestPattern {
    /// Projector off.
    Dark,
    /// Every column full on.
    White,
    /// Fringe `m` of group `group`: `PA + PB·cos(2π f_m c̃)`, `f_m = harmonic / period_columns`.
    Fringe {
        /// Group, 1 or 2.
        group: u8,
        /// `m`, 0-based.
        m: u16,
        /// `n₁ + m`.
        harmonic: u32,
        /// `L`.
        period_columns: u32,
        /// `f_m` in cycles per column.
        frequency: f64,
    },
    /// Mask `mask` of group `group`: the blocks listed are full on, all else off.
    Mask {
        /// Group, 1 or 2.
        group: u8,
        /// Mask number, 0-based.
        mask: u16,
        /// The blocks it lights (two for group 2's shared edge mask).
        blocks: Vec<u16>,
    },
    /// A baseline's sinusoidal fringe `½ + ½cos(2π(c/period + offset))` (phase shift, Micro
    /// Phase Shifting).
    PhaseFringe {
        /// Period in columns.
        period_columns: f64,
        /// Phase offset in turns.
        offset_turns: f64,
    },
    /// Phase shift's complementary Gray code: bit `bit` (0 = most significant) of the Gray code
    /// of the half-period index.
    GrayBit {
        /// Bit, most significant first.
        bit: u8,
    },
    /// Line scanning: column `column` alone full on.
    Line {
        /// The lit column.
        column: u32,
    },
    /// Code Ensemble: bit `bit` of the code `code` (`conventional Gray`, `long-run Gray`,
    /// `XOR-04`, `XOR-02`), or its inverse.
    CodeBit {
        /// The code's name.
        code: String,
        /// Pattern bit (0 = the Gray codes' most significant).
        bit: u8,
        /// Whether this is the bit's inverse.
        inverse: bool,
    },
}

/// One image of the set.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifestFrame {
    /// Position in the sequence.
    pub index: usize,
    /// File name in the set's folder.
    pub file: String,
    /// What it shows.
    #[serde(flatten)]
    pub pattern: ManifestPattern,
}

/// The manifest of a pattern set (`manifest.json`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// [`MANIFEST_VERSION`].
    pub format_version: u32,
    /// The plan's fingerprint, 16 hex digits.
    pub plan_fingerprint: String,
    /// The fingerprint of the plan's patterns alone, 16 hex digits: what the row dump of a
    /// capture of these images carries (absent from manifests written before it existed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pattern_fingerprint: Option<String>,
    /// The plan itself, as its plan file holds it (without `format_version`).
    pub plan: serde_json::Value,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Bits per sample: 8 or 16.
    pub bit_depth: u8,
    /// The projector-response file the codes were pre-corrected with, if any.
    pub response_file: Option<String>,
    /// Every image, in sequence order.
    pub frames: Vec<ManifestFrame>,
}

impl Manifest {
    /// The set in words, as `fsm patterns` reports it: `770 images of 768x768 (8-bit)`.
    pub fn describe(&self) -> String {
        let (frames, bits) = (self.frames.len(), self.bit_depth);
        format!(
            "{frames} images of {}x{} ({bits}-bit)",
            self.width, self.height
        )
    }

    /// What `fsm patterns` says once the set is in the folder `dir`: `wrote 770 images of
    /// 768x768 (8-bit) and manifest.json to DIR`.
    pub fn written_to(&self, dir: &Path) -> String {
        let (what, name) = (self.describe(), MANIFEST_NAME);
        format!("wrote {what} and {name} to {}", dir.display())
    }
}

/// The manifest entry of `pattern`.
pub fn describe(plan: &ScanPlan, pattern: Pattern) -> ManifestPattern {
    match pattern {
        Pattern::Dark => ManifestPattern::Dark,
        Pattern::White => ManifestPattern::White,
        Pattern::Fringe { group, index } => ManifestPattern::Fringe {
            group: group.number(),
            m: index,
            harmonic: plan.band.first_harmonic + index as u32,
            period_columns: plan.band.period_columns,
            frequency: plan.frequency(index),
        },
        Pattern::Mask { group, index } => {
            let blocks = plan.mask_blocks(group, index);
            ManifestPattern::Mask {
                group: group.number(),
                mask: index,
                blocks: std::iter::once(blocks.first).chain(blocks.second).collect(),
            }
        }
    }
}

/// The manifest entry of frame `frame` of `plan`, any method.
pub fn describe_frame(plan: &MethodPlan, frame: usize) -> ManifestPattern {
    match plan {
        MethodPlan::Fsm(p) => describe(p, p.pattern(frame).expect("frame within the sequence")),
        MethodPlan::PhaseShift(p) => match p.pattern(frame).expect("frame within the sequence") {
            PhaseShiftPattern::Dark => ManifestPattern::Dark,
            PhaseShiftPattern::White => ManifestPattern::White,
            PhaseShiftPattern::Fringe { step } => ManifestPattern::PhaseFringe {
                period_columns: p.period_columns as f64,
                offset_turns: -(step as f64) / p.steps as f64,
            },
            PhaseShiftPattern::Gray { bit } => ManifestPattern::GrayBit { bit },
        },
        MethodPlan::MicroPhaseShift(p) => {
            let (f, offset) = p.frame(frame).expect("frame within the sequence");
            ManifestPattern::PhaseFringe {
                period_columns: p.periods()[f] as f64,
                offset_turns: offset,
            }
        }
        MethodPlan::CodeEnsemble(p) => {
            let (code, bit, inverse) = p.frame(frame).expect("frame within the sequence");
            ManifestPattern::CodeBit {
                code: code.name().to_owned(),
                bit: bit as u8,
                inverse,
            }
        }
        MethodPlan::LineScan(_) => match frame {
            0 => ManifestPattern::Dark,
            1 => ManifestPattern::White,
            f => ManifestPattern::Line {
                column: (f - 2) as u32,
            },
        },
    }
}

/// Writes the pattern images of `plan` and their manifest into the folder `out`, whole or not
/// at all (an existing non-empty folder is refused unless `replace`).
pub fn write_pattern_set(
    plan: &ScanPlan,
    options: &PatternOptions,
    response_file: Option<&Path>,
    out: &Path,
    replace: bool,
    progress: &Progress,
) -> Result<Manifest> {
    write_method_pattern_set(
        &MethodPlan::Fsm(*plan),
        options,
        response_file,
        out,
        replace,
        progress,
    )
}

/// [`write_pattern_set`] for a plan of any method.
pub fn write_method_pattern_set(
    plan: &MethodPlan,
    options: &PatternOptions,
    response_file: Option<&Path>,
    out: &Path,
    replace: bool,
    progress: &Progress,
) -> Result<Manifest> {
    plan.validate().map_err(|source| Error::PlanFile {
        path: out.to_path_buf(),
        source,
    })?;
    let patterns = plan.patterns();
    let columns = patterns.projector_columns() as u32;
    let width = options.width.unwrap_or(columns);
    if width < columns || options.height == 0 {
        return Err(Error::Usage(format!(
            "projector size {width}x{}: the width must be at least the plan's {columns} columns and the height at least 1",
            options.height
        )));
    }
    let staged = StagedDir::create(out, replace)?;
    let frames = patterns.frame_count();
    let max_code = if options.sixteen_bit {
        u16::MAX
    } else {
        u8::MAX as u16
    };
    progress.start(frames as u64, "writing patterns");
    let entries: Vec<ManifestFrame> = (0..frames)
        .into_par_iter()
        .map(|index| {
            let file = frame_file_name(index, frames, options.format);
            let row = frame_row(
                plan.patterns(),
                index,
                width,
                max_code,
                options.response.as_ref(),
            );
            write_pattern_image(&staged.file(&file), options, width, &row)?;
            progress.advance(1);
            Ok(ManifestFrame {
                index,
                file,
                pattern: describe_frame(plan, index),
            })
        })
        .collect::<Result<_>>()?;
    progress.finish();
    let manifest = Manifest {
        format_version: MANIFEST_VERSION,
        plan_fingerprint: format!("{:016x}", patterns.fingerprint()),
        pattern_fingerprint: Some(format!("{:016x}", patterns.pattern_fingerprint())),
        plan: crate::plan_file::plan_value(plan),
        width,
        height: options.height,
        bit_depth: if options.sixteen_bit { 16 } else { 8 },
        response_file: response_file.map(|p| p.display().to_string()),
        frames: entries,
    };
    let json = serde_json::to_string_pretty(&manifest).expect("manifest serialises");
    outputs::write_file(&staged.file(MANIFEST_NAME), json.as_bytes())?;
    staged.commit()?;
    Ok(manifest)
}

fn write_pattern_image(
    path: &Path,
    options: &PatternOptions,
    width: u32,
    row: &[u16],
) -> Result<()> {
    let height = options.height;
    let encode_error = |e: image_files::ImageError| Error::Encode {
        path: path.to_path_buf(),
        message: e.0,
    };
    let file = std::fs::File::create(path).map_err(|e| Error::io(path, e))?;
    let mut out = std::io::BufWriter::new(file);
    let n = width as usize * height as usize;
    if options.sixteen_bit {
        let image: Vec<u16> = row.iter().copied().cycle().take(n).collect();
        match options.format {
            ImageFormat::Png => image_files::write_png_gray16(&mut out, width, height, &image),
            ImageFormat::Tiff => image_files::write_tiff_gray16(&mut out, width, height, &image),
        }
    } else {
        let image: Vec<u8> = row.iter().map(|&v| v as u8).cycle().take(n).collect();
        match options.format {
            ImageFormat::Png => image_files::write_png_gray8(&mut out, width, height, &image),
            ImageFormat::Tiff => image_files::write_tiff_gray8(&mut out, width, height, &image),
        }
    }
    .map_err(encode_error)?;
    std::io::Write::flush(&mut out).map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fsm_core::GroupCount;

    #[test]
    fn set_and_manifest_follow_the_sequence() {
        let dir = tempfile::tempdir().unwrap();
        let plan = ScanPlan::paper_efsm(GroupCount::Two);
        let out = dir.path().join("patterns");
        let options = PatternOptions {
            width: None,
            height: 3,
            sixteen_bit: true,
            format: ImageFormat::Png,
            response: None,
        };
        let manifest =
            write_pattern_set(&plan, &options, None, &out, false, &Progress::hidden()).unwrap();
        assert_eq!(manifest.frames.len(), plan.sequence_len());
        let text = std::fs::read_to_string(out.join(MANIFEST_NAME)).unwrap();
        let back: Manifest = serde_json::from_str(&text).unwrap();
        assert_eq!(back, manifest);
        for (i, frame) in manifest.frames.iter().enumerate() {
            let (info, data) = image_files::read_image(&out.join(&frame.file)).unwrap();
            assert_eq!((info.width, info.height, info.container_bits), (768, 3, 16));
            let pattern = plan.pattern(i).unwrap();
            for x in [0u32, 1, 31, 32, 700, 767] {
                let want = (plan.intensity(pattern, x) as f64 * 65535.0).round() as u16;
                assert_eq!(data[x as usize], want);
                assert_eq!(data[2 * 768 + x as usize], want);
            }
        }
        assert_eq!(manifest.frames[0].pattern, ManifestPattern::Dark);
        assert_eq!(manifest.frames[0].file, "0000.png");
    }
}
