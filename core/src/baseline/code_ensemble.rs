//! Code Ensemble ("CE", Gupta, Agrawal, Veeraraghavan & Narasimhan, CVPR 2011; the paper's
//! ref. \[19\] and its 80-image comparison in §VII): four 10-bit binary codes, each built to
//! survive one kind of indirect light, decoded separately; a pixel keeps the column two of them
//! agree on, and no column where none agree.
//!
//! | code | what its stripes are | what it survives |
//! |---|---|---|
//! | [`Code::Gray`] | conventional (reflected) Gray code, stripes 2–512 wide | defocus and sub-surface scattering: most of its stripes are wide |
//! | [`Code::LongRun`] | a Gray code whose stripes are 8 to 16 columns wide | blur and defocus |
//! | [`Code::Xor2`] | Gray bits 0–8 XORed with bit 9 (stripes 1–2 wide) | long-range interreflection |
//! | [`Code::Xor4`] | Gray bits 0–7 XORed with bit 8 (stripes 2–4 wide) | long-range interreflection |
//!
//! A coarse stripe lights half the scene at once, so a pixel in the dark half can receive more
//! indirect light than a lit one: its bit flips. An XOR pattern lights every other narrow
//! stripe, so the indirect light is about the same in a pattern and its inverse, and the
//! comparison of the two survives it; XORing the decoded bit with the decoded base bit gives
//! back the Gray bit (the logical coding of the CE paper).
//!
//! Frames: for each code in [`CODES`] order, for each bit (0 = most significant for the Gray
//! and XOR codes), the pattern and then its inverse: `4 × 10 × 2 = 80` frames, no reference
//! frames. A bit reads 1 where the pattern's sample exceeds its inverse's.
//!
//! Choices the CE paper leaves to its implementation (`docs/comparison.md`):
//! - **The long-run code.** The CE paper uses a "max min-SW" Gray code (Goddyn & Gvozdjak 2003),
//!   whose narrowest stripe is 8 columns, the most 10 bits allow. Ours reaches 8 too, with
//!   stripes at most 16 wide (a test checks both figures, and that every bit's runs are at
//!   least 8 cyclically): [`long_run_code`] changes a low and a high 5-bit half in turn, the
//!   low half stepping through a 5-bit code of Goddyn, Lawrence & Nemeth (1988, Theorem 2)
//!   whose runs are 4 to 8 long, the high half through a 512-step walk built from a 64-step
//!   seed of ours by a symmetry. Before 2026-12-08 it was their Theorem 1 composition of two
//!   5-bit codes, stripes 7 to 18 wide; the fingerprints tell the two apart.
//! - **Agreement.** Two codes agree when their columns differ by at most
//!   [`CodeEnsemblePlan::agreement_columns`]; among agreeing pairs the column is taken with the
//!   precedence of the authors' decoder (the long-run code first, then XOR-04, then XOR-02).
//! - **No spatial filling.** The authors median-filter each code's map and fill pixels where no
//!   two codes agree from their neighbours; here a pixel is decoded from its own samples, and one
//!   without agreement has no candidate (a point is right or absent).
//! - **Shadow.** A pixel whose mean `|pattern − inverse|` is at most `min_contrast_dn` is dark.
//! - **Projectors wider than 1024 columns** share codewords: codeword `k` covers the columns
//!   `c` with `⌊1024·c / cmax⌋ = k`, and the decoded column is their centre.

use core::fmt;

use super::{offer_light, PatternSequence, PixelDecoder};
use crate::candidate::{ColumnRange, PixelCandidates, PixelFlags};
use crate::noise::{amplitude_noise_dn, sample_noise_dn};
use crate::plan::SensorNoise;

/// Bits of every code.
pub const BITS: usize = 10;

/// Codewords of every code: `2^BITS`.
pub const CODEWORDS: usize = 1 << BITS;

/// Frames of one code: each bit's pattern and its inverse.
pub const FRAMES_PER_CODE: usize = 2 * BITS;

/// The four codes, in frame order.
pub const CODES: [Code; 4] = [Code::Gray, Code::LongRun, Code::Xor4, Code::Xor2];

