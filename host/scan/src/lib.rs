//! From candidates to a surface: the scan stages after decoding.
//!
//! | stage | module | paper |
//! |---|---|---|
//! | choose the direct candidate of every pixel | [`selection`] | §III-E, eqs. 10–13 |

pub mod selection;

pub use selection::{select, CandidateField, Label, Paths, Selection, SelectionParams};
