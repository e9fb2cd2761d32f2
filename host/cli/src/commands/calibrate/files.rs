//! `fsm calibrate import|export`: OpenCV FileStorage calibrations of other tools.

use std::path::PathBuf;

use fsm_geometry::opencv::{self, ImportOptions, LengthUnit, Tool};
use fsm_geometry::Calibration;
use fsm_io::image_files::parse_size;
use fsm_io::Result;

use crate::commands::{named, OutFile};

const IMPORT_HELP: &str = "\
The file is YAML or XML, recognised from its text. Its R, T (camera to projector, as all
three tools have them: calibration/README.md) are taken as they are, T in --unit. The files
hold no measurement volume and not always the image sizes: give them as options (an option
wins over a size in the file, with a warning).

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

/// The other tool's file (`fsm calibrate import`, `export`): its key set and its unit.
#[derive(clap::Args, Debug)]
struct ToolFile {
    /// The tool whose file it is (its key set): slstudio (Kc kc Kp kp Rp Tp, XML;
    /// X_p = Rp·X_c + Tp, mm), scan3d-capture (Moreno & Taubin: cam_K cam_kc proj_K proj_kc R T,
    /// YAML; mm), procam (kamino410's procam-calibration: cam_int cam_dist proj_int proj_dist
    /// roration translation, XML; in the unit of its chessboard squares).
    #[arg(long, value_parser = named(Tool::ALL.map(|t| (t, t.name()))))]
    format: Tool,
    /// Unit of the file's translation.
    #[arg(long, default_value = "mm", value_parser = named(LengthUnit::ALL.map(|u| (u, u.name()))))]
    unit: LengthUnit,
}

/// Read another tool's OpenCV FileStorage calibration and write our calibration file.
#[derive(clap::Args, Debug)]
#[command(after_help = IMPORT_HELP)]
pub struct ImportArgs {
    #[command(flatten)]
    tool: ToolFile,
    /// The tool's calibration file.
    #[arg(long = "in", value_name = "FILE")]
    input: PathBuf,
    #[command(flatten)]
    output: OutFile,
    /// Camera image size, pixels (required unless the file has it: SLStudio's
    /// frameWidth/frameHeight, procam's img_shape).
    #[arg(long, value_name = "WxH", value_parser = |s: &str| parse_size(s, 1))]
    camera_size: Option<(u32, u32)>,
    /// Projector size, columns x rows (required unless the file has it: SLStudio's
    /// screenResX/screenResY). The columns are the plan's projector columns.
    #[arg(long, value_name = "COLSxROWS", value_parser = |s: &str| parse_size(s, 1))]
    projector_size: Option<(u32, u32)>,
    /// Nearest depth of the measurement volume, mm along the camera's z axis.
    #[arg(long, value_name = "MM")]
    near_mm: Option<f64>,
    /// Farthest depth of the measurement volume, mm.
    #[arg(long, value_name = "MM")]
    far_mm: Option<f64>,
}

/// Write our calibration file as another tool's OpenCV FileStorage file.
#[derive(clap::Args, Debug)]
#[command(after_help = EXPORT_HELP)]
pub struct ExportArgs {
    /// Our calibration file.
    #[arg(long, value_name = "FILE")]
    calibration: PathBuf,
    #[command(flatten)]
    tool: ToolFile,
    #[command(flatten)]
    output: OutFile,
}

/// Runs `fsm calibrate import`.
pub fn import(args: ImportArgs) -> Result<()> {
    let why = "the input file: write our calibration to another file";
    let out = args.output.check_not(&args.input, why)?;
    let options = ImportOptions {
        camera_size: args.camera_size,
        projector_size: args.projector_size,
        near_mm: args.near_mm,
        far_mm: args.far_mm,
        unit: args.tool.unit,
    };
    let imported = opencv::read(&args.input, args.tool.format, &options)?;
    imported.calibration.write(out)?;
    eprintln!("{}", imported.report(args.tool.format, &args.input, out));
    Ok(())
}

/// Runs `fsm calibrate export`.
pub fn export(args: ExportArgs) -> Result<()> {
    let why = "the calibration being exported: write to another file";
    let out = args.output.check_not(&args.calibration, why)?;
    let calibration = Calibration::read(&args.calibration)?;
    let (tool, unit) = (args.tool.format, args.tool.unit);
    opencv::write(&calibration, tool, out, unit)?;
    eprintln!(
        "{}",
        opencv::export_report(tool, unit, out, &args.calibration)
    );
    Ok(())
}