/// One of the ensemble's four binary codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Code {
    /// Conventional reflected Gray code.
    Gray,
    /// A Gray code with long runs ([`long_run_code`]).
    LongRun,
    /// Gray bits 0–7 XORed with Gray bit 8 (the base), bits 8 and 9 as they are.
    Xor4,
    /// Gray bits 0–8 XORed with Gray bit 9 (the base), bit 9 as it is.
    Xor2,
}

impl Code {
    /// The code's name in the CE paper.
    pub fn name(self) -> &'static str {
        match self {
            Code::Gray => "conventional Gray",
            Code::LongRun => "long-run Gray",
            Code::Xor4 => "XOR-04",
            Code::Xor2 => "XOR-02",
        }
    }

    /// The base bit an XOR code's coarser bits are XORed with.
    fn xor_base(self) -> Option<usize> {
        match self {
            Code::Xor4 => Some(BITS - 2),
            Code::Xor2 => Some(BITS - 1),
            Code::Gray | Code::LongRun => None,
        }
    }

    /// The `BITS` pattern bits (bit `b` of the result is pattern `b`) of codeword index `k`.
    pub fn patterns(self, k: usize) -> u16 {
        match self {
            Code::LongRun => LONG_RUN.codeword[k % CODEWORDS],
            _ => {
                let gray = gray_msb_first(k % CODEWORDS);
                match self.xor_base() {
                    Some(base) => {
                        let mask = (1u16 << base) - 1;
                        let base_bit = (gray >> base) & 1;
                        gray ^ (mask * base_bit)
                    }
                    None => gray,
                }
            }
        }
    }

    /// The codeword index whose patterns read `bits` (bit `b` = pattern `b` lit).
    pub fn index(self, bits: u16) -> usize {
        let bits = bits & (CODEWORDS as u16 - 1);
        match self {
            Code::LongRun => LONG_RUN.index[bits as usize] as usize,
            _ => {
                let gray = match self.xor_base() {
                    Some(base) => {
                        let mask = (1u16 << base) - 1;
                        bits ^ (mask * ((bits >> base) & 1))
                    }
                    None => bits,
                };
                gray_index_msb_first(gray)
            }
        }
    }
}

/// The reflected Gray code of `k` with its most significant bit as pattern 0.
fn gray_msb_first(k: usize) -> u16 {
    let gray = (k ^ (k >> 1)) as u16;
    reverse_bits(gray)
}

/// The inverse of [`gray_msb_first`].
fn gray_index_msb_first(bits: u16) -> usize {
    let mut k = reverse_bits(bits) as usize;
    let mut shift = 1;
    while shift < BITS {
        k ^= k >> shift;
        shift <<= 1;
    }
    k
}

/// `BITS`-bit reversal: pattern 0 shows the most significant bit.
fn reverse_bits(v: u16) -> u16 {
    v.reverse_bits() >> (16 - BITS)
}

/// A long-run Gray code: every codeword, and every codeword's index.
pub struct LongRunCode {
    /// Codeword `k` (bit `b` = pattern `b`).
    pub codeword: [u16; CODEWORDS],
    /// The index of each codeword.
    pub index: [u16; CODEWORDS],
}

/// The ensemble's long-run Gray code, built once at compile time.
pub static LONG_RUN: LongRunCode = long_run_code();

