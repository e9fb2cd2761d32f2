//! From candidates to a surface: the scan stages after decoding.
//!
//! | stage | module | paper |
//! |---|---|---|
//! | candidates of every pixel, from any method | [`decoded`] | |
//! | every candidate → a 3D point, measurement volume | [`triangulate`] | SPEC §5 |
//! | choose the direct candidate of every pixel | [`selection`] | §III-E, eqs. 10–13 |
//! | drop the chosen points the projector cannot light directly | [`visibility`] | |
//! | find plane mirrors, drop the virtual images they make | [`mirror`] | |
//! | a pixel whose choice was fictitious takes the candidate that continues its neighbours' surface | [`surface`], [`continuation`] | |
//! | drop the pixels that straddle a depth edge or a crease | [`surface`], [`continuation`] | |
//! | the chosen point (or why none), column and direct / indirect light per pixel | [`surface`] | eqs. 12–13 |
//! | Fig. 9 metrics and column errors against ground truth | [`metrics`] | §VII-B |
//! | `points.ply` | [`ply`] | |
//! | everything `fsm scan` writes | [`output`] | |
//! | the whole scan, candidates in, a written folder out | [`pipeline`] | |

pub mod continuation;
pub mod decoded;
pub mod metrics;
pub mod mirror;
pub mod output;
pub mod pipeline;
pub mod ply;
pub mod selection;
pub mod surface;
pub mod triangulate;
pub mod visibility;

pub use selection::{select, CandidateField, Label, Paths, Selection, SelectionParams};
pub use surface::{NoPoint, NoPointCounts, Surface};
