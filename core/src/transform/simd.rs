//! Vectors of `W` lanes of `f32`: the only module with `unsafe` (unaligned loads and stores).
//!
//! The kernels are written once, generic over [`Vector`]: `f32` itself (`W = 1`, the scalar
//! reference path, on every target), `[f32; W]` arrays (portable, one loop per operation) and
//! [`F4`], the 4-lane vector of the target: `__m128` on x86-64 (SSE2, the baseline), a NEON
//! `float32x4_t` on 32-bit ARM built with `+neon` (the camera's Cortex-A9), else an array.
//! On x86-64, `__m256` (AVX) and `__m512` (AVX-512F) are used only by code the build targets
//! at them or by lane loops compiled with their target feature and entered after
//! [`crate::transform::isa::Isa::detect`] saw the CPU run them (`crate::decoder`). Every
//! operation is a lane-wise IEEE add, subtract or multiply (no FMA, no horizontal operation,
//! no approximation), so lane `l` of any vector type gets the bits the scalar path gets.
//!
//! NEON on ARMv7 always flushes subnormal inputs and results to zero, where SSE, AVX and the
//! scalar VFP keep them, so the lanes agree only while no value falls below 2^-126 (about
//! 10^-38) without being zero. The decoder's inputs are sensor codes less a reference level of
//! at least half a code (or an integer), so a non-zero input is above 10^-8; its tables hold
//! nothing below 10^-8 but exact zeros; the transform's few dozen multiplications and
//! additions per value would have to cancel almost completely at every stage to reach 10^-38.
//! Plans whose fringe amplitude is below 10^-6 of the projector's output are refused
//! ([`crate::plan::MIN_LEVEL_AMPLITUDE`]), and the QEMU cross-check compares the camera's
//! candidates with the host's, bit for bit, in CI.
#![allow(unsafe_code)]
#![allow(clippy::needless_range_loop)]

use core::ops::{Add, Mul, Sub};

/// Lane-wise arithmetic: what the butterflies need.
pub(crate) trait Arith:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self>
{
    /// All lanes `x`.
    fn splat(x: f32) -> Self;
}

/// An [`Arith`] that loads from and stores to `W` consecutive `f32`s.
pub(crate) trait Vector<const W: usize>: Arith {
    /// The `W` values of `a`, lane `l` from `a[l]`.
    fn load(a: &[f32; W]) -> Self;
    /// Writes lane `l` to `a[l]`.
    fn store(self, a: &mut [f32; W]);
    /// The `W` sensor codes of `a` as `f32` (exact: codes are below 2^24).
    fn load_codes(a: &[u16; W]) -> Self;
    /// The larger of each lane (of finite values: the decoder takes it of codes).
    fn max(self, b: Self) -> Self;
    /// Bit `l` set where lane `l` of `self` is above `b`'s (false for NaN, as `>`).
    fn above(self, b: Self) -> u32;
    /// Bit `l` set where lane `l` of any of `a` is above `b`'s: the four [`Vector::above`]s
    /// or-ed, which a vector type does with one mask extraction.
    #[inline(always)]
    fn above_any(a: [Self; 4], b: Self) -> u32 {
        a[0].above(b) | a[1].above(b) | a[2].above(b) | a[3].above(b)
    }
}

impl Arith for f32 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        x
    }
}

impl Vector<1> for f32 {
    #[inline(always)]
    fn load(a: &[f32; 1]) -> Self {
        a[0]
    }
    #[inline(always)]
    fn store(self, a: &mut [f32; 1]) {
        a[0] = self;
    }
    #[inline(always)]
    fn load_codes(a: &[u16; 1]) -> Self {
        a[0] as f32
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        if self > b {
            self
        } else {
            b
        }
    }
    #[inline(always)]
    fn above(self, b: Self) -> u32 {
        (self > b) as u32
    }
}

/// Portable `W`-lane vector: a plain array, one loop per operation.
#[derive(Clone, Copy)]
pub(crate) struct Array<const W: usize>(pub(crate) [f32; W]);

impl<const W: usize> Add for Array<W> {
    type Output = Self;
    #[inline(always)]
    fn add(self, b: Self) -> Self {
        let mut r = self.0;
        for l in 0..W {
            r[l] = self.0[l] + b.0[l];
        }
        Array(r)
    }
}

