//! Captured image stacks: a folder of grey images numbered in sequence order like the
//! patterns (`0000.png`, `0001.tif`, …; PNG or TIFF, 8- or 16-bit containers, sensors of
//! 1–16 bits with `--bit-depth`).
//!
//! [`Stack::open`] checks the frame count, every image's size and container depth against
//! the plan before any work starts, reading only headers. [`Stack::read_band`] reads a band
//! of camera rows of every frame (frames in parallel) straight into the layout the line
//! decoder wants, so no transpose copy is needed: `band[(y − y0)·M·W + i·W + x]` is frame `i`
//! at pixel `(x, y)`, i.e. each row is one sample-major temporal row (SPEC §1).

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use fsm_core::ScanPlan;
use rayon::prelude::*;

use crate::image_files::{self, ImageFormat, ImageInfo};
use crate::plan_file::{MethodPlan, MethodPlanText};

/// What is wrong with a stack.
#[derive(Debug, thiserror::Error)]
pub enum StackError {
    /// The folder cannot be listed.
    #[error("{}: cannot read the capture folder: {source}", dir.display())]
    Folder {
        /// The folder.
        dir: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// The number of numbered images differs from the plan's sequence.
    #[error("{}: holds {found} numbered images, the plan's sequence has {expected} frames ({what}){}", dir.display(), first_missing.map(|i| format!("; frame {i} is the first missing")).unwrap_or_default())]
    Count {
        /// The folder.
        dir: PathBuf,
        /// Numbered images found.
        found: usize,
        /// Frames the plan needs.
        expected: usize,
        /// What the plan's frames are.
        what: String,
        /// The first index below `expected` with no image.
        first_missing: Option<usize>,
    },
    /// Two files carry the same frame number.
    #[error("{}: frame {frame} appears twice ({} and {})", dir.display(), first.display(), second.display())]
    Duplicate {
        /// The folder.
        dir: PathBuf,
        /// The frame number.
        frame: usize,
        /// One file.
        first: PathBuf,
        /// The other.
        second: PathBuf,
    },
    /// One image is unreadable or differs from the others in size or depth.
    #[error("{}: frame {frame}: {message}", path.display())]
    Frame {
        /// The image file.
        path: PathBuf,
        /// Its frame number.
        frame: usize,
        /// What is wrong.
        message: String,
    },
    /// A sample above the sensor's range.
    #[error("{}: frame {frame}, pixel ({x}, {y}) = {value} exceeds the {bits}-bit range 0..={} (is --bit-depth right?)", path.display(), (1u32 << bits) - 1)]
    SampleRange {
        /// The image file.
        path: PathBuf,
        /// Its frame number.
        frame: usize,
        /// Column.
        x: u32,
        /// Row.
        y: u32,
        /// The sample.
        value: u16,
        /// The sensor bit depth.
        bits: u8,
    },
    /// The requested sensor bit depth does not fit the images.
    #[error("{}: --bit-depth {bits} does not fit the stack's {container_bits}-bit images (8-bit images hold 1..=8 bits, 16-bit images 1..=16)", dir.display())]
    BitDepth {
        /// The folder.
        dir: PathBuf,
        /// Requested.
        bits: u8,
        /// The images' container depth.
        container_bits: u8,
    },
}

/// A checked stack of captures.
#[derive(Clone, Debug)]
pub struct Stack {
    dir: PathBuf,
    frames: Vec<PathBuf>,
    info: ImageInfo,
    bit_depth: u8,
}

/// Lists `dir`'s numbered images (`<digits>.<png|tif|tiff>`) by frame number.
pub(crate) fn numbered_images(dir: &Path) -> Result<BTreeMap<usize, PathBuf>, StackError> {
    let folder_error = |source| StackError::Folder {
        dir: dir.to_path_buf(),
        source,
    };
    let mut frames = BTreeMap::new();
    for entry in std::fs::read_dir(dir).map_err(folder_error)? {
        let path = entry.map_err(folder_error)?.path();
        let (Some(stem), Some(_)) = (
            path.file_stem().and_then(|s| s.to_str()),
            ImageFormat::of(&path),
        ) else {
            continue;
        };
        if stem.is_empty() || !stem.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        let Ok(index) = stem.parse::<usize>() else {
            continue;
        };
        if let Some(first) = frames.insert(index, path.clone()) {
            let (first, second) = if first < path {
                (first, path)
            } else {
                (path, first)
            };
            return Err(StackError::Duplicate {
                dir: dir.to_path_buf(),
                frame: index,
                first,
                second,
            });
        }
    }
    Ok(frames)
}

/// "dark, white, 768 fringes": the plan's frames in words.
pub fn sequence_summary(plan: &ScanPlan) -> String {
    let mut parts = Vec::new();
    if plan.references.dark {
        parts.push("dark".to_owned());
    }
    if plan.references.white {
        parts.push("white".to_owned());
    }
    for group in plan.groups() {
        let label = if plan.group_count() > 1 {
            format!(" of group {}", group.number())
        } else {
            String::new()
        };
        parts.push(format!("{} fringes{label}", plan.band.count));
        let masks = plan.mask_count(group);
        if masks > 0 {
            parts.push(format!("{masks} masks{label}"));
        }
    }
    parts.join(", ")
}

impl Stack {
    /// Finds and checks the captures of `plan` in `dir`: count, size and container depth of
    /// every image (headers only), and `bit_depth` (the sensor's; default: the container's).
    pub fn open(
        dir: &Path,
        plan: impl Into<MethodPlan>,
        bit_depth: Option<u8>,
    ) -> Result<Self, StackError> {
        let plan: MethodPlan = plan.into();
        let found = numbered_images(dir)?;
        let expected = plan.frame_count();
        let first_missing = (0..expected).find(|i| !found.contains_key(i));
        if found.len() != expected || first_missing.is_some() {
            return Err(StackError::Count {
                dir: dir.to_path_buf(),
                found: found.len(),
                expected,
                what: plan.sequence_summary(),
                first_missing,
            });
        }
        let frames: Vec<PathBuf> = found.into_values().collect();
        let probe = |frame: usize| {
            image_files::probe(&frames[frame]).map_err(|e| StackError::Frame {
                path: frames[frame].clone(),
                frame,
                message: e.0,
            })
        };
        let info = probe(0)?;
        // Headers of the other frames, in parallel: a mismatch anywhere stops the work here,
        // reported for the first bad frame in sequence order (the same error on every run).
        let probed: Vec<Result<(), StackError>> = (1..frames.len())
            .into_par_iter()
            .map(|frame| {
                let other = probe(frame)?;
                if other != info {
                    return Err(StackError::Frame {
                        path: frames[frame].clone(),
                        frame,
                        message: format!(
                            "is {}x{} {}-bit, frame 0 ({}) is {}x{} {}-bit",
                            other.width,
                            other.height,
                            other.container_bits,
                            frames[0].display(),
                            info.width,
                            info.height,
                            info.container_bits
                        ),
                    });
                }
                Ok(())
            })
            .collect();
        probed.into_iter().collect::<Result<(), StackError>>()?;
        let bit_depth = bit_depth.unwrap_or(info.container_bits);
        if bit_depth == 0 || bit_depth > info.container_bits {
            return Err(StackError::BitDepth {
                dir: dir.to_path_buf(),
                bits: bit_depth,
                container_bits: info.container_bits,
            });
        }
        Ok(Stack {
            dir: dir.to_path_buf(),
            frames,
            info,
            bit_depth,
        })
    }

    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Image file of frame `index`.
    pub fn frame_path(&self, index: usize) -> &Path {
        &self.frames[index]
    }

