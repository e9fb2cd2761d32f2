//! From a pixel's samples to a domain where each projector column's light can be read.
//!
//! | transform | module | used by |
//! |---|---|---|
//! | zero-padded real DFT of the fringe samples (`microfft`) | [`spectrum`] | CLEAN, local maxima |
//! | modelled spectrum of one lit column | [`kernel`] | CLEAN, local maxima, deconvolution |

pub mod kernel;
pub mod spectrum;
