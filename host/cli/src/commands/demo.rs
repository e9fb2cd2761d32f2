//! `fsm demo`: the paper's comparison on a simulated mirror scene, no camera needed (the
//! experiment is [`fsm_sim::comparison`]).

use fsm_io::Result;
use fsm_sim::comparison;

/// Run the paper's comparison on simulated scenes: FSM against phase shift, Micro Phase
/// Shifting, Code Ensemble and line scanning, under mirror and glossy interreflection.
///
/// Every method (BFSM and EFSM also decoded by CLEAN, and EFSM by the camera's local-maximum
/// search as EFSM-fast) scans, on the bench scanner, plane_mirror (a plane lit directly and
/// through a mirror), plane_mirror_covered (the mirror blackened: the reference),
/// sphere_mirror and vgroove_glossy (rough metal); each scan is compared with the ground truth
/// and with the others (paper Figs. 9 and 13). The plans and figures: docs/comparison.md.
///
/// Writes into the output folder:
///   report.html, report.md     the figures per method with pictures, for a browser and Markdown
///   report.json                the same figures, for programs
///   <method>/<scene>/          each scan's outputs (as `fsm scan` writes them)
///   <method>/column_error.png  |decoded − true column| with the mirror (0 to 1 column)
///   interreflection.png        where the mirror's light exceeds 20% of the direct light
///
/// Examples:
///   fsm demo
///   fsm demo --out my-demo --camera 640x480
#[derive(clap::Args, Debug)]
#[command(verbatim_doc_comment)]
#[command(mut_arg("out", |a| a.required(false).default_value("fsm-demo")))]
pub struct Args {
    #[command(flatten)]
    output: super::OutDir,
    #[command(flatten)]
    bench: super::BenchArgs,
}

pub fn run(args: Args) -> Result<()> {
    let staged = args.output.stage()?;
    let system = args.bench.system();
    eprintln!("fsm demo: {}", comparison::announcement(&system));
    let report = comparison::run(&system, args.bench.seed, staged.path(), |line| {
        eprintln!("  {line}")
    })?;
    comparison::write_reports(staged.path(), &report)?;
    let out = staged.commit()?;
    eprintln!("fsm demo: {}", comparison::reports_written(&out));
    Ok(())
}