/// The transition sequence of a 5-bit cyclic Gray code whose runs are all at least 4 long (the
/// bit that changes after each codeword): Goddyn, Lawrence & Nemeth's composition of two 2-bit
/// codes and a 1-bit code ("Gray codes with optimized run lengths", Utilitas Mathematica 34,
/// 1988, Theorem 2 with `n = m = 2`, `r = 1`, `s = t = 1`). Its runs are 4 to 8 long; an
/// exhaustive search of ours over the 5-bit cyclic Gray codes with runs of at least 4 found
/// none whose widest run is narrower than 8.
pub const fn five_bit_transitions() -> [u8; 32] {
    // 2-bit and 1-bit cyclic codes: their transition sequences.
    const TWO: [u8; 4] = [0, 1, 0, 1];
    const ONE: [u8; 2] = [0, 0];
    // P = "ba" (one b, then one a); Q = P repeated 2^n = 4 times with its last b (place 6)
    // made a c; Z = Q repeated 2^m = 4 times. The a's step through the first 2-bit code (bits
    // 0–1), the b's through the second (bits 2–3), the c's through the 1-bit code (bit 4).
    let mut five = [0u8; 32];
    let (mut ia, mut ib, mut ic, mut i) = (0, 0, 0, 0);
    while i < 32 {
        let q = i % 8; // place within Q
        five[i] = if q % 2 == 1 {
            ia += 1;
            TWO[(ia - 1) % 4]
        } else if q == 6 {
            ic += 1;
            ONE[(ic - 1) % 2] + 4
        } else {
            ib += 1;
            TWO[(ib - 1) % 4] + 2
        };
        i += 1;
    }
    five
}

/// The first 64 steps of the walk the high five bits take ([`long_run_code`]): the bit (0–4)
/// that changes at each step. Found by a depth-first search of ours (not taken from a
/// publication) for a sequence with the three properties [`long_run_code`] needs, which a test
/// checks: no bit changes twice within 4 steps, also across the joins to its images under
/// [`high_shift`]; its walk from 0 ends at [`HIGH_OFFSET`]; and the words `32` steps apart in
/// it lie in different orbits of [`high_symmetry`]. Among the sequences found, one whose runs
/// are at most 6 steps long.
pub const HIGH_SEED: [u8; 64] = [
    4, 0, 3, 1, 4, 2, 3, 0, 4, 1, 3, 2, 0, 4, 3, 1, 2, 0, 4, 1, 3, 0, 2, 4, 1, 3, 2, 0, 4, 3, 1, 0,
    2, 4, 3, 1, 2, 0, 4, 3, 1, 2, 0, 4, 3, 1, 0, 2, 4, 3, 1, 2, 0, 3, 4, 1, 2, 0, 4, 3, 1, 0, 2, 3,
];

/// The bit permutation of [`high_symmetry`]: bits 0 → 1 → 2 → 3 → 0, bit 4 fixed.
pub const fn high_shift(bit: u8) -> u8 {
    if bit < 4 {
        (bit + 1) % 4
    } else {
        bit
    }
}

/// Bits `0b10001`: the word the walk of [`HIGH_SEED`] ends at, and the offset of
/// [`high_symmetry`].
pub const HIGH_OFFSET: u8 = 0b1_0001;

/// The symmetry of the high bits' walk: the word `w` with its bits moved by [`high_shift`], then
/// XORed with [`HIGH_OFFSET`]. Its eighth power is the identity and its fourth adds `0b01111`,
/// so every orbit holds 8 words, all of the same parity: two orbits of even words, two of odd.
pub const fn high_symmetry(w: u8) -> u8 {
    let mut moved = 0;
    let mut bit = 0;
    while bit < 5 {
        if (w >> bit) & 1 == 1 {
            moved |= 1 << high_shift(bit);
        }
        bit += 1;
    }
    moved ^ HIGH_OFFSET
}