    /// Number of frames `M`.
    pub fn frame_count(&self) -> usize {
        self.frames.len()
    }

    /// Pixels per row `W`.
    pub fn width(&self) -> u32 {
        self.info.width
    }

    /// Rows `H`.
    pub fn height(&self) -> u32 {
        self.info.height
    }

    /// Sensor bit depth.
    pub fn bit_depth(&self) -> u8 {
        self.bit_depth
    }

    /// Bits per sample of the image files (8 or 16).
    pub fn container_bits(&self) -> u8 {
        self.info.container_bits
    }

    /// Samples of one temporal row, `M·W`.
    pub fn row_len(&self) -> usize {
        self.frames.len() * self.info.width as usize
    }

    /// The stack's samples as the line decoder holds them: `M·W·H` samples of 2 bytes (`u16`).
    pub fn samples_bytes(&self) -> u64 {
        self.row_len() as u64 * self.info.height as u64 * 2
    }

    /// The stack's own size: `M·W·H` samples of its container depth (1 or 2 bytes).
    pub fn own_bytes(&self) -> u64 {
        self.row_len() as u64 * self.info.height as u64 * (self.info.container_bits as u64 / 8)
    }

    /// Reads camera rows `rows` of every frame into `band` (length `rows.len()·M·W`),
    /// sample-major per row. Frames are decoded in parallel on the current rayon pool.
    pub fn read_band(&self, rows: Range<u32>, band: &mut [u16]) -> Result<(), StackError> {
        let w = self.info.width as usize;
        let m = self.frames.len();
        let n_rows = rows.len();
        assert_eq!(band.len(), n_rows * m * w, "band buffer size");
        // Per frame, the slices of the band it fills: one per row, disjoint.
        let mut slots: Vec<Vec<&mut [u16]>> = (0..m).map(|_| Vec::with_capacity(n_rows)).collect();
        for row in band.chunks_exact_mut(m * w) {
            for (frame, slot) in row.chunks_exact_mut(w).enumerate() {
                slots[frame].push(slot);
            }
        }
        let max = ((1u32 << self.bit_depth) - 1) as u16;
        // Every frame's result, then the first error in sequence order: the same error on every
        // run, whichever thread meets a bad frame first (`try_for_each` returned that one).
        let results: Vec<Result<(), StackError>> = slots
            .into_par_iter()
            .enumerate()
            .map(|(frame, mut slot)| {
                let path = &self.frames[frame];
                let mut out_of_range = None;
                image_files::read_rows(path, &self.info, rows.clone(), |y, samples| {
                    let dest = &mut slot[(y - rows.start) as usize];
                    dest.copy_from_slice(samples);
                    if out_of_range.is_none() {
                        if let Some(x) = samples.iter().position(|&s| s > max) {
                            out_of_range = Some((x as u32, y, samples[x]));
                        }
                    }
                    Ok(())
                })
                .map_err(|e| StackError::Frame {
                    path: path.clone(),
                    frame,
                    message: e.0,
                })?;
                if let Some((x, y, value)) = out_of_range {
                    return Err(StackError::SampleRange {
                        path: path.clone(),
                        frame,
                        x,
                        y,
                        value,
                        bits: self.bit_depth,
                    });
                }
                Ok(())
            })
            .collect();
        results.into_iter().collect()
    }
}
