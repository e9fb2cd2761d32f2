//! `fsm convert`: turn a stack of captured images into a row dump.

use std::path::PathBuf;

use fsm_io::dump;
use fsm_io::progress::Progress;
use fsm_io::stack::Stack;
use fsm_io::Result;

use super::{BitDepth, MemoryBudget, OutFile, PlanFile};

/// Convert a stack of captured images into a row dump (the format the camera streams).
///
/// The stack is checked against the plan first (image count, size, bit depth), then read in
/// bands of rows within the memory budget; the dump appears whole or not at all.
///
/// Example: fsm convert --plan plan.toml --images captures/ --bit-depth 12 --out scan.dump
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    #[command(flatten)]
    plan: PlanFile,
    /// Folder of captured images (0000.png, 0001.png, …).
    #[arg(long, value_name = "DIR")]
    images: PathBuf,
    #[command(flatten)]
    bit_depth: BitDepth,
    #[command(flatten)]
    output: OutFile,
    #[command(flatten)]
    memory: MemoryBudget,
}

pub fn run(args: Args) -> Result<()> {
    let out = args.output.check()?;
    let plan = args.plan.read()?;
    let stack = Stack::open(&args.images, plan, args.bit_depth.bit_depth)?;
    let budget = args.memory.bytes();
    let header = dump::write_dump_from_stack(plan, &stack, out, budget, &Progress::stderr())?;
    let (h, w, frames, bits) = (header.height, header.width, header.frames, header.bit_depth);
    let out = out.display();
    eprintln!("wrote {out}: {h} rows of {w} pixels x {frames} frames, {bits}-bit");
    Ok(())
}
