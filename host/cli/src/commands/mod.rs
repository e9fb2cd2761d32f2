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

use std::path::PathBuf;

use fsm_core::ScanPlan;
use fsm_io::capture::{BadRows, Capture};
use fsm_io::decode::DecodeOptions;
use fsm_io::{plan_file, Result};

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

/// What a bad record of a dump does.
#[derive(clap::Args, Debug)]
pub struct BadRowsArg {
    /// Decode a dump whose records fail their check (CRC, row index, a repeated row) or that
    /// ends early: the good rows are decoded, the bad or missing ones get no point (no_data)
    /// and are listed on stderr (and in summary.json). By default such a dump is refused
    /// with the error that names the record and its row.
    #[arg(long, requires = "dump")]
    pub skip_bad_rows: bool,
}

impl BadRowsArg {
    /// The policy.
    pub fn policy(&self) -> BadRows {
        if self.skip_bad_rows {
            BadRows::Skip
        } else {
            BadRows::Refuse
        }
    }
}

/// Tells what a decode skipped ([`BadRows::Skip`]), on stderr.
pub fn report_bad_rows(summary: &fsm_io::decode::DecodeSummary) {
    if let Some(skipped) = summary.skipped() {
        eprintln!("  {}", skipped.replace('\n', "\n  "));
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

impl CaptureSource {
    /// Opens and checks the capture against `plan` (before any work).
    pub fn open(
        &self,
        plan: impl Into<fsm_io::plan_file::MethodPlan>,
        bit_depth: &BitDepth,
        bad_rows: BadRows,
    ) -> Result<Capture> {
        match (&self.images, &self.dump) {
            (Some(dir), _) => Capture::open_stack(dir, plan, bit_depth.bit_depth),
            (None, Some(path)) => Capture::open_dump(path, plan, bit_depth.bit_depth, bad_rows),
            (None, None) => unreachable!("clap requires one source"),
        }
    }
}

/// Reads the plan file.
pub fn load_plan(path: &std::path::Path) -> Result<ScanPlan> {
    plan_file::read_plan(path)
}

/// The `--preset` names (`fsm plan`, `fsm simulate`).
pub fn preset_parser() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(fsm_io::plan_file::Preset::ALL.map(|(_, n)| n))
}

/// `WxH`, both at least `min`.
pub fn parse_size(s: &str, min: u32) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .split_once('x')
        .ok_or_else(|| format!("`{s}`: expected WxH, e.g. 1280x1024"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|&v| v >= min)
            .ok_or_else(|| format!("`{s}`: `{v}` is not a size of {min} or more pixels"))
    };
    Ok((parse(w)?, parse(h)?))
}

/// `X,Y` pixel coordinates.
pub fn parse_pixel(s: &str) -> std::result::Result<(u32, u32), String> {
    let (x, y) = s
        .split_once(',')
        .ok_or_else(|| format!("`{s}`: expected X,Y (e.g. 640,480)"))?;
    let parse = |v: &str, name: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{s}`: {name} = `{v}` is not a pixel coordinate"))
    };
    Ok((parse(x, "X")?, parse(y, "Y")?))
}
