//! `fsm calibrate import|export`: OpenCV FileStorage calibrations of other tools.

use std::path::{Path, PathBuf};

use fsm_geometry::opencv::{self, ImportOptions, LengthUnit, Syntax, Tool};
use fsm_geometry::Calibration;
use fsm_io::{Error, Result};

use crate::commands::{named, size};

const IMPORT_HELP: &str = "\
The file is YAML or XML, recognised from its text. All three tools calibrate with OpenCV's
stereoCalibrate, camera first: their R, T map camera coordinates to projector coordinates
(X_p = R·X_c + T), which is our pose as it is. T is in the unit the tool's user gave the
checkerboard squares in (--unit, default mm). The files hold no measurement volume and not
always the image sizes: give them as options (an option wins over a size in the file, with a
warning). See calibration/README.md.

Examples:
  fsm calibrate import --format slstudio --in calibration.xml --near-mm 350 --far-mm 700 \\
      --out cal.toml
  fsm calibrate import --format scan3d-capture --in calibration.yml --camera-size 1280x1024 \\
      --projector-size 768x1024 --near-mm 350 --far-mm 700 --out cal.toml
  fsm calibrate import --format procam --in calibration_result.xml --projector-size 1280x800 \\
      --near-mm 300 --far-mm 900 --unit mm --out cal.toml";

const EXPORT_HELP: &str = "\
The syntax follows the name: .yml/.yaml for YAML, .xml for XML (SLStudio reads only .xml).
The file gets the tool's six keys (R, T camera to projector, as the tool has them) and what
the tool writes besides: SLStudio's frameWidth/frameHeight/screenResX/screenResY,
scan3d-capture's E and F, procam's img_shape. The sizes and the measurement volume that the
format cannot carry are in a comment at the top.

Examples:
  fsm calibrate export --calibration cal.toml --format slstudio --out calibration.xml
  fsm calibrate export --calibration cal.toml --format scan3d-capture --out calibration.yml";

/// Read another tool's OpenCV FileStorage calibration and write our calibration file.
#[derive(clap::Args, Debug)]
#[command(after_help = IMPORT_HELP)]
pub struct ImportArgs {
    /// Which tool wrote the file (its key set): slstudio (Kc kc Kp kp Rp Tp, XML;
    /// X_p = Rp·X_c + Tp, mm), scan3d-capture (Moreno & Taubin: cam_K cam_kc proj_K proj_kc R T,
    /// YAML; mm), procam (kamino410's procam-calibration: cam_int cam_dist proj_int proj_dist
    /// roration translation, XML; in the unit of its chessboard squares).
    #[arg(long, value_parser = named(Tool::ALL.map(|t| (t, t.name()))))]
    format: Tool,
    /// The tool's calibration file.
    #[arg(long = "in", value_name = "FILE")]
    input: PathBuf,
    /// Our calibration file to write (TOML).
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Replace the output file if it exists.
    #[arg(long)]
    force: bool,
    /// Camera image size, pixels (required unless the file has it: SLStudio's
    /// frameWidth/frameHeight, procam's img_shape).
    #[arg(long, value_name = "WxH", value_parser = size::<1>)]
    camera_size: Option<(u32, u32)>,
    /// Projector size, columns x rows (required unless the file has it: SLStudio's
    /// screenResX/screenResY). The columns are the plan's projector columns.
    #[arg(long, value_name = "COLSxROWS", value_parser = size::<1>)]
    projector_size: Option<(u32, u32)>,
    /// Nearest depth of the measurement volume, mm along the camera's z axis.
    #[arg(long, value_name = "MM")]
    near_mm: Option<f64>,
    /// Farthest depth of the measurement volume, mm.
    #[arg(long, value_name = "MM")]
    far_mm: Option<f64>,
    /// Unit of the file's translation.
    #[arg(long, default_value = "mm", value_parser = named(LengthUnit::ALL.map(|u| (u, u.name()))))]
    unit: LengthUnit,
}

/// Write our calibration file as another tool's OpenCV FileStorage file.
#[derive(clap::Args, Debug)]
#[command(after_help = EXPORT_HELP)]
pub struct ExportArgs {
    /// Our calibration file.
    #[arg(long, value_name = "FILE")]
    calibration: PathBuf,
    /// Which tool's key set to write.
    #[arg(long, value_parser = named(Tool::ALL.map(|t| (t, t.name()))))]
    format: Tool,
    /// The file to write (.yml, .yaml or .xml).
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Replace the output file if it exists.
    #[arg(long)]
    force: bool,
    /// Unit of the written translation.
    #[arg(long, default_value = "mm", value_parser = named(LengthUnit::ALL.map(|u| (u, u.name()))))]
    unit: LengthUnit,
}

/// Refuses to write `out` over `input`, whatever --force says: `--out OUT is {why}`.
fn refuse_same_file(input: &Path, out: &Path, why: &str) -> Result<()> {
    match (input.canonicalize(), out.canonicalize()) {
        (Ok(a), Ok(b)) if a == b => Err(Error::Usage(format!("--out {} is {why}", out.display()))),
        _ => Ok(()),
    }
}

/// Runs `fsm calibrate import`.
pub fn import(args: ImportArgs) -> Result<()> {
    let why = "the input file: write our calibration to another file";
    refuse_same_file(&args.input, &args.out, why)?;
    fsm_io::outputs::check_file_target(&args.out, args.force)?;
    let options = ImportOptions {
        camera_size: args.camera_size,
        projector_size: args.projector_size,
        near_mm: args.near_mm,
        far_mm: args.far_mm,
        unit: args.unit,
    };
    let imported = opencv::read(&args.input, args.format, &options)?;
    imported.calibration.write(&args.out)?;
    for note in &imported.notes {
        eprintln!("{note}");
    }
    eprintln!(
        "wrote {}: {} calibration from {}; {}",
        args.out.display(),
        args.format,
        args.input.display(),
        imported.calibration.summary()
    );
    Ok(())
}

/// Runs `fsm calibrate export`.
pub fn export(args: ExportArgs) -> Result<()> {
    let why = "the calibration being exported: write to another file";
    refuse_same_file(&args.calibration, &args.out, why)?;
    fsm_io::outputs::check_file_target(&args.out, args.force)?;
    let calibration = Calibration::read(&args.calibration)?;
    let tool = args.format;
    opencv::write(&calibration, tool, &args.out, args.unit)?;
    if tool == Tool::SlStudio && Syntax::of_path(&args.out) == Some(Syntax::Yaml) {
        eprintln!("note: SLStudio loads only .xml calibration files");
    }
    eprintln!(
        "wrote {}: {} calibration (translation in {}) from {}",
        args.out.display(),
        tool,
        args.unit.name(),
        args.calibration.display()
    );
    Ok(())
}
