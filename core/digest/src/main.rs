//! Prints a digest of every candidate decoded from a fixed synthetic workload.
//!
//! Candidates must be bit-identical in every build profile and on every machine (SPEC §6, the
//! firmware cross-check). `cargo test --workspace` runs this program as built for the tests and
//! compares its output with `digest.expected` (`tests/expected.rs`); CI also runs the release
//! build (`cargo run --release -p fsm-digest`) and compares. Each plan's row is also decoded 1,
//! 4, 8 and 16 lanes at a time, and the program fails unless every lane count gives the same
//! candidates, unless each pixel's strong light is among its candidates (85% of the pixels of
//! every plan) and unless there are at least as many candidates as pixels. A change of the
//! decoder's output changes the digest, and `digest.expected` is then updated on purpose, in
//! the same commit, saying why (`cargo run -q -p fsm-digest > core/digest/digest.expected`).

use fsm_core::{Decoder, GroupCount, PixelCandidates, Row, ScanPlan, Window};

/// FNV-1a, 64 bit.
struct Digest(u64);

impl Digest {
    fn bytes(&mut self, bytes: &[u8]) {
        for b in bytes {
            self.0 ^= *b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// A row of `width` pixels lit by one or two columns, with integer pseudo-noise; with each
/// pixel's lights (the first straddles columns `a` and `a + 1`: its centre is `a + 0.28`).
fn row(plan: &ScanPlan, width: usize, seed: u64) -> (Vec<u16>, Vec<[Option<f32>; 2]>) {
    let mut state = seed;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 33) as u32
    };
    let cmax = plan.projector_columns as u32;
    let mut frames = vec![0u16; plan.sequence_len() * width];
    let mut lights = Vec::with_capacity(width);
    for x in 0..width {
        let a = 2 + next() % (cmax - 4);
        let b = (x % 3 == 0).then(|| 2 + next() % (cmax - 4));
        lights.push([Some(a as f32 + 700.0 / 2500.0), b.map(|b| b as f32)]);
        for (i, p) in plan.sequence().enumerate() {
            let mut v = 90.0 + 1800.0 * plan.intensity(p, a) + 700.0 * plan.intensity(p, a + 1);
            if let Some(b) = b {
                v += 900.0 * plan.intensity(p, b);
            }
            let noise = (next() % 7) as f32 - 3.0;
            frames[i * width + x] = (v + noise).round().clamp(0.0, 4095.0) as u16;
        }
    }
    (frames, lights)
}

fn main() {
    let mut hann = ScanPlan::paper_efsm(GroupCount::Two).with_clean();
    hann.decoding.window = Window::Hann;
    let plans = [
        ScanPlan::paper_bfsm(),
        ScanPlan::paper_efsm(GroupCount::Two),
        ScanPlan::paper_efsm(GroupCount::One),
        ScanPlan::paper_bfsm().with_clean(),
        hann,
        ScanPlan::paper_efsm(GroupCount::Two).with_local_maxima(),
    ];
    let mut digest = Digest(0xcbf2_9ce4_8422_2325);
    let (mut count, mut pixels) = (0, 0);
    for (n, plan) in plans.iter().enumerate() {
        // Not a multiple of the lane counts: every count ends with a partial chunk.
        let width = 61;
        let (frames, lights) = row(plan, width, n as u64 + 1);
        let mut tables = vec![0.0; Decoder::tables_len(plan)];
        let decoder = Decoder::new(plan, &mut tables).expect("preset is valid");
        let row = Row {
            frames: &frames,
            width,
            bit_depth: 12,
            column_limits: None,
        };
        let out = decode::<1>(&decoder, &row);
        for (lanes, other) in [
            (4, decode::<4>(&decoder, &row)),
            (8, decode::<8>(&decoder, &row)),
            (16, decode::<16>(&decoder, &row)),
            (0, decode_default(&decoder, &row)),
        ] {
            assert!(
                other == out,
                "plan {n}: {lanes} lanes (0: the default) differ from one lane"
            );
        }
        // The digest says the profiles agree; the lights say the candidates are right: the
        // strong light of every pixel within half a column.
        let found = out
            .iter()
            .zip(&lights)
            .filter(|(p, [a, _])| {
                let a = a.expect("every pixel has its strong light");
                p.candidates.iter().any(|c| (c.column - a).abs() <= 0.5)
            })
            .count();
        println!("plan {n}: strong light found in {found} of {width} pixels");
        // EFSM with one group aliases some lights modulo the block width (55 of 61 here).
        assert!(
            100 * found >= 85 * width,
            "plan {n}: the strong light in only {found} of {width} pixels"
        );
        pixels += width;
        for p in &out {
            digest.bytes(&[p.flags.0]);
            digest.bytes(&p.noise_dn.to_bits().to_le_bytes());
            for c in &p.candidates {
                digest.bytes(&c.column.to_bits().to_le_bytes());
                digest.bytes(&c.amplitude.to_bits().to_le_bytes());
                digest.bytes(&[c.groups.0, c.group.number(), c.peak]);
                digest.bytes(&c.block.to_le_bytes());
                count += 1;
            }
        }
    }
    // Every pixel is lit: fewer candidates than pixels means lights went missing, whatever
    // the profiles agree on.
    assert!(
        count >= pixels,
        "{count} candidates for {pixels} lit pixels"
    );
    println!("{count} candidates, digest {:016x}", digest.0);
}

fn decode<const L: usize>(decoder: &Decoder<'_>, row: &Row<'_>) -> Vec<PixelCandidates<16>> {
    let mut scratch = vec![0.0; Decoder::scratch_len_lanes::<L>(decoder.plan())];
    let mut out = vec![PixelCandidates::<16>::new(); row.width];
    decoder
        .decode_row_lanes::<L, 16>(row, &mut scratch, &mut out)
        .expect("row decodes");
    out
}

fn decode_default(decoder: &Decoder<'_>, row: &Row<'_>) -> Vec<PixelCandidates<16>> {
    let mut scratch = vec![0.0; Decoder::scratch_len(decoder.plan())];
    let mut out = vec![PixelCandidates::<16>::new(); row.width];
    decoder
        .decode_row(row, &mut scratch, &mut out)
        .expect("row decodes");
    out
}