/// Builds the ensemble's long-run code from its transition sequence (the bit that changes after
/// each codeword). The 10-bit cube is the product of two 5-bit cubes, the low bits 0–4 and the
/// high bits 5–9, and the code changes a low bit and a high bit in turn, the shape a secondary
/// account gives Goddyn & Gvozdjak's product circuits (“Binary Gray codes with long bit runs”,
/// Electronic Journal of Combinatorics 10, 2003, R27; we could not read the paper itself, so
/// the construction and its proof below are ours). Each half's own sequence keeps a bit at
/// least 4 of its steps, so every bit of the code keeps at least 8 columns. Which 512-step
/// high walk makes the circuit meet every word once is our own choice, below.
///
/// - The low bits step through the 5-bit code of [`five_bit_transitions`] (32 steps, repeated
///   16 times): the low word at step `k` is `A[k mod 32]`, `A` that code's words.
/// - The high bits walk 512 steps: [`HIGH_SEED`], then 7 more copies, copy `q` with every bit
///   moved `q` times by [`high_shift`]. The high word `B[k]` at step `k` is then
///   `σ^q(B[k − 64q])` with `σ` = [`high_symmetry`], and the walk closes after 8 copies.
///
/// Codeword `2k` is `(A[k mod 32], B[k])` and codeword `2k + 1` is `(A[k+1 mod 32], B[k])`. A
/// low word `A[i]` is thus paired with the high words `B[k]` for `k ≡ i` and for `k ≡ i − 1`
/// (mod 32), of opposite parities; each of those two sets is the 16 words `σ^p(B[r])`,
/// `σ^p(B[r + 32])`, `p < 8`, which are distinct because [`HIGH_SEED`] puts `B[r]` and
/// `B[r + 32]` in different orbits of `σ`. So every 10-bit word is a codeword exactly once, and
/// the code is a cyclic Gray code: one bit changes per step, also from the last codeword to the
/// first. Its runs are 8 to 16 columns wide (the low code's widest run, 8 of its steps, is 16
/// columns; the high walk's, 6 steps, 12).
pub const fn long_run_code() -> LongRunCode {
    let low = five_bit_transitions();
    let mut transitions = [0u8; CODEWORDS];
    let mut k = 0;
    while k < CODEWORDS / 2 {
        let (copy, step) = (k / 64, k % 64);
        let mut high = HIGH_SEED[step];
        let mut q = 0;
        while q < copy {
            high = high_shift(high);
            q += 1;
        }
        transitions[2 * k] = low[k % 32];
        transitions[2 * k + 1] = 5 + high;
        k += 1;
    }
    let mut code = LongRunCode {
        codeword: [0; CODEWORDS],
        index: [0; CODEWORDS],
    };
    let mut word = 0u16;
    let mut k = 0;
    while k < CODEWORDS {
        code.codeword[k] = word;
        code.index[word as usize] = k as u16;
        word ^= 1 << transitions[k];
        k += 1;
    }
    code
}

/// CRC-32 of the long-run code's codewords (each little-endian, in index order), part of every
/// Code Ensemble fingerprint: a capture or decode made with another long-run code is refused.
pub fn long_run_digest() -> u32 {
    let mut h = crc32fast::Hasher::new();
    for word in LONG_RUN.codeword.iter() {
        h.update(&word.to_le_bytes());
    }
    h.finalize()
}

/// A Code Ensemble scan.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct CodeEnsemblePlan {
    /// Projector columns `cmax`.
    pub projector_columns: u16,
    /// Two codes agree when their columns differ by at most this many codewords.
    pub agreement_columns: u16,
    /// A pixel's mean `|pattern − inverse|` must exceed this (sensor DN) to be decoded.
    pub min_contrast_dn: f32,
    /// The camera's sensor: the noise a point's quality is measured in (only the scan reads
    /// it; plan files written before it have the default).
    #[cfg_attr(feature = "serde", serde(default))]
    pub sensor: SensorNoise,
}

/// A violated Code Ensemble plan rule.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[allow(missing_docs)] // each field is the value the variant reports
pub enum CodeEnsembleError {
    /// At least 2 columns.
    Columns { projector_columns: u16 },
    /// Agreement within a quarter of the codewords is no agreement.
    Agreement { agreement_columns: u16 },
    /// A threshold must be a finite number, not below 0.
    Threshold { value: f32 },
    /// The sensor's noise model ([`SensorNoise::check`]).
    Sensor { field: &'static str, value: f32 },
}

impl fmt::Display for CodeEnsembleError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            CodeEnsembleError::Columns { projector_columns } => write!(
                f,
                "projector_columns = {projector_columns}: at least 2 columns are needed"
            ),
            CodeEnsembleError::Agreement { agreement_columns } => write!(
                f,
                "agreement_columns = {agreement_columns}: must be at most {}",
                CODEWORDS / 4
            ),
            CodeEnsembleError::Threshold { value } => {
                write!(
                    f,
                    "min_contrast_dn = {value}: must be a finite number, not below 0"
                )
            }
            CodeEnsembleError::Sensor { field, value } => {
                write!(f, "{field} = {value}: {}", SensorNoise::RULE)
            }
        }
    }
}

