//! A pose folder of `fsm calibrate target`: the board's white frame and its decoded column
//! map, from a captured stack of the plan's patterns (decoded with `fsm_io`'s pipeline) or from
//! `column.tiff` beside a white frame.

use std::fmt;
use std::path::Path;

use fsm_core::ScanPlan;
use fsm_io::candidate_file::HostCandidates;
use fsm_io::capture::Capture;
use fsm_io::column_map::COLUMN_TIFF_NAME;
use fsm_io::decode::{decode_capture, DecodeOptions};
use fsm_io::image_files;
use fsm_io::progress::Progress;
use fsm_io::{Error, Result};

/// The names the white frame of a decoded pose folder may have.
pub const WHITE_NAMES: [&str; 3] = ["white.png", "white.tif", "white.tiff"];
/// The names its optional dark frame may have.
pub const DARK_NAMES: [&str; 3] = ["dark.png", "dark.tif", "dark.tiff"];

fn read_grey(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    let (info, data) = image_files::read_image(path)
        .map_err(|e| Error::Usage(format!("{}: {}", path.display(), e.0)))?;
    Ok((
        info.width,
        info.height,
        data.into_iter().map(f32::from).collect(),
    ))
}

/// A pose folder's white − dark image and column map, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseData {
    /// Image width, px.
    pub width: u32,
    /// Image height, px.
    pub height: u32,
    /// The board under the full-on frame less the dark frame (where given), grey levels.
    pub white: Vec<f32>,
    /// The strongest candidate's projector column of each pixel (NaN: none).
    pub columns: Vec<f32>,
}

/// Reads a pose folder: `column.tiff` and `white.png` (`dark.png` optional) as written by
/// `fsm decode` and a camera, or a captured stack of `plan`, decoded here (`bit_depth` and
/// `options` as `fsm decode`'s).
pub fn load_pose(
    dir: &Path,
    plan: &ScanPlan,
    bit_depth: Option<u8>,
    options: &DecodeOptions,
) -> Result<PoseData> {
    let column_tiff = dir.join(COLUMN_TIFF_NAME);
    if column_tiff.is_file() {
        let (w, h, columns) = image_files::read_tiff_f32(&column_tiff)
            .map_err(|e| Error::Usage(format!("{}: {}", column_tiff.display(), e.0)))?;
        let white_path = WHITE_NAMES
            .iter()
            .map(|n| dir.join(n))
            .find(|p| p.is_file())
            .ok_or_else(|| {
                Error::Usage(format!(
                    "{}: has {COLUMN_TIFF_NAME} but no white.png / white.tif / white.tiff (the board under a full-on frame) to find the corners in",
                    dir.display()
                ))
            })?;
        let (ww, wh, mut white) = read_grey(&white_path)?;
        if (ww, wh) != (w, h) {
            return Err(Error::Usage(format!(
                "{}: {ww}x{wh}, but {COLUMN_TIFF_NAME} is {w}x{h}",
                white_path.display()
            )));
        }
        if let Some(dark_path) = DARK_NAMES.iter().map(|n| dir.join(n)).find(|p| p.is_file()) {
            let (dw, dh, dark) = read_grey(&dark_path)?;
            if (dw, dh) != (w, h) {
                return Err(Error::Usage(format!(
                    "{}: {dw}x{dh}, but {COLUMN_TIFF_NAME} is {w}x{h}",
                    dark_path.display()
                )));
            }
            for (v, d) in white.iter_mut().zip(dark) {
                *v -= d;
            }
        }
        return Ok(PoseData {
            width: w,
            height: h,
            white,
            columns,
        });
    }
    // A captured stack: decode it, and take its dark and white frames.
    let capture = Capture::open_stack(dir, plan, bit_depth)?;
    let Capture::Stack(stack) = &capture else {
        unreachable!("open_stack opens a stack");
    };
    let (w, h) = (stack.width(), stack.height());
    let (_, _, dark) = read_grey(stack.frame_path(0))?;
    let (_, _, mut white) = read_grey(stack.frame_path(1))?;
    for (v, d) in white.iter_mut().zip(dark) {
        *v -= d;
    }
    let mut columns = vec![f32::NAN; w as usize * h as usize];
    // Only the strongest columns are kept: nothing of the candidates.
    let keep = |_: u32, _: &[HostCandidates]| Ok(());
    decode_capture(plan, &capture, options, &Progress::stderr(), keep, |row| {
        let y = row.row as usize * w as usize;
        columns[y..y + w as usize].copy_from_slice(&row.strongest);
        Ok(())
    })?;
    Ok(PoseData {
        width: w,
        height: h,
        white,
        columns,
    })
}