impl<const W: usize> Sub for Array<W> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, b: Self) -> Self {
        let mut r = self.0;
        for l in 0..W {
            r[l] = self.0[l] - b.0[l];
        }
        Array(r)
    }
}

impl<const W: usize> Mul for Array<W> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, b: Self) -> Self {
        let mut r = self.0;
        for l in 0..W {
            r[l] = self.0[l] * b.0[l];
        }
        Array(r)
    }
}

impl<const W: usize> Arith for Array<W> {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Array([x; W])
    }
}

impl<const W: usize> Vector<W> for Array<W> {
    #[inline(always)]
    fn load(a: &[f32; W]) -> Self {
        Array(*a)
    }
    #[inline(always)]
    fn store(self, a: &mut [f32; W]) {
        *a = self.0;
    }
    #[inline(always)]
    fn load_codes(a: &[u16; W]) -> Self {
        Array(core::array::from_fn(|l| a[l] as f32))
    }
    #[inline(always)]
    fn max(self, b: Self) -> Self {
        Array(core::array::from_fn(|l| {
            if self.0[l] > b.0[l] {
                self.0[l]
            } else {
                b.0[l]
            }
        }))
    }
    #[inline(always)]
    fn above(self, b: Self) -> u32 {
        let mut bits = 0;
        for l in 0..W {
            bits |= ((self.0[l] > b.0[l]) as u32) << l;
        }
        bits
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) use x86::*;

#[cfg(all(target_arch = "arm", target_feature = "neon"))]
pub(crate) use arm::F4;

/// The target's 4-lane vector: a plain array where it has no 4-lane registers the build may use.
#[cfg(not(any(
    target_arch = "x86_64",
    all(target_arch = "arm", target_feature = "neon")
)))]
pub(crate) type F4 = Array<4>;

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Arith, Vector};
    use core::arch::x86_64::*;
    use core::ops::{Add, Mul, Sub};

    /// Defines a wrapper type over one register type with its lane-wise operators.
    macro_rules! vector {
        ($name:ident, $reg:ty, $w:literal, $add:ident, $sub:ident, $mul:ident, $set1:ident,
         $load:ident, $store:ident, $max:ident, |$codes:ident| $from_codes:expr,
         |$a:ident, $b:ident| $above:expr, |$xs:ident, $t:ident| $above_any:expr) => {
            #[doc = concat!("`", stringify!($reg), "`: ", stringify!($w), " lanes.")]
            #[derive(Clone, Copy)]
            pub(crate) struct $name($reg);

            impl Add for $name {
                type Output = Self;
                #[inline(always)]
                fn add(self, b: Self) -> Self {
                    // SAFETY: SSE2 is part of x86-64; the AVX types are used only where the
                    // build or the CPU (detected) runs them (module docs).
                    $name(unsafe { $add(self.0, b.0) })
                }
            }

            impl Sub for $name {
                type Output = Self;
                #[inline(always)]
                fn sub(self, b: Self) -> Self {
                    // SAFETY: SSE2 is part of x86-64; the AVX types are used only where the
                    // build or the CPU (detected) runs them (module docs).
                    $name(unsafe { $sub(self.0, b.0) })
                }
            }

            impl Mul for $name {
                type Output = Self;
                #[inline(always)]
                fn mul(self, b: Self) -> Self {
                    // SAFETY: SSE2 is part of x86-64; the AVX types are used only where the
                    // build or the CPU (detected) runs them (module docs).
                    $name(unsafe { $mul(self.0, b.0) })
                }
            }

            impl Arith for $name {
                #[inline(always)]
                fn splat(x: f32) -> Self {
                    // SAFETY: as for `add`: the CPU runs the intrinsic.
                    $name(unsafe { $set1(x) })
                }
            }

            impl Vector<$w> for $name {
                #[inline(always)]
                fn load(a: &[f32; $w]) -> Self {
                    // SAFETY: `a` is a reference to `$w` initialised f32s, all readable; the
                    // unaligned load has no alignment requirement; the CPU runs it (as `add`).
                    $name(unsafe { $load(a.as_ptr()) })
                }
                #[inline(always)]
                fn store(self, a: &mut [f32; $w]) {
                    // SAFETY: `a` is an exclusive reference to `$w` f32s, all writable; the
                    // unaligned store has no alignment requirement; the CPU runs it (as `add`).
                    unsafe { $store(a.as_mut_ptr(), self.0) }
                }
                #[inline(always)]
                fn load_codes($codes: &[u16; $w]) -> Self {
                    // SAFETY: the expression reads exactly the `$w` codes of `$codes` (an
                    // unaligned integer load), widens them to i32 and converts them to f32;
                    // the CPU runs it (as `add`).
                    $name(unsafe { $from_codes })
                }
                #[inline(always)]
                fn max(self, b: Self) -> Self {
                    // SAFETY: as `add`.
                    $name(unsafe { $max(self.0, b.0) })
                }
                #[inline(always)]
                fn above(self, b: Self) -> u32 {
                    let ($a, $b) = (self.0, b.0);
                    // SAFETY: as `add`: an ordered compare (false for NaN, like `>`) and the
                    // sign bits of its lanes.
                    unsafe { $above }
                }
                #[inline(always)]
                fn above_any(xs: [Self; 4], t: Self) -> u32 {
                    let ($xs, $t) = (xs.map(|x| x.0), t.0);
                    // SAFETY: as `above`, with the four compares or-ed before the mask.
                    unsafe { $above_any }
                }
            }
        };
    }

    vector!(
        F4,
        __m128,
        4,
        _mm_add_ps,
        _mm_sub_ps,
        _mm_mul_ps,
        _mm_set1_ps,
        _mm_loadu_ps,
        _mm_storeu_ps,
        _mm_max_ps,
        |c| _mm_cvtepi32_ps(_mm_unpacklo_epi16(
            _mm_loadl_epi64(c.as_ptr() as *const __m128i),
            _mm_setzero_si128()
        )),
        |a, b| _mm_movemask_ps(_mm_cmpgt_ps(a, b)) as u32,
        |x, t| _mm_movemask_ps(_mm_or_ps(
            _mm_or_ps(_mm_cmpgt_ps(x[0], t), _mm_cmpgt_ps(x[1], t)),
            _mm_or_ps(_mm_cmpgt_ps(x[2], t), _mm_cmpgt_ps(x[3], t))
        )) as u32
    );

    vector!(
        F8,
        __m256,
        8,
        _mm256_add_ps,
        _mm256_sub_ps,
        _mm256_mul_ps,
        _mm256_set1_ps,
        _mm256_loadu_ps,
        _mm256_storeu_ps,
        _mm256_max_ps,
        |c| _mm256_cvtepi32_ps(_mm256_cvtepu16_epi32(_mm_loadu_si128(
            c.as_ptr() as *const __m128i
        ))),
        |a, b| _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(a, b)) as u32,
        |x, t| _mm256_movemask_ps(_mm256_or_ps(
            _mm256_or_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(x[0], t),
                _mm256_cmp_ps::<_CMP_GT_OQ>(x[1], t)
            ),
            _mm256_or_ps(
                _mm256_cmp_ps::<_CMP_GT_OQ>(x[2], t),
                _mm256_cmp_ps::<_CMP_GT_OQ>(x[3], t)
            )
        )) as u32
    );

    vector!(
        F16,
        __m512,
        16,
        _mm512_add_ps,
        _mm512_sub_ps,
        _mm512_mul_ps,
        _mm512_set1_ps,
        _mm512_loadu_ps,
        _mm512_storeu_ps,
        _mm512_max_ps,
        |c| _mm512_cvtepi32_ps(_mm512_cvtepu16_epi32(_mm256_loadu_si256(
            c.as_ptr() as *const __m256i
        ))),
        |a, b| _mm512_cmp_ps_mask::<_CMP_GT_OQ>(a, b) as u32,
        |x, t| (_mm512_cmp_ps_mask::<_CMP_GT_OQ>(x[0], t)
            | _mm512_cmp_ps_mask::<_CMP_GT_OQ>(x[1], t)
            | _mm512_cmp_ps_mask::<_CMP_GT_OQ>(x[2], t)
            | _mm512_cmp_ps_mask::<_CMP_GT_OQ>(x[3], t)) as u32
    );
}

