//! Peak searches: from a pixel's transform to the lights that reach it, one family per folder
//! entry, chosen by the plan ([`crate::plan::PeakSearch`]).
//!
//! | search | module | transform |
//! |---|---|---|
//! | CLEAN: strongest peak, fit, subtract its model, repeat | [`clean`] | zero-padded DFT |
//! | the paper's local maxima of the Hann-windowed magnitude | [`local_maxima`] | zero-padded DFT |
//! | lights as runs of the column profile | [`cosine`] | inverse cosine transform |

pub mod clean;
pub mod cosine;
pub mod local_maxima;

/// Most bins the noise median of a DFT search is taken over.
pub(crate) const MEDIAN_SAMPLES: usize = 128;
