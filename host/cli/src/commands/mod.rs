//! One module per subcommand, plus the argument groups they share.

pub mod calibrate;
pub mod camera;
pub mod convert;
pub mod decode;
pub mod demo;
pub mod inspect;
pub mod patterns;
pub mod plan;
pub mod scan;
pub mod simulate;

use std::path::{Path, PathBuf};

use clap::builder::{PossibleValuesParser, TypedValueParser};
use fsm_io::capture::{BadRows, Capture};
use fsm_io::decode::DecodeOptions;
use fsm_io::image_files::parse_size;
use fsm_io::outputs::{check_file_target, check_file_target_not, StagedDir};
use fsm_io::plan_file::MethodPlan;
use fsm_io::Result;
use fsm_sim::System;

/// The plan file of a command that takes any method (`fsm patterns`, `convert`, `decode`,
/// `inspect`, `scan`).
#[derive(clap::Args, Debug)]
pub struct PlanFile {
    /// Plan file, of any method (`fsm plan`); for a capture, the plan it was made with.
    #[arg(long, value_name = "FILE")]
    pub plan: PathBuf,
}

impl PlanFile {
    /// The plan, read and checked.
    pub fn read(&self) -> Result<MethodPlan> {
        fsm_io::plan_file::read_method_plan(&self.plan)
    }
}

/// Where the captured data is: exactly one of a stack of images or a row dump.
#[derive(clap::Args, Debug)]
#[group(required = true, multiple = false)]
pub struct CaptureSource {
    /// Folder of captured images, one per pattern, numbered in sequence order like the
    /// patterns (0000.png, 0001.png, …; PNG or TIFF, 8- or 16-bit grey).
    #[arg(long, value_name = "DIR")]
    pub images: Option<PathBuf>,
    /// Row-dump file written by the camera (or by `fsm convert`).
    #[arg(long, value_name = "FILE")]
    pub dump: Option<PathBuf>,
}

impl CaptureSource {
    /// Opens and checks the capture against `plan` (before any work).
    pub fn open(&self, plan: MethodPlan, bits: &BitDepth, bad_rows: BadRows) -> Result<Capture> {
        match (&self.images, &self.dump) {
            (Some(dir), _) => Capture::open_stack(dir, plan, bits.bit_depth),
            (None, Some(path)) => Capture::open_dump(path, plan, bits.bit_depth, bad_rows),
            (None, None) => unreachable!("clap requires one source"),
        }
    }
}

/// A capture to decode (`fsm decode`, `fsm scan`): where it is, the sensor's bit depth, and
/// what a bad record of a dump does.
#[derive(clap::Args, Debug)]
pub struct CaptureArgs {
    #[command(flatten)]
    pub source: CaptureSource,
    #[command(flatten)]
    pub bit_depth: BitDepth,
    /// Decode a dump whose records fail their check (CRC, row index, a repeated row) or that
    /// ends early: the bad or missing rows get no point (no_data) and are listed on stderr and
    /// in summary.json. By default such a dump is refused, the error naming the record and row.
    #[arg(long, requires = "dump")]
    pub skip_bad_rows: bool,
}

impl CaptureArgs {
    /// Opens and checks the capture against `plan` (before any work).
    pub fn open(&self, plan: MethodPlan) -> Result<Capture> {
        let bad_rows = if self.skip_bad_rows {
            BadRows::Skip
        } else {
            BadRows::Refuse
        };
        self.source.open(plan, &self.bit_depth, bad_rows)
    }
}

/// How much of a capture is held in memory (`fsm convert`, and every decoding command).
#[derive(clap::Args, Debug)]
pub struct MemoryBudget {
    /// Most captured samples held in memory at once, MiB: a stack larger than this is read
    /// in bands of rows (re-reading the images for each band).
    #[arg(long, value_name = "MiB", default_value_t = 2048)]
    pub memory_budget: u64,
}

impl MemoryBudget {
    /// The budget in bytes.
    pub fn bytes(&self) -> u64 {
        self.memory_budget.saturating_mul(1 << 20)
    }
}

/// How a capture is decoded: threads and memory (`fsm decode`, `fsm scan`, `fsm calibrate
/// target`).
#[derive(clap::Args, Debug)]
pub struct DecodeArgs {
    /// Decoding threads (default: one per core).
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub threads: usize,
    #[command(flatten)]
    pub memory: MemoryBudget,
}

impl DecodeArgs {
    /// The decoding pipeline's options.
    pub fn options(&self) -> DecodeOptions {
        DecodeOptions {
            memory_budget_bytes: self.memory.bytes(),
            threads: self.threads,
        }
    }
}

/// Sensor bit depth option.
#[derive(clap::Args, Debug)]
pub struct BitDepth {
    /// Sensor bit depth, when it is less than the image container's: e.g. 10 or 12 for a
    /// 10/12-bit camera writing 16-bit images (values must be right-aligned). Codes at
    /// 2^bits − 1 count as saturated. Default: the container's 8 or 16; a dump's header.
    #[arg(long, value_name = "BITS", value_parser = clap::value_parser!(u8).range(1..=16))]
    pub bit_depth: Option<u8>,
}

/// An output folder, written whole or not at all (`fsm patterns`, `decode`, `scan`,
/// `simulate`).
#[derive(clap::Args, Debug)]
pub struct OutDir {
    /// Output folder (created; must not exist or be empty, unless --force).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Replace the output folder if it exists and is not empty.
    #[arg(long)]
    pub force: bool,
}

impl OutDir {
    /// The folder staged under a temporary name (refused if it is in the way).
    pub fn stage(&self) -> Result<StagedDir> {
        StagedDir::create(&self.out, self.force)
    }
}

/// A single output file, written whole or not at all (`fsm convert`, `inspect`, `calibrate
/// target|import|export`).
#[derive(clap::Args, Debug)]
pub struct OutFile {
    /// Output file (written whole or not at all).
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Replace the output file if it exists.
    #[arg(long)]
    pub force: bool,
}

impl OutFile {
    /// The file's path, once checked before any work (`fsm_io::outputs::check_file_target`).
    pub fn check(&self) -> Result<&Path> {
        check_file_target(&self.out, self.force)?;
        Ok(&self.out)
    }

    /// [`OutFile::check`], and never `input`, whatever --force says: `--out OUT is {why}`
    /// (`fsm_io::outputs::check_file_target_not`).
    pub fn check_not(&self, input: &Path, why: &str) -> Result<&Path> {
        check_file_target_not(&self.out, input, self.force, why)?;
        Ok(&self.out)
    }
}

/// The simulated bench scanner (`fsm simulate`, `fsm demo`).
#[derive(clap::Args, Debug)]
pub struct BenchArgs {
    /// Camera size WxH (same field of view; the footprint shrinks as it grows).
    #[arg(long, value_name = "WxH", default_value = "320x240", value_parser = |s: &str| parse_size(s, 8))]
    pub camera: (u32, u32),
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

impl BenchArgs {
    /// The bench with this camera.
    pub fn system(&self) -> System {
        System::bench_with_camera(self.camera.0, self.camera.1)
    }
}

/// A value parser over one of the libraries' name tables (`Preset::ALL`, `MethodKind::ALL`,
/// …): the names are the possible values, and the value is the library's.
pub fn named<T, const N: usize>(table: [(T, &'static str); N]) -> impl TypedValueParser<Value = T>
where
    T: Copy + Send + Sync + 'static,
{
    PossibleValuesParser::new(table.map(|(_, name)| name)).map(move |name| {
        table
            .into_iter()
            .find(|(_, n)| *n == name)
            .expect("listed")
            .0
    })
}
