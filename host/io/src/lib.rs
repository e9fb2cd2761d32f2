//! # fsm-io: the host side of the Frequency Shift Method scanner
//!
//! Everything the `fsm` tool does, as a library: plans as files, pattern sets for the
//! projector, captured stacks and row dumps, parallel decoding into candidate files and
//! column maps, and pictures of spectra. All FSM math is `fsm_core`'s; this crate only moves
//! data between files, threads and the core (conventions: `docs/spec.md`).
//!
//! | concern | module |
//! |---|---|
//! | scan plans as TOML/JSON files, presets, `key=value` overrides | [`plan_file`] |
//! | projector response and gamma pre-correction | [`projector_response`] |
//! | projector images of a plan and their manifest | [`patterns`] |
//! | grey PNG/TIFF files read by bands, written whole | [`image_files`] |
//! | captured image stacks, checked against the plan, read by bands of rows | [`stack`] |
//! | row dumps on disk: streaming reader, writer, stack → dump | [`dump`] |
//! | a scan's rows from a stack or a dump, in batches within a memory budget | [`capture`] |
//! | all rows through the line decoder in parallel, in row order | [`decode`] |
//! | candidate files (header + one record per row) | [`candidate_file`] |
//! | a scan's candidates in memory: one flat list, an offset per pixel | [`candidate_image`] |
//! | strongest-candidate column map: float TIFF and preview | [`column_map`] |
//! | plots of one pixel's spectra (the baselines: its samples) and one row's map | [`inspect`] |
//! | whole-or-nothing outputs (temporary name, rename) | [`outputs`] |
//! | progress bars | [`progress`] |
//!
//! ```no_run
//! use fsm_io::{capture::Capture, decode, plan_file, progress::Progress};
//! # fn main() -> fsm_io::Result<()> {
//! let plan = plan_file::read_plan("plan.toml".as_ref())?;
//! let capture = Capture::open_stack("captures".as_ref(), &plan, Some(12))?;
//! let summary = decode::decode_to_dir(
//!     &plan, &capture, "decoded".as_ref(), false, &Default::default(), &Progress::stderr())?;
//! println!("{:.3} Mpx/s", summary.megapixels_per_second());
//! # Ok(()) }
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod candidate_file;
pub mod candidate_image;
pub mod capture;
pub mod column_map;
pub mod decode;
pub mod dump;
pub mod error;
pub mod image_files;
pub mod inspect;
pub mod map_picture;
pub mod outputs;
pub mod patterns;
pub mod plan_file;
pub mod progress;
pub mod projector_response;
pub mod stack;

pub use error::{Error, Result};
