//! The floating-point functions every part of the project uses.
//!
//! Candidates must be bit-identical on the camera and on the host, and std's `sinf`/`expf`/
//! `logf` (the platform's C library) differ from `libm` in the last bit. So `core` computes
//! everything with `libm` and plain IEEE `f32`/`f64` arithmetic, and the host calls these
//! functions instead of std's whenever a result can reach a candidate.

/// `√x`, correctly rounded.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    libm::sqrtf(x)
}

/// Natural logarithm.
#[inline]
pub fn ln(x: f32) -> f32 {
    libm::logf(x)
}

/// `eˣ`.
#[inline]
pub fn exp(x: f32) -> f32 {
    libm::expf(x)
}

/// Round half away from zero.
#[inline]
pub fn round(x: f32) -> f32 {
    libm::roundf(x)
}

/// Largest integer not above `x`.
#[inline]
pub fn floor(x: f32) -> f32 {
    libm::floorf(x)
}

/// `sin x` in `f64`.
#[inline]
pub fn sin64(x: f64) -> f64 {
    libm::sin(x)
}

/// `cos x` in `f64`.
#[inline]
pub fn cos64(x: f64) -> f64 {
    libm::cos(x)
}

/// A complex number of `f32` parts (the layout microfft uses: `re` then `im`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Complex {
    /// Real part.
    pub re: f32,
    /// Imaginary part.
    pub im: f32,
}

impl Complex {
    /// `re + i·im`.
    #[inline]
    pub const fn new(re: f32, im: f32) -> Self {
        Complex { re, im }
    }

    /// `|z|²`.
    #[inline]
    pub fn norm_sqr(self) -> f32 {
        self.re * self.re + self.im * self.im
    }

    /// `|z|`.
    #[inline]
    pub fn norm(self) -> f32 {
        sqrt(self.norm_sqr())
    }

    /// `Re(z̄·w)`: the real inner product of two complex numbers seen as 2-vectors.
    #[inline]
    pub fn dot(self, w: Complex) -> f32 {
        self.re * w.re + self.im * w.im
    }
}