/// A pose folder read and its corners found, as [`observe_poses`] reports it; its `Display`
/// is the line `fsm calibrate target` prints (`pose1/: 54 corners, 87.3% of pixels decoded`),
/// made here beside the counts it reports.
#[derive(Clone, Copy, Debug)]
pub struct PoseSeen<'a> {
    /// The pose folder.
    pub dir: &'a Path,
    /// Corners found.
    pub corners: usize,
    /// Share of the pixels with a decoded column, 0 to 1.
    pub decoded: f64,
}

impl fmt::Display for PoseSeen<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: {} corners, {:.1}% of pixels decoded",
            self.dir.display(),
            self.corners,
            100.0 * self.decoded
        )
    }
}

/// Every pose of a calibration: the board's corners and the decoded columns per pose, and the
/// white frames (for the residual pictures), all of one image size.
pub struct ObservedPoses {
    /// Per pose, in the order given.
    pub observations: Vec<crate::PoseObservation>,
    /// Each pose's white − dark image, row-major.
    pub whites: Vec<Vec<f32>>,
    /// Image width, px.
    pub width: u32,
    /// Image height, px.
    pub height: u32,
}

/// Reads every pose folder of `dirs` ([`load_pose`]) and finds `board`'s corners in its white
/// frame. Refuses fewer folders than a calibration needs before any work, folders of another
/// image size than the first's, and folders where the corners are not found, naming the
/// folder. `seen` is told about each pose ([`PoseSeen`]).
pub fn observe_poses(
    dirs: &[std::path::PathBuf],
    plan: &ScanPlan,
    bit_depth: Option<u8>,
    options: &DecodeOptions,
    board: &crate::board::Checkerboard,
    mut seen: impl FnMut(&PoseSeen),
) -> Result<ObservedPoses> {
    if dirs.len() < crate::zhang::MIN_POSES {
        return Err(Error::Usage(format!(
            "{} pose folders given; at least {} are needed (tilted in different directions)",
            dirs.len(),
            crate::zhang::MIN_POSES
        )));
    }
    let mut observed = ObservedPoses {
        observations: Vec::with_capacity(dirs.len()),
        whites: Vec::with_capacity(dirs.len()),
        width: 0,
        height: 0,
    };
    for (i, dir) in dirs.iter().enumerate() {
        let pose = load_pose(dir, plan, bit_depth, options)?;
        if i == 0 {
            (observed.width, observed.height) = (pose.width, pose.height);
        } else if (pose.width, pose.height) != (observed.width, observed.height) {
            return Err(Error::Usage(format!(
                "{}: images are {}x{}, the first pose's are {}x{}",
                dir.display(),
                pose.width,
                pose.height,
                observed.width,
                observed.height
            )));
        }
        let (w, h) = (pose.width as usize, pose.height as usize);
        let corners = crate::corners::detect(&pose.white, w, h, board)
            .map_err(|e| Error::Usage(format!("{}: corners: {e}", dir.display())))?;
        let lit = pose.columns.iter().filter(|c| c.is_finite()).count();
        seen(&PoseSeen {
            dir,
            corners: corners.len(),
            decoded: lit as f64 / (w * h).max(1) as f64,
        });
        observed.observations.push(crate::PoseObservation {
            label: dir.display().to_string(),
            corners_px: corners,
            columns: crate::ColumnMap {
                width: w,
                height: h,
                columns: pose.columns,
            },
        });
        observed.whites.push(pose.white);
    }
    Ok(observed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn too_few_poses_are_refused_before_any_folder_is_read() {
        let board = crate::board::Checkerboard {
            inner_columns: 9,
            inner_rows: 6,
            square_mm: 20.0,
        };
        let dirs = ["no-such-pose-1", "no-such-pose-2"].map(std::path::PathBuf::from);
        let plan = ScanPlan::paper_bfsm();
        let options = DecodeOptions::default();
        let mut seen = 0;
        let e = observe_poses(&dirs, &plan, None, &options, &board, |_| seen += 1)
            .err()
            .expect("refused")
            .to_string();
        assert!(
            e.contains("2 pose folders") && e.contains("at least 3"),
            "{e}"
        );
        assert_eq!(seen, 0);
    }
}
