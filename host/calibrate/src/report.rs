//! The calibration report as a person reads it: the text table `fsm calibrate target` prints
//! and each pose's residual picture; and the files a calibration from pose folders writes
//! ([`TargetOutputs`]).

use std::path::Path;

use fsm_geometry::Calibration;
use fsm_io::outputs::write_file;

use crate::calibrate::{CalibrationReport, Parameter, PoseReport};
use crate::pose_folder::ObservedPoses;

impl CalibrationReport {
    /// The report as the text table `fsm calibrate target` prints: RMS per pose and overall,
    /// each parameter with its standard deviation, the baseline and the assumptions made.
    pub fn table(&self) -> String {
        let report = self;
        let mut out = String::new();
        out.push_str(
        "pose                          camera RMS px   projector RMS col   corners (with column)   dense RMS col (samples)\n",
    );
        let dense = |rms: Option<f64>| rms.map_or("-".to_string(), |r| format!("{r:.4}"));
        for p in &report.poses {
            out += &format!(
                "{:<30} {:>12.4} {:>19.4}   {:>9} ({:>2})           {:>7} ({})\n",
                p.label,
                p.camera_rms_px,
                p.projector_rms_columns,
                p.corners,
                p.corners_with_column,
                dense(p.dense_rms_columns),
                p.dense_samples
            );
        }
        out += &format!(
            "{:<30} {:>12.4} {:>19.4}                           {:>7}\n",
            "all",
            report.camera_rms_px,
            report.projector_rms_columns,
            dense(report.dense_rms_columns)
        );
        let show = |name: &str, params: &[Parameter]| {
            let list: Vec<String> = params
                .iter()
                .map(|p| match p.std_dev {
                    Some(s) => format!("{} {:.6} ± {:.2e}", p.name, p.value, s),
                    None => format!("{} {:.6} (fixed)", p.name, p.value),
                })
                .collect();
            format!("{name}: {}\n", list.join(", "))
        };
        out += &show("camera", &report.camera);
        out += &show("projector", &report.projector);
        out += &format!("baseline {:.3} mm\n", report.baseline_mm);
        for a in &report.assumptions {
            out += &format!("assumed: {a}\n");
        }
        out
    }
}

/// The white frame in grey, each corner's camera residual as a red line (× 200) and its
/// projector residual as a dot coloured by sign and size (full colour at 0.1 column).
pub fn residual_picture(pose: &PoseReport, white: &[f32], w: usize, h: usize) -> Vec<u8> {
    let max = white.iter().copied().fold(0.0f32, f32::max).max(1.0);
    let mut rgb: Vec<u8> = white
        .iter()
        .flat_map(|&v| {
            let g = (60.0 + 120.0 * (v / max).clamp(0.0, 1.0)) as u8;
            [g, g, g]
        })
        .collect();
    let put = |x: i64, y: i64, c: [u8; 3], rgb: &mut Vec<u8>| {
        if x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h {
            let i = 3 * (y as usize * w + x as usize);
            rgb[i..i + 3].copy_from_slice(&c);
        }
    };
    for ((c, r), pr) in pose
        .corners_px
        .iter()
        .zip(&pose.camera_residuals_px)
        .zip(&pose.projector_residuals_columns)
    {
        let (x0, y0) = (c[0], c[1]);
        let (x1, y1) = (x0 + 200.0 * r[0], y0 + 200.0 * r[1]);
        let steps = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
        for s in 0..=steps {
            let t = s as f64 / steps as f64;
            put(
                (x0 + t * (x1 - x0)).round() as i64,
                (y0 + t * (y1 - y0)).round() as i64,
                [230, 40, 40],
                &mut rgb,
            );
        }
        let colour = match pr {
            None => [0, 0, 0],
            Some(v) => {
                let a = (v.abs() / 0.1).clamp(0.15, 1.0);
                if *v < 0.0 {
                    [0, (120.0 * a) as u8, (255.0 * a) as u8]
                } else {
                    [(255.0 * a) as u8, (220.0 * a) as u8, 0]
                }
            }
        };
        for dy in -1..=1 {
            for dx in -1..=1 {
                put(
                    x0.round() as i64 + dx,
                    y0.round() as i64 + dy,
                    colour,
                    &mut rgb,
                );
            }
        }
    }
    rgb
}

/// Writes one residual picture per pose ([`residual_picture`]) into `dir` (created if
/// missing): `pose00.png`, `pose01.png`, …, each whole or not at all.
pub fn write_residual_pictures(
    dir: &Path,
    report: &CalibrationReport,
    whites: &[Vec<f32>],
    (w, h): (u32, u32),
) -> fsm_io::Result<()> {
    use fsm_io::Error;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    for (i, (pose, white)) in report.poses.iter().zip(whites).enumerate() {
        let path = dir.join(format!("pose{i:02}.png"));
        let rgb = residual_picture(pose, white, w as usize, h as usize);
        let mut bytes = Vec::new();
        fsm_io::image_files::write_png_rgb8(&mut bytes, w, h, &rgb)
            .map_err(|e| Error::Usage(format!("{}: {}", path.display(), e.0)))?;
        fsm_io::outputs::write_file(&path, &bytes)?;
    }
    Ok(())
}

/// The files `fsm calibrate target` writes once it has calibrated: the calibration file, the
/// JSON report and the residual pictures (both optional), in that order, each whole or not at
/// all. Here rather than in the command: which files a calibration makes, and the white frames
/// the pictures are drawn on ([`ObservedPoses`]), are the calibration's.
#[derive(Clone, Copy, Debug)]
pub struct TargetOutputs<'a> {
    /// The calibration file (TOML).
    pub calibration: &'a Path,
    /// The report as JSON ([`CalibrationReport::to_json`]).
    pub report: Option<&'a Path>,
    /// The folder of the residual pictures ([`write_residual_pictures`]; created if missing).
    pub residuals: Option<&'a Path>,
}

impl TargetOutputs<'_> {
    /// Writes `calibration` and its `report` from `poses`; `wrote` gets a line as each output
    /// is written (`wrote cal.toml`, `wrote 6 residual pictures to residuals/`).
    pub fn write(
        &self,
        calibration: &Calibration,
        report: &CalibrationReport,
        poses: &ObservedPoses,
        mut wrote: impl FnMut(String),
    ) -> fsm_io::Result<()> {
        write_file(self.calibration, calibration.to_toml().as_bytes())?;
        wrote(format!("wrote {}", self.calibration.display()));
        if let Some(path) = self.report {
            write_file(path, report.to_json().as_bytes())?;
            wrote(format!("wrote {}", path.display()));
        }
        if let Some(dir) = self.residuals {
            write_residual_pictures(dir, report, &poses.whites, (poses.width, poses.height))?;
            let count = report.poses.len();
            wrote(format!(
                "wrote {count} residual pictures to {}",
                dir.display()
            ));
        }
        Ok(())
    }
}