impl CodeEnsemblePlan {
    /// The ensemble on a projector of `columns` columns, codes agreeing within one codeword (a
    /// pixel on a stripe edge may read either side of it).
    pub fn for_projector(columns: u16) -> Self {
        CodeEnsemblePlan {
            projector_columns: columns,
            agreement_columns: 1,
            min_contrast_dn: 2.0,
            sensor: SensorNoise::default(),
        }
    }

    /// The paper's comparison: the 768 projector columns FSM codes.
    pub fn paper() -> Self {
        Self::for_projector(768)
    }

    /// Checks the plan's rules.
    pub fn validate(&self) -> Result<(), CodeEnsembleError> {
        if self.projector_columns < 2 {
            return Err(CodeEnsembleError::Columns {
                projector_columns: self.projector_columns,
            });
        }
        if self.agreement_columns as usize > CODEWORDS / 4 {
            return Err(CodeEnsembleError::Agreement {
                agreement_columns: self.agreement_columns,
            });
        }
        let value = self.min_contrast_dn;
        if !(value.is_finite() && value >= 0.0) {
            return Err(CodeEnsembleError::Threshold { value });
        }
        self.sensor
            .check()
            .map_err(|(field, value)| CodeEnsembleError::Sensor { field, value })
    }

    /// Frames in the sequence: 80.
    pub fn sequence_len(&self) -> usize {
        CODES.len() * FRAMES_PER_CODE
    }

    /// What frame `frame` shows: its code, bit, and whether it is the inverse.
    pub fn frame(&self, frame: usize) -> Option<(Code, usize, bool)> {
        (frame < self.sequence_len()).then(|| {
            let code = CODES[frame / FRAMES_PER_CODE];
            let within = frame % FRAMES_PER_CODE;
            (code, within / 2, within % 2 == 1)
        })
    }

    /// The codeword index of projector column `column`.
    pub fn codeword_of(&self, column: u32) -> usize {
        let columns = self.projector_columns as usize;
        if columns <= CODEWORDS {
            column as usize
        } else {
            column as usize * CODEWORDS / columns
        }
    }

    /// The centre of the columns codeword `k` covers, or `None` past the projector.
    pub fn column_of(&self, k: usize) -> Option<f32> {
        let columns = self.projector_columns as usize;
        if columns <= CODEWORDS {
            return (k < columns).then_some(k as f32);
        }
        // Columns c with ⌊CODEWORDS·c / columns⌋ = k: from ⌈k·columns/CODEWORDS⌉ to
        // ⌈(k+1)·columns/CODEWORDS⌉ − 1.
        let first = (k * columns).div_ceil(CODEWORDS);
        let last = ((k + 1) * columns).div_ceil(CODEWORDS) - 1;
        (k < CODEWORDS).then_some(0.5 * (first + last) as f32)
    }

    /// CRC-64/XZ of the plan's fields, little-endian after the tag `CE`, then the
    /// [`long_run_digest`]: the identity candidate files of its decodes carry. Not the sensor,
    /// which no candidate depends on (it only scales the points' quality).
    pub fn fingerprint(&self) -> u64 {
        let mut bytes = [0u8; 14];
        bytes[..2].copy_from_slice(b"CE");
        bytes[2..4].copy_from_slice(&self.projector_columns.to_le_bytes());
        bytes[4..6].copy_from_slice(&self.agreement_columns.to_le_bytes());
        bytes[6..10].copy_from_slice(&self.min_contrast_dn.to_le_bytes());
        bytes[10..14].copy_from_slice(&long_run_digest().to_le_bytes());
        crate::wire::crc64(&bytes)
    }

