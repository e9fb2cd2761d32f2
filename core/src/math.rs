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

/// An integer whose order is `f32::total_cmp`'s, and whose bits are the float's for `x ≥ +0`.
#[inline]
pub(crate) fn total_order_key(x: f32) -> i32 {
    let bits = x.to_bits() as i32;
    bits ^ (((bits >> 31) as u32) >> 1) as i32
}

/// The `k`-th smallest of `v` (which it reorders), by Wirth's selection with a median-of-three
/// pivot: the element a sort would put at `k`, without sorting. `k < v.len()`.
pub(crate) fn select(v: &mut [i32], k: usize) -> i32 {
    let k = k as isize;
    let (mut lo, mut hi) = (0isize, v.len() as isize - 1);
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        let (a, b, c) = (v[lo as usize], v[mid as usize], v[hi as usize]);
        // An element of the range, so the scans below stop inside it.
        let pivot = a.max(b).min(a.min(b).max(c));
        let (mut i, mut j) = (lo, hi);
        while i <= j {
            while v[i as usize] < pivot {
                i += 1;
            }
            while pivot < v[j as usize] {
                j -= 1;
            }
            if i <= j {
                v.swap(i as usize, j as usize);
                i += 1;
                j -= 1;
            }
        }
        // Now v[lo..=j] ≤ pivot ≤ v[i..=hi], and everything between equals the pivot.
        if j < k {
            lo = i;
        }
        if k < i {
            hi = j;
        }
    }
    v[k as usize]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn select_finds_what_a_sort_puts_there() {
        let mut state = 12345u64;
        for len in 1..=130usize {
            for round in 0..20 {
                let mut v: [i32; 130] = core::array::from_fn(|_| {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    // Few distinct values in some rounds: ties.
                    let r = (state >> 33) as i32;
                    if round % 3 == 0 {
                        r % 5
                    } else {
                        r
                    }
                });
                if round % 7 == 1 {
                    v[..len].sort_unstable();
                }
                if round % 7 == 2 {
                    v[..len].sort_unstable_by(|a, b| b.cmp(a));
                }
                let mut sorted = v;
                sorted[..len].sort_unstable();
                for k in [0, len / 2, len - 1] {
                    let mut w = v;
                    assert_eq!(select(&mut w[..len], k), sorted[k], "len {len} k {k}");
                }
            }
        }
    }

    #[test]
    fn total_order_key_orders_like_total_cmp() {
        let values = [
            0.0f32,
            1e-40,
            1.0,
            2.5,
            1e30,
            f32::INFINITY,
            f32::NAN,
            3.0e-20,
        ];
        for a in values {
            for b in values {
                assert_eq!(
                    total_order_key(a).cmp(&total_order_key(b)),
                    a.total_cmp(&b),
                    "{a} {b}"
                );
            }
        }
        assert_eq!(f32::from_bits(total_order_key(2.5) as u32), 2.5);
    }
}
