//! From a pixel's samples to a domain where each projector column's light can be read.
//!
//! | transform | module | used by |
//! |---|---|---|
//! | exact inverse cosine transform (DCT-I) of a full band, `L` pixels at once | [`cosine`] | the cosine search |
//! | lane-parallel mixed-radix complex FFT under it | [`fft`] | [`cosine`] |
//! | the vector instructions this CPU runs, found at run time | [`isa`] | the decoder |
//! | zero-padded real DFT of the fringe samples (`microfft`) | [`spectrum`] | CLEAN, local maxima |
//! | modelled spectrum of one lit column | [`kernel`] | CLEAN, local maxima, deconvolution |
//!
//! The lane-parallel transforms work on [`Lanes`]: one `f32` per pixel, `L` pixels at once,
//! struct-of-arrays. Every lane performs the same scalar IEEE operations in the same order (no
//! fused multiply-add, no operation across lanes), so a pixel decoded on the one-lane camera
//! core and on a sixteen-lane host gives the same bits.

pub mod cosine;
pub mod fft;
pub mod isa;
pub mod kernel;
pub(crate) mod simd;
pub mod spectrum;

/// One `f32` per pixel: `L` pixels processed at once (struct-of-arrays). Element `k` of a
/// signal is a `Lanes<L>` holding that element for all `L` pixels.
pub type Lanes<const L: usize> = [f32; L];

pub use cosine::{CosineTransform, TransformError};
