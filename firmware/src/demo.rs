//! The bring-up demo: target-independent computations, so that the host build can run and test
//! exactly what the firmware runs (and the two result lines can be compared).
//!
//! A 1024-point real FFT (microfft) of a synthetic cosine, a few libm functions, a
//! heapless::Vec of spectral peaks, CRC-32 of input bytes, and a fixed 32-byte output record.

use core::fmt::Write as _;

use heapless::{String, Vec};
use microfft::Complex32;

/// FFT length of the demo.
pub const N: usize = 1024;
/// Frequency of the synthetic cosine, in FFT bins.
pub const TONE_BIN: usize = 37;
/// Amplitude of the synthetic cosine.
pub const TONE_AMP: f32 = 3.0;
/// Phase of the synthetic cosine at sample 0, radians.
pub const TONE_PHASE: f32 = 0.5;
/// Constant offset added to the cosine.
pub const DC: f32 = 0.25;

/// Fill `buf` with `DC + TONE_AMP * cos(2π·TONE_BIN·n/N + TONE_PHASE)`.
pub fn synth(buf: &mut [f32; N]) {
    for (n, x) in buf.iter_mut().enumerate() {
        // Reduce the argument modulo one period first to keep it small and exact.
        let k = (TONE_BIN * n) % N;
        let arg = 2.0 * core::f32::consts::PI * (k as f32) / (N as f32) + TONE_PHASE;
        *x = DC + TONE_AMP * libm::cosf(arg);
    }
}

/// The in-place 1024-point real FFT (microfft's packing: bin 0 holds DC in `re` and the
/// Nyquist term in `im`).
#[inline(never)]
pub fn rfft(buf: &mut [f32; N]) -> &mut [Complex32; N / 2] {
    microfft::real::rfft_1024(buf)
}

/// One spectral peak.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Peak {
    pub bin: u16,
    pub mag: f32,
    pub phase: f32,
}

/// What the demo reads off a spectrum.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    /// The strongest bins (excluding DC), strongest first.
    pub peaks: Vec<Peak, 4>,
    pub dc: f32,
    pub nyquist: f32,
    /// Energy outside the strongest bin relative to it, dB (very negative for a clean tone).
    pub leakage_db: f32,
}

/// Pick the four strongest bins 1..N/2 and measure leakage.
pub fn analyse(spec: &[Complex32; N / 2]) -> Report {
    let mut peaks: Vec<Peak, 4> = Vec::new();
    let mut total = 0.0f32;
    for (bin, c) in spec.iter().enumerate().skip(1) {
        let mag = libm::hypotf(c.re, c.im);
        total += mag * mag;
        let p = Peak {
            bin: bin as u16,
            mag,
            phase: libm::atan2f(c.im, c.re),
        };
        // Insert keeping descending magnitude; drop the weakest when full.
        let pos = peaks
            .iter()
            .position(|q| mag > q.mag)
            .unwrap_or(peaks.len());
        if pos < peaks.capacity() {
            if peaks.is_full() {
                peaks.pop();
            }
            peaks.insert(pos, p).ok();
        }
    }
    let top = peaks.first().map(|p| p.mag * p.mag).unwrap_or(0.0);
    let rest = (total - top).max(1e-30);
    let leakage_db = if top > 0.0 {
        10.0 * libm::log10f(rest / top)
    } else {
        0.0
    };
    Report {
        peaks,
        dc: spec[0].re,
        nyquist: spec[0].im,
        leakage_db,
    }
}

/// A few libm results, to be compared between host and target.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LibmReport {
    pub sqrt2: f32,
    pub pi: f32,
    pub e: f64,
    pub ln10: f64,
    pub cbrt27: f32,
}

pub fn libm_report() -> LibmReport {
    LibmReport {
        sqrt2: libm::sqrtf(2.0),
        pi: 4.0 * libm::atan2f(1.0, 1.0),
        e: libm::exp(1.0),
        ln10: libm::log(10.0),
        cbrt27: libm::cbrtf(27.0),
    }
}

/// The one-line summary printed by both the firmware and the host binary.
pub fn result_line(r: &Report, l: &LibmReport) -> String<256> {
    let mut s: String<256> = String::new();
    let p = r.peaks.first().copied().unwrap_or(Peak {
        bin: 0,
        mag: 0.0,
        phase: 0.0,
    });
    let _ = write!(
        s,
        "RESULT fft1024 peak_bin={} mag={:.3} phase={:.4} dc={:.3} nyquist={:.3} leakage_db={:.1} peaks={} \
         libm sqrt2={:.6} pi={:.6} e={:.9} ln10={:.9} cbrt27={:.4}",
        p.bin,
        p.mag,
        p.phase,
        r.dc,
        r.nyquist,
        r.leakage_db,
        r.peaks.len(),
        l.sqrt2,
        l.pi,
        l.e,
        l.ln10,
        l.cbrt27
    );
    s
}