#[cfg(all(target_arch = "arm", target_feature = "neon"))]
mod arm {
    use super::{Arith, Vector};
    use core::arch::arm::*;
    use core::ops::{Add, Mul, Sub};

    /// `float32x4_t`: 4 lanes of NEON (the Cortex-A9's Advanced SIMD unit).
    #[derive(Clone, Copy)]
    pub(crate) struct F4(float32x4_t);

    // SAFETY (every `unsafe` block below): the build enables NEON (`cfg` of this module), so
    // the CPU runs the intrinsics; loads and stores go through references to exactly the
    // lanes they touch, and NEON's element loads need no more than the element's alignment.

    impl Add for F4 {
        type Output = Self;
        #[inline(always)]
        fn add(self, b: Self) -> Self {
            // SAFETY: see the module's note.
            F4(unsafe { vaddq_f32(self.0, b.0) })
        }
    }

    impl Sub for F4 {
        type Output = Self;
        #[inline(always)]
        fn sub(self, b: Self) -> Self {
            // SAFETY: see the module's note.
            F4(unsafe { vsubq_f32(self.0, b.0) })
        }
    }

    impl Mul for F4 {
        type Output = Self;
        #[inline(always)]
        fn mul(self, b: Self) -> Self {
            // SAFETY: see the module's note.
            F4(unsafe { vmulq_f32(self.0, b.0) })
        }
    }

