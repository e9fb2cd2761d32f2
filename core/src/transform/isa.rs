//! Which vector instructions the lane loops may use on this CPU, found at run time.
//!
//! A host binary is built for the x86-64 baseline (SSE2) so that it runs on every x86-64 CPU;
//! on one that also runs AVX2 or AVX-512F the decoder enters lane loops compiled for them
//! ([`crate::decoder`]). Every path performs the same IEEE operations in every lane, so the
//! choice changes the speed, never the bits (`core/digest` checks it on every run).
//! Elsewhere (the camera's Cortex-A9) there is one portable path.

/// The widest vector instructions the lane loops may use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Isa {
    /// What the build targets (SSE2 on x86-64, scalar VFP on the camera).
    Portable,
    /// AVX2: 8 lanes of `f32` per register.
    Avx2,
    /// AVX-512F: 16 lanes of `f32` per register.
    Avx512,
}

impl Isa {
    /// The widest instruction set this CPU and its operating system run: CPUID says the CPU
    /// has it and that the OS saves the registers' state (XGETBV), as every OS that runs
    /// AVX code must.
    pub fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            x86::detect()
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Isa::Portable
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::Isa;
    use core::arch::x86_64::{__cpuid, __cpuid_count, _xgetbv};

    /// CPUID leaf 1, ECX: OSXSAVE (the OS has enabled XGETBV and the saved-state area) and AVX.
    const OSXSAVE: u32 = 1 << 27;
    const AVX: u32 = 1 << 28;
    /// Leaf 7, EBX: AVX2 and AVX-512F.
    const AVX2: u32 = 1 << 5;
    const AVX512F: u32 = 1 << 16;
    /// XCR0: the OS saves SSE and AVX state (bits 1, 2), and the AVX-512 opmask and upper
    /// registers (bits 5, 6, 7).
    const XCR0_AVX: u64 = 0b110;
    const XCR0_AVX512: u64 = 0b1110_0110;

    #[allow(unsafe_code, unused_unsafe)]
    pub(super) fn detect() -> Isa {
        // SAFETY: CPUID exists on every x86-64 CPU and only reads identification registers
        // (older compilers mark it `unsafe`).
        let (max_leaf, leaf1) = unsafe { (__cpuid(0).eax, __cpuid(1).ecx) };
        if leaf1 & (OSXSAVE | AVX) != (OSXSAVE | AVX) || max_leaf < 7 {
            return Isa::Portable;
        }
        // SAFETY: XGETBV is executed only where CPUID reports OSXSAVE, which is what makes the
        // instruction available; it reads the OS's enabled-state register and nothing else.
        let xcr0 = unsafe { _xgetbv(0) };
        // SAFETY: as above; leaf 7 exists (checked against the highest leaf).
        let leaf7 = unsafe { __cpuid_count(7, 0).ebx };
        let avx2 = leaf7 & AVX2 != 0 && xcr0 & XCR0_AVX == XCR0_AVX;
        let avx512 = avx2 && leaf7 & AVX512F != 0 && xcr0 & XCR0_AVX512 == XCR0_AVX512;
        if avx512 {
            Isa::Avx512
        } else if avx2 {
            Isa::Avx2
        } else {
            Isa::Portable
        }
    }
}