/// Checks the firmware makes before reporting success.
pub fn check(r: &Report) -> Result<(), &'static str> {
    let p = r.peaks.first().ok_or("no peak")?;
    if p.bin as usize != TONE_BIN {
        return Err("peak at wrong bin");
    }
    let want = TONE_AMP * (N as f32) / 2.0;
    if (p.mag - want).abs() > 1e-3 * want {
        return Err("peak magnitude off");
    }
    if (p.phase - TONE_PHASE).abs() > 1e-3 {
        return Err("peak phase off");
    }
    if (r.dc - DC * N as f32).abs() > 1e-2 {
        return Err("DC off");
    }
    Ok(())
}

/// CRC-32 (IEEE 802.3, as zlib's `crc32`), table-driven.
pub fn crc32(data: &[u8]) -> u32 {
    const TABLE: [u32; 256] = {
        let mut t = [0u32; 256];
        let mut i = 0;
        while i < 256 {
            let mut c = i as u32;
            let mut k = 0;
            while k < 8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
                k += 1;
            }
            t[i] = c;
            i += 1;
        }
        t
    };
    let mut c = !0u32;
    for &b in data {
        c = TABLE[((c ^ b as u32) & 0xFF) as usize] ^ (c >> 8);
    }
    !c
}

/// Magic of the output record ("FSMO" little-endian).
pub const OUTPUT_MAGIC: u32 = u32::from_le_bytes(*b"FSMO");
/// Length of the output record.
pub const OUTPUT_LEN: usize = 32;

/// The record the firmware writes to the host file `fw-out.bin` (all little-endian u32/f32):
/// magic "FSMO", version 1, peak bin, peak magnitude, peak phase, input length,
/// input CRC-32, instructions of one rfft_1024 (exact under scripts/run-qemu.sh --icount,
/// otherwise 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutputRecord {
    pub peak_bin: u32,
    pub peak_mag: f32,
    pub peak_phase: f32,
    pub input_len: u32,
    pub input_crc: u32,
    pub fft_instructions: u32,
}

impl OutputRecord {
    pub fn encode(&self) -> [u8; OUTPUT_LEN] {
        let words = [
            OUTPUT_MAGIC,
            1,
            self.peak_bin,
            self.peak_mag.to_bits(),
            self.peak_phase.to_bits(),
            self.input_len,
            self.input_crc,
            self.fft_instructions,
        ];
        let mut out = [0u8; OUTPUT_LEN];
        for (chunk, w) in out.chunks_exact_mut(4).zip(words) {
            chunk.copy_from_slice(&w.to_le_bytes());
        }
        out
    }

    pub fn decode(b: &[u8]) -> Option<Self> {
        if b.len() != OUTPUT_LEN {
            return None;
        }
        let w = |i: usize| u32::from_le_bytes([b[4 * i], b[4 * i + 1], b[4 * i + 2], b[4 * i + 3]]);
        if w(0) != OUTPUT_MAGIC || w(1) != 1 {
            return None;
        }
        Some(OutputRecord {
            peak_bin: w(2),
            peak_mag: f32::from_bits(w(3)),
            peak_phase: f32::from_bits(w(4)),
            input_len: w(5),
            input_crc: w(6),
            fft_instructions: w(7),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run() -> Report {
        let mut buf = [0.0f32; N];
        synth(&mut buf);
        analyse(rfft(&mut buf))
    }

    #[test]
    fn fft_finds_the_tone() {
        let r = run();
        check(&r).unwrap();
        assert_eq!(r.peaks.len(), 4);
        assert!(r.leakage_db < -80.0, "leakage {}", r.leakage_db);
        assert!(r.nyquist.abs() < 1e-2);
    }

    #[test]
    fn libm_values() {
        let l = libm_report();
        assert!((l.sqrt2 - core::f32::consts::SQRT_2).abs() < 1e-6);
        assert!((l.pi - core::f32::consts::PI).abs() < 1e-6);
        assert!((l.e - core::f64::consts::E).abs() < 1e-15);
        assert!((l.ln10 - core::f64::consts::LN_10).abs() < 1e-15);
        assert_eq!(l.cbrt27, 3.0);
    }

    #[test]
    fn result_line_fits() {
        let line = result_line(&run(), &libm_report());
        assert!(
            line.starts_with("RESULT fft1024 peak_bin=37 mag=1536.000 phase=0.5000"),
            "{line}"
        );
        assert!(line.ends_with("cbrt27=3.0000"), "{line}");
    }

    #[test]
    fn crc32_check_value() {
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
    }

    #[test]
    fn output_record_round_trip() {
        let r = OutputRecord {
            peak_bin: 37,
            peak_mag: 1536.0,
            peak_phase: 0.5,
            input_len: 9,
            input_crc: 0xCBF4_3926,
            fft_instructions: 12345,
        };
        let b = r.encode();
        assert_eq!(&b[..4], b"FSMO");
        assert_eq!(OutputRecord::decode(&b), Some(r));
        assert_eq!(OutputRecord::decode(&b[..31]), None);
    }
}
