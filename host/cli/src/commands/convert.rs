//! `fsm convert`: turn a stack of captured images into a row dump.

use std::path::PathBuf;

use fsm_io::dump;
use fsm_io::progress::Progress;
use fsm_io::stack::Stack;
use fsm_io::Result;

use super::{BitDepth, MemoryBudget};

/// Convert a stack of captured images into a row dump (the format the camera streams).
///
/// The stack is checked against the plan first (image count, size, bit depth), then read in
/// bands of rows within the memory budget; the dump appears whole or not at all.
///
/// Example: fsm convert --plan plan.toml --images captures/ --bit-depth 12 --out scan.dump
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Plan file the images were captured with, of any method.
    #[arg(long, value_name = "FILE")]
    plan: PathBuf,
    /// Folder of captured images (0000.png, 0001.png, …).
    #[arg(long, value_name = "DIR")]
    images: PathBuf,
    #[command(flatten)]
    bit_depth: BitDepth,
    /// Output dump file.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
    /// Replace the output file if it exists.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    memory: MemoryBudget,
}

pub fn run(args: Args) -> Result<()> {
    fsm_io::outputs::check_file_target(&args.out, args.force)?;
    let plan = fsm_io::plan_file::read_method_plan(&args.plan)?;
    let stack = Stack::open(&args.images, plan, args.bit_depth.bit_depth)?;
    let header = dump::write_dump_from_stack(
        plan,
        &stack,
        &args.out,
        args.memory.bytes(),
        &Progress::stderr(),
    )?;
    eprintln!(
        "wrote {}: {} rows of {} pixels x {} frames, {}-bit",
        args.out.display(),
        header.height,
        header.width,
        header.frames,
        header.bit_depth
    );
    Ok(())
}
