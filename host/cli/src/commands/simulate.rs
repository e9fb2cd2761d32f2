//! `fsm simulate`: the captures a scanner would record of a simulated scene, with the plan,
//! the calibration and the ground truth, ready for `fsm decode` and `fsm scan`.

use std::path::{Path, PathBuf};

use fsm_core::ScanPlan;
use fsm_host::image_files::{write_png_gray16, write_png_gray8, write_tiff_f32};
use fsm_host::outputs::{write_file, StagedDir};
use fsm_host::plan_file::{write_plan, Preset};
use fsm_host::{Error, Result};
use fsm_sim::scene::presets::NAMES;
use fsm_sim::{Capture, LightTransport, Scene, Sensor, System, TransportSettings};

/// Simulate a scan: the camera's captures of a scene under a plan's patterns.
///
/// The bench scanner (SPEC §5; baseline 200 mm, standoff 500 mm, 768-column projector with
/// a 0.7-column defocus blur, 12-bit camera) looks at a preset scene; light reaches the
/// camera directly and through mirrors and diffuse interreflection, and the sensor adds shot
/// and read noise. Scenes: plane, plane_mirror, plane_mirror_covered, vgroove, sphere_mirror.
///
/// Writes into the output folder:
///   plan.toml            the plan the patterns follow
///   calibration.toml     the simulated scanner's calibration
///   scan.dump            the captures as a row dump (or images/0000.png… with --images)
///   truth/depth.tiff     ground-truth depth, mm (NaN: background)
///   truth/column.tiff    ground-truth direct column (SPEC §7; NaN where not lit directly)
///   truth/interreflection.png  pixels whose indirect light exceeds 20% of the direct
///
/// Examples:
///   fsm simulate --scene plane_mirror --preset paper-bfsm --out sim/
///   fsm scan --plan sim/plan.toml --calibration sim/calibration.toml --dump sim/scan.dump --out scan/
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Scene preset.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(NAMES))]
    scene: String,
    /// Scan-plan file.
    #[arg(
        long,
        value_name = "FILE",
        conflicts_with = "preset",
        required_unless_present = "preset"
    )]
    plan: Option<PathBuf>,
    /// A preset plan instead of a file: paper-bfsm, paper-efsm-1 or paper-efsm-2.
    #[arg(long, value_parser = clap::builder::PossibleValuesParser::new(Preset::ALL.map(|(_, n)| n)))]
    preset: Option<String>,
    /// Output folder (created; must not exist or be empty, unless --force).
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Camera size WxH (same field of view; the footprint shrinks as it grows).
    #[arg(long, value_name = "WxH", default_value = "320x240", value_parser = parse_size)]
    camera: (u32, u32),
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Write a 16-bit PNG per frame under images/ instead of a row dump.
    #[arg(long)]
    images: bool,
    /// Replace the output folder if it exists and is not empty.
    #[arg(long)]
    force: bool,
}

/// `WxH`.
pub fn parse_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| format!("`{s}`: expected WxH, e.g. 320x240"))?;
    let parse = |v: &str| {
        v.parse::<u32>()
            .ok()
            .filter(|&v| v >= 8)
            .ok_or_else(|| format!("`{s}`: `{v}` is not a size of 8 or more"))
    };
    Ok((parse(w)?, parse(h)?))
}

fn sim_error(e: impl std::fmt::Display) -> Error {
    Error::Usage(format!("simulation: {e}"))
}

pub fn run(args: Args) -> Result<()> {
    let plan = match (&args.plan, &args.preset) {
        (Some(path), _) => super::load_plan(path)?,
        (None, Some(name)) => Preset::from_name(name)
            .expect("clap checked the name")
            .plan(),
        (None, None) => unreachable!("clap requires a plan or a preset"),
    };
    let scene = Scene::by_name(&args.scene).map_err(sim_error)?;
    let system = System::bench_with_camera(args.camera.0, args.camera.1);
    let staged = StagedDir::create(&args.out, args.force)?;
    let transport = LightTransport::compute(&scene, &system, &TransportSettings::default())
        .map_err(sim_error)?;
    let capture = Capture::new(
        std::sync::Arc::new(transport),
        &plan,
        &system,
        Sensor::default(),
        args.seed,
    )
    .map_err(sim_error)?;
    write_plan(&plan, &staged.file("plan.toml"))?;
    system
        .calibration
        .write(&staged.file("calibration.toml"))
        .map_err(|e| Error::Usage(e.to_string()))?;
    if args.images {
        write_stack(&capture, &plan, &staged.file("images"))?;
    } else {
        let path = staged.file("scan.dump");
        capture.write_row_dump_file(&path).map_err(sim_error)?;
    }
    write_truth(&capture, &staged.file("truth"))?;
    let out = staged.commit()?;
    eprintln!(
        "simulated {} ({}x{}, {} frames, seed {}) -> {}",
        args.scene,
        capture.width(),
        capture.height(),
        capture.frame_count(),
        args.seed,
        out.display()
    );
    Ok(())
}

/// One 16-bit PNG per frame, numbered in sequence order like the patterns.
fn write_stack(capture: &Capture, plan: &ScanPlan, dir: &Path) -> Result<()> {
    std::fs::create_dir(dir).map_err(|e| Error::io(dir, e))?;
    let (w, h) = (capture.width() as usize, capture.height() as usize);
    let frames = plan.sequence_len();
    let mut images = vec![0u16; frames * w * h];
    for y in 0..h {
        let row = capture.row(y as u32).map_err(sim_error)?;
        for i in 0..frames {
            images[(i * h + y) * w..(i * h + y + 1) * w].copy_from_slice(&row[i * w..(i + 1) * w]);
        }
    }
    for i in 0..frames {
        let path = dir.join(format!("{i:04}.png"));
        let mut bytes = Vec::new();
        write_png_gray16(
            &mut bytes,
            w as u32,
            h as u32,
            &images[i * w * h..(i + 1) * w * h],
        )
        .map_err(|e| Error::Encode {
            path: path.clone(),
            message: e.0,
        })?;
        write_file(&path, &bytes)?;
    }
    Ok(())
}

/// The ground truth as images.
fn write_truth(capture: &Capture, dir: &Path) -> Result<()> {
    std::fs::create_dir(dir).map_err(|e| Error::io(dir, e))?;
    let truth = capture.ground_truth();
    let (w, h) = (capture.width(), capture.height());
    let mut depth = vec![f32::NAN; (w * h) as usize];
    let mut column = vec![f32::NAN; (w * h) as usize];
    let mut interreflection = vec![0u8; (w * h) as usize];
    for (x, y, p) in truth.iter() {
        let i = (y * w + x) as usize;
        depth[i] = p.point_mm[2] as f32;
        column[i] = p.direct_column as f32;
        interreflection[i] = if p.is_interreflection() { 255 } else { 0 };
    }
    for (name, values) in [("depth.tiff", &depth), ("column.tiff", &column)] {
        let path = dir.join(name);
        let mut bytes = Vec::new();
        write_tiff_f32(&mut std::io::Cursor::new(&mut bytes), w, h, values).map_err(|e| {
            Error::Encode {
                path: path.clone(),
                message: e.0,
            }
        })?;
        write_file(&path, &bytes)?;
    }
    let path = dir.join("interreflection.png");
    let mut bytes = Vec::new();
    write_png_gray8(&mut bytes, w, h, &interreflection).map_err(|e| Error::Encode {
        path: path.clone(),
        message: e.0,
    })?;
    write_file(&path, &bytes)
}