    /// The fingerprint of the frames alone ([`crate::wire::pattern_fingerprint`], tag
    /// `CE`): the columns, then the [`long_run_digest`] (the other three codes are fixed); not
    /// the decoder's `agreement_columns` and `min_contrast_dn`. Row dumps recorded with the
    /// long-run code of before 2026-12-08 (narrowest stripe 7 columns) carry another one and
    /// are refused.
    pub fn pattern_fingerprint(&self) -> u64 {
        let mut fields = [0u8; 6];
        fields[..2].copy_from_slice(&self.projector_columns.to_le_bytes());
        fields[2..6].copy_from_slice(&long_run_digest().to_le_bytes());
        crate::wire::pattern_fingerprint(b"CE", &fields)
    }

    /// The consistency rule: the column two codes agree on, in the authors' precedence, given
    /// each code's codeword index in [`CODES`] order.
    pub fn agreed(&self, index: [usize; 4]) -> Option<usize> {
        let [gray, long_run, xor4, xor2] = index;
        let near = |a: usize, b: usize| a.abs_diff(b) <= self.agreement_columns as usize;
        // Highest precedence first (the authors assign the cases in the reverse order).
        let all = near(gray, long_run)
            && near(gray, xor4)
            && near(gray, xor2)
            && near(long_run, xor4)
            && near(long_run, xor2)
            && near(xor4, xor2);
        if all {
            Some(long_run)
        } else if near(xor4, gray) {
            Some(xor4)
        } else if near(xor4, long_run) {
            Some(long_run)
        } else if near(xor2, gray) {
            Some(xor2)
        } else if near(xor2, long_run) || near(gray, long_run) {
            Some(long_run)
        } else if near(xor2, xor4) {
            Some(xor4)
        } else {
            None
        }
    }
}

impl PatternSequence for CodeEnsemblePlan {
    fn projector_columns(&self) -> u16 {
        self.projector_columns
    }

    fn frame_count(&self) -> usize {
        self.sequence_len()
    }

    fn frame_intensity(&self, frame: usize, column: u32) -> f32 {
        if column >= self.projector_columns as u32 {
            return 0.0;
        }
        let Some((code, bit, inverse)) = self.frame(frame) else {
            return 0.0;
        };
        let lit = (code.patterns(self.codeword_of(column)) >> bit) & 1 == 1;
        (lit != inverse) as u8 as f32
    }

    fn fingerprint(&self) -> u64 {
        CodeEnsemblePlan::fingerprint(self)
    }

    fn pattern_fingerprint(&self) -> u64 {
        CodeEnsemblePlan::pattern_fingerprint(self)
    }
}

impl PixelDecoder for CodeEnsemblePlan {
    /// The mean of every code's `pattern − inverse` differences.
    fn dark_amplitude_noise_dn(&self, bit_depth: u8) -> f32 {
        let sample = sample_noise_dn(&self.sensor, bit_depth, 0.0);
        amplitude_noise_dn(sample, CODES.len() * BITS)
    }

    /// One candidate (the agreed column, the mean `|pattern − inverse|`), or none when the
    /// pixel is dark, no two codes agree, or the agreed column is outside `range`.
    fn decode_pixel<const K: usize>(
        &self,
        samples: impl Fn(usize) -> u16,
        saturation: u16,
        range: &ColumnRange,
        out: &mut PixelCandidates<K>,
    ) {
        out.clear();
        let mut index = [0usize; 4];
        let mut contrast = 0u32;
        let mut saturated = false;
        for (c, code) in CODES.iter().enumerate() {
            let mut bits = 0u16;
            for bit in 0..BITS {
                let frame = c * FRAMES_PER_CODE + 2 * bit;
                let (pattern, inverse) = (samples(frame), samples(frame + 1));
                saturated |= pattern >= saturation || inverse >= saturation;
                contrast += pattern.abs_diff(inverse) as u32;
                bits |= ((pattern > inverse) as u16) << bit;
            }
            index[c] = code.index(bits);
        }
        if saturated {
            out.flags.insert(PixelFlags::SATURATED);
        }
        let contrast = contrast as f32 / (CODES.len() * BITS) as f32;
        if contrast <= self.min_contrast_dn {
            return;
        }
        let Some(column) = self.agreed(index).and_then(|k| self.column_of(k)) else {
            return;
        };
        offer_light(out, range, column, contrast);
    }
}
