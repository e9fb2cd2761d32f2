//! The floating-point functions every part of the project uses.
//!
//! Candidates must be bit-identical on the camera and on the host, and std's `sinf`/`expf`/
//! `logf` (the platform's C library) differ from `libm` in the last bit. So `core` computes
//! everything with `libm` and plain IEEE `f32`/`f64` arithmetic, and the host calls these
//! functions instead of std's whenever a result can reach a candidate.

/// `√x`, correctly rounded.
///
/// IEEE 754 requires a correctly rounded square root, so the VFP's `vsqrt.f32` on the camera,
/// SSE's `sqrtss` (which `libm` uses on x86) and `libm`'s bitwise fallback all give the same
/// bits. On 32-bit ARM `libm` has no hardware path and its fallback costs a few hundred
/// instructions per call, a fifth of an EFSM pixel's decode.
#[inline]
pub fn sqrt(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        vfp_sqrt(x)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// `vsqrt.f32`: every hard-float (`eabihf`) ARM target has a VFP.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline]
#[allow(unsafe_code)]
fn vfp_sqrt(mut x: f32) -> f32 {
    // SAFETY: one VFP instruction on registers: no memory access, no side effect beyond the
    // FPSCR exception flags, which nothing here reads.
    unsafe {
        core::arch::asm!(
            "vsqrt.f32 {x}, {x}",
            x = inout(sreg) x,
            options(nostack, nomem, pure),
        );
    }
    x
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
