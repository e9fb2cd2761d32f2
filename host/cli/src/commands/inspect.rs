//! `fsm inspect`: pictures of what the decoder sees at a pixel or along a row.

use std::path::PathBuf;

use fsm_core::Group;
use fsm_io::capture::BadRows;
use fsm_io::inspect;
use fsm_io::Result;

use super::{BitDepth, CaptureSource};

/// Plot what the decoder sees.
///
///   --pixel X,Y  the pixel's fringe samples against frequency, and against projector
///                column what the decoder reads its lights from, the lights marked (paper
///                Figs. 3, 8): the light of each column (the cosine search, the default) or
///                the spectrum magnitude (CLEAN, local maxima). EFSM adds the mask samples of
///                each block.
///   --row Y      the same for every pixel of camera row Y as an image: pixel across, column
///                down (paper Fig. 4e). Direct light draws one line; light reflected from
///                elsewhere draws a second, separate line.
///
/// Examples:
///   fsm inspect --plan plan.toml --images captures/ --pixel 640,480 --out pixel.png
///   fsm inspect --plan plan.toml --dump scan.dump --row 480 --out row.png
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Scan-plan file the capture was made with.
    #[arg(long, value_name = "FILE")]
    plan: PathBuf,
    #[command(flatten)]
    source: CaptureSource,
    #[command(flatten)]
    bit_depth: BitDepth,
    /// Plot one pixel (camera coordinates, 0-based).
    #[arg(long, value_name = "X,Y", value_parser = super::parse_pixel, conflicts_with = "row", required_unless_present = "row")]
    pixel: Option<(u32, u32)>,
    /// Map one camera row (0-based).
    #[arg(long, value_name = "Y")]
    row: Option<u32>,
    /// EFSM pattern group shown by --row (1 or 2).
    #[arg(long, value_name = "G", default_value_t = 1, value_parser = clap::value_parser!(u8).range(1..=2))]
    group: u8,
    /// Output picture (PNG).
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Replace the output file if it exists.
    #[arg(long)]
    force: bool,
}

pub fn run(args: Args) -> Result<()> {
    fsm_io::outputs::check_file_target(&args.out, args.force)?;
    let plan = super::load_plan(&args.plan)?;
    let capture = args.source.open(&plan, &args.bit_depth, BadRows::Refuse)?;
    if let Some((x, y)) = args.pixel {
        let view = inspect::inspect_pixel(&plan, &capture, x, y, &args.out)?;
        eprintln!("wrote {}", args.out.display());
        if view.candidates.candidates.is_empty() {
            sayln!("pixel ({x}, {y}): no candidate");
        }
        for c in &view.candidates.candidates {
            sayln!(
                "pixel ({x}, {y}): column {:.3}, amplitude {:.1} DN, group {}, block {}",
                c.column,
                c.amplitude,
                c.group.number(),
                c.block
            );
        }
    } else if let Some(y) = args.row {
        let group = if args.group == 2 {
            Group::Two
        } else {
            Group::One
        };
        inspect::inspect_row(&plan, &capture, y, group, &args.out)?;
        eprintln!("wrote {}", args.out.display());
    }
    Ok(())
}
