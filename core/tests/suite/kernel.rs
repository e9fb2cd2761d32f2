//! The decoder's modelled spectrum of a lit column (SPEC §2) against a direct f64 DFT, and
//! against the spectrum the decoder computes from frames rendered with the plan's own pattern
//! function: the three cannot disagree.

use crate::support;

use fsm_core::{Decoder, Group, GroupCount, Row, ScanPlan, Window};
use support::Pixel;

/// `(1/Σh) Σ_m h_m (z_m − z̄) e^{−i2πkm/N}` for `z_m = cos(2π f_m j)`, in f64.
fn direct_dft(plan: &ScanPlan, column: u32, bin: usize) -> (f64, f64) {
    let m = plan.band.count as usize;
    let n = plan.transform_size as f64;
    let z: Vec<f64> = (0..m)
        .map(|i| (std::f64::consts::TAU * plan.frequency(i as u16) * column as f64).cos())
        .collect();
    let mean = z.iter().sum::<f64>() / m as f64;
    let h = |i: usize| match plan.decoding.window {
        Window::Rectangular => 1.0,
        Window::Hann => 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / (m as f64 - 1.0)).cos(),
    };
    let sum_h: f64 = (0..m).map(h).sum();
    let (mut re, mut im) = (0.0, 0.0);
    for (i, zi) in z.iter().enumerate() {
        let a = -std::f64::consts::TAU * bin as f64 * i as f64 / n;
        re += h(i) * (zi - mean) * a.cos();
        im += h(i) * (zi - mean) * a.sin();
    }
    (re / sum_h, im / sum_h)
}

/// The DFT searches' plans (the kernel is their model of a column's spectrum).
fn plans() -> Vec<ScanPlan> {
    let mut hann = ScanPlan::paper_bfsm().with_clean();
    hann.decoding.window = Window::Hann;
    let mut efsm_hann = ScanPlan::paper_efsm(GroupCount::One).with_clean();
    efsm_hann.decoding.window = Window::Hann;
    let mut band_limited = ScanPlan::paper_bfsm().with_clean();
    band_limited.band.first_harmonic = 3;
    band_limited.band.count = 500;
    let mut padded = ScanPlan::paper_bfsm().with_clean();
    padded.transform_size = 4096;
    vec![
        ScanPlan::paper_bfsm().with_clean(),
        hann,
        band_limited,
        padded,
        ScanPlan::paper_efsm(GroupCount::One).with_clean(),
        efsm_hann,
        ScanPlan::efsm(768, 96, GroupCount::One).with_clean(),
        ScanPlan::efsm(768, 32, GroupCount::One).with_clean(),
    ]
}

#[test]
fn kernel_matches_a_direct_dft_of_the_model() {
    for plan in plans() {
        let mut tables = vec![0.0; Decoder::tables_len(&plan)];
        let decoder = Decoder::new(&plan, &mut tables).unwrap();
        let kernel = decoder.kernel().unwrap();
        let span = plan.span_columns() as u32;
        for column in [0, 1, 2, 7, span / 3, span / 2, span - 2, span - 1] {
            let terms = kernel.column_terms(column as i32);
            let mut worst: f64 = 0.0;
            for k in 0..plan.bin_count() {
                let (re, im) = direct_dft(&plan, column, k);
                let got = kernel.response(&terms, k);
                worst = worst
                    .max((got.re as f64 - re).abs())
                    .max((got.im as f64 - im).abs());
            }
            // A unit column peaks at 1/2: the model is exact to f32 rounding.
            assert!(
                worst < 2e-6,
                "{:?} window {:?} column {column}: worst {worst:e}",
                plan.method,
                plan.decoding.window
            );
        }
    }
}

#[test]
fn decoder_spectrum_of_rendered_frames_is_the_kernel_model() {
    // A 16-bit pixel lit by three columns through the plan's own pattern function: its spectrum
    // must be Σ_j w_j b_j(k) with w_j = DN · PB, up to the quantisation of the samples.
    for plan in plans() {
        let mut tables = vec![0.0; Decoder::tables_len(&plan)];
        let decoder = Decoder::new(&plan, &mut tables).unwrap();
        let span = plan.span_columns() as u32;
        let lights = [
            (span / 3, 9000.0),
            (span / 3 + 1, 20000.0),
            (span / 3 + 2, 6000.0),
        ];
        let pixel = Pixel {
            lights: lights.to_vec(),
            ambient: 500.0,
        };
        let mut noise = support::Noise::new(1);
        let samples = pixel.samples(&plan, 0.0, 16, &mut noise);
        let row = Row {
            frames: &samples,
            width: 1,
            bit_depth: 16,
            column_limits: None,
        };
        let mut scratch = vec![0.0; Decoder::scratch_len(&plan)];
        let spectrum = decoder.spectrum(&row, 0, Group::One, &mut scratch).unwrap();
        let kernel = decoder.kernel().unwrap();
        let pb = plan.levels.amplitude as f64;
        let mut worst: f64 = 0.0;
        for k in 0..spectrum.len() {
            let (mut re, mut im) = (0.0, 0.0);
            for &(j, dn) in &lights {
                let b = kernel.response(&kernel.column_terms(j as i32), k);
                re += dn * pb * b.re as f64;
                im += dn * pb * b.im as f64;
            }
            let x = spectrum.bin(k);
            worst = worst
                .max((x.re as f64 - re).abs())
                .max((x.im as f64 - im).abs());
        }
        // Rounding each sample to an integer adds at most 0.5 DN, i.e. ≤ 0.5·Σh/Σh per bin;
        // in practice its spectrum is noise of RMS sqrt(1/12 / M).
        assert!(worst < 0.2, "{:?}: worst {worst}", plan.method);
    }
}
