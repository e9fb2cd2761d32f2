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
use fsm_host::capture::Capture;
use fsm_host::{plan_file, Result};

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
    pub fn open(&self, plan: &ScanPlan, bit_depth: &BitDepth) -> Result<Capture> {
        match (&self.images, &self.dump) {
            (Some(dir), _) => Capture::open_stack(dir, plan, bit_depth.bit_depth),
            (None, Some(path)) => Capture::open_dump(path, plan, bit_depth.bit_depth),
            (None, None) => unreachable!("clap requires one source"),
        }
    }
}

/// Reads the plan file.
pub fn load_plan(path: &std::path::Path) -> Result<ScanPlan> {
    plan_file::read_plan(path)
}

/// Memory budget in MiB, as bytes.
pub fn mebibytes(mib: u64) -> u64 {
    mib.saturating_mul(1 << 20)
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
