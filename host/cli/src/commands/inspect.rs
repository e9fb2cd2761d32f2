//! `fsm inspect`: pictures of what the decoder sees at a pixel or along a row.

use fsm_core::Group;
use fsm_io::capture::BadRows;
use fsm_io::inspect;
use fsm_io::Result;

use super::{BitDepth, CaptureSource, OutFile, PlanFile};

/// Plot what the decoder sees, as a PNG picture.
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
/// For the other methods (phase shift, Micro Phase Shifting, Code Ensemble, line scanning)
/// --pixel draws the pixel's samples grouped as the method's decoder reads them (fringes
/// by phase offset, code bits with their threshold or inverse, line scanning's temporal
/// profile by lit column) and --row the candidates of every pixel against projector column
/// (line scanning: over the samples, as for FSM).
///
/// Examples:
///   fsm inspect --plan plan.toml --images captures/ --pixel 640,480 --out pixel.png
///   fsm inspect --plan plan.toml --dump scan.dump --row 480 --out row.png
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    plan: PlanFile,
    #[command(flatten)]
    source: CaptureSource,
    #[command(flatten)]
    bit_depth: BitDepth,
    /// Plot one pixel (camera coordinates, 0-based).
    #[arg(long, value_name = "X,Y", value_parser = fsm_io::image_files::parse_pixel, conflicts_with = "row", required_unless_present = "row")]
    pixel: Option<(u32, u32)>,
    /// Map one camera row (0-based).
    #[arg(long, value_name = "Y")]
    row: Option<u32>,
    /// EFSM pattern group shown by --row (1 or 2; default 1).
    #[arg(long, value_name = "G", value_parser = super::named([(Group::One, "1"), (Group::Two, "2")]))]
    group: Option<Group>,
    #[command(flatten)]
    output: OutFile,
}

pub fn run(args: Args) -> Result<()> {
    let out = args.output.check()?;
    let plan = args.plan.read()?;
    let capture = args.source.open(plan, &args.bit_depth, BadRows::Refuse)?;
    if let Some((x, y)) = args.pixel {
        let candidates = inspect::draw_pixel(&plan, &capture, x, y, out)?;
        eprintln!("wrote {}", out.display());
        say!("{}", inspect::candidate_lines(&plan, x, y, &candidates));
    } else if let Some(y) = args.row {
        inspect::draw_row(&plan, &capture, y, args.group, out)?;
        eprintln!("wrote {}", out.display());
    }
    Ok(())
}
