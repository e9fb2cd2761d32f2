//! `fsm demo`: the paper's comparison on a simulated mirror scene, no camera needed (the
//! experiment is [`fsm_sim::comparison`]).

use fsm_io::Result;
use fsm_sim::comparison;

/// Run the paper's comparison on simulated scenes: FSM and the methods it is compared with
/// (phase shift, Micro Phase Shifting, Code Ensemble, line scanning), with and without a
/// mirror's interreflection, and under glossy interreflection.
///
/// The bench scanner looks at a diffuse plane beside a planar mirror (`plane_mirror`): the
/// plane receives the projector's light directly and through the mirror. The same scene with
/// the mirror blackened (`plane_mirror_covered`) is the reference. Each is scanned with BFSM
/// (768 patterns), EFSM (cB 64, two groups: 152 patterns), phase shift + Gray code (6 + 7
/// patterns), Micro Phase Shifting (17), Code Ensemble (80), line scanning (768) and the EFSM
/// patterns decoded by the local-maximum search (`EFSM-fast`, the camera's fast decoder),
/// each through the same decode → triangulate → select path, and compared with the
/// simulator's ground truth and with each other (paper Fig. 9: Ed, EnoI, EwiI; Fig. 13: BFSM
/// against line scanning with as many patterns). BFSM and EFSM are also decoded by CLEAN
/// (`-CLEAN`, the DFT search the cosine search replaced). Every method also scans
/// `vgroove_glossy` (two rough-metal facets whose light reflected facet to facet outshines the
/// direct light): how often the direct column is among the candidates and the selected point
/// is right.
///
/// Writes into the output folder:
///   report.html, report.md     the figures per method, with pictures (the same report,
///                              for a browser and for a Markdown viewer)
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
    eprintln!(
        "fsm demo: simulating plane_mirror, plane_mirror_covered, sphere_mirror and vgroove_glossy ({}x{} camera)…",
        system.width(),
        system.height()
    );
    let report = comparison::run(&system, args.bench.seed, staged.path(), |line| {
        eprintln!("  {line}")
    })?;
    comparison::write_reports(staged.path(), &report)?;
    let out = staged.commit()?;
    eprintln!(
        "fsm demo: report in {} (and report.md, report.json beside it)",
        out.join("report.html").display()
    );
    Ok(())
}