    impl Arith for F4 {
        #[inline(always)]
        fn splat(x: f32) -> Self {
            // SAFETY: see the module's note.
            F4(unsafe { vdupq_n_f32(x) })
        }
    }

    impl Vector<4> for F4 {
        #[inline(always)]
        fn load(a: &[f32; 4]) -> Self {
            // SAFETY: `a` is 4 readable f32s; see the module's note.
            F4(unsafe { vld1q_f32(a.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, a: &mut [f32; 4]) {
            // SAFETY: `a` is 4 writable f32s; see the module's note.
            unsafe { vst1q_f32(a.as_mut_ptr(), self.0) }
        }
        #[inline(always)]
        fn load_codes(a: &[u16; 4]) -> Self {
            // SAFETY: `a` is 4 readable u16s, widened to u32 and converted exactly (< 2^24).
            F4(unsafe { vcvtq_f32_u32(vmovl_u16(vld1_u16(a.as_ptr()))) })
        }
        #[inline(always)]
        fn max(self, b: Self) -> Self {
            // SAFETY: see the module's note.
            F4(unsafe { vmaxq_f32(self.0, b.0) })
        }
        #[inline(always)]
        fn above(self, b: Self) -> u32 {
            // SAFETY: see the module's note: an ordered compare (false for NaN, like `>`),
            // each lane's bit kept, and the four bits added pairwise.
            unsafe { lane_bits(vcgtq_f32(self.0, b.0)) }
        }
        #[inline(always)]
        fn above_any(a: [Self; 4], b: Self) -> u32 {
            // SAFETY: see the module's note: four ordered compares or-ed, then their bits.
            unsafe {
                let (x, t) = (a.map(|v| v.0), b.0);
                lane_bits(vorrq_u32(
                    vorrq_u32(vcgtq_f32(x[0], t), vcgtq_f32(x[1], t)),
                    vorrq_u32(vcgtq_f32(x[2], t), vcgtq_f32(x[3], t)),
                ))
            }
        }
    }

    /// Bit `l` set where lane `l` of the compare result `mask` is all ones.
    ///
    /// # Safety
    /// The CPU runs NEON (see the module's note).
    #[inline(always)]
    unsafe fn lane_bits(mask: uint32x4_t) -> u32 {
        const BITS: [u32; 4] = [1, 2, 4, 8];
        // SAFETY: the caller's; `BITS` is 4 readable u32s.
        unsafe {
            let bits = vandq_u32(mask, vld1q_u32(BITS.as_ptr()));
            let pairs = vpadd_u32(vget_low_u32(bits), vget_high_u32(bits));
            vget_lane_u32::<0>(vpadd_u32(pairs, pairs))
        }
    }
}
