//! A corner as the centre of a fitted X-junction: the last step of [`detect`](super::detect).
//!
//! `cornerSubPix` ([`refine`](super::refine)) weighs mostly the pixels near the corner, on a
//! smoothed image; what the rest of the four edges say about the corner is left unused. Here
//! the image around the corner is fitted, by least squares on the raw (normalised) pixels, with
//! a model of what a camera pixel sees at a corner:
//!
//! - two edges through the corner `c`, at angles `θa` (along the board's row, lattice step `u`)
//!   and `θb` (along its column, step `v`); a pixel's signed distances from them
//!   `d = n·r − κ/2 (t·r)²` (`r` from the corner, `n`, `t` an edge's normal and direction, `κ`
//!   its bend, given: see below);
//! - each edge the step of the board's print blurred by a Gaussian of std `σ` (the optics;
//!   fitted) and averaged over the pixel's square footprint ([`PixelEdge`], in closed form):
//!   `E(d)` from −1 to 1; the light share of the pixel `P = ½ (1 + s · E(da) · E(db))`
//!   (`s` = ±1: which diagonal is light). For edges along the pixel grid this is exact; for
//!   others it errs only within a pixel of the corner, and the same way at `c ± r`;
//! - the light and the dark squares' levels each linear across the window (`L = L0 + gL · r`,
//!   `D = D0 + gD · r`): the illumination's fall-off;
//! - the pixel's value `D + (L − D) · P`.
//!
//! The window is the parallelogram `|α|, |β| ≤ 0.75` of the lattice coordinates
//! (`x = c + α u + β v`): all four squares around the corner, a quarter step short of the next
//! corners (whose edges the model does not have). Eleven parameters (`c`, `θa`, `θb`, `σ`,
//! `L0`, `gL`, `D0`, `gD`), Levenberg–Marquardt with the analytic Jacobian (its own fixed-size
//! loop, not [`refine::levenberg_marquardt`](crate::refine::levenberg_marquardt): that one's
//! numeric Jacobian would cost 22 more passes over the window per iteration, on every corner,
//! and it has no bound for the blur), started at the
//! `cornerSubPix` estimate, the levels at the means of the pixels more than 0.2 step from both
//! edges (so a window cut by the image's border still fits), the blur held at 0.05 px or more
//! (a sharp edge on a pixel border leaves no partial pixel, and the cost no gradient). The fit
//! is kept only if it converged within 1 px of its start with a blur under 4 px and some
//! contrast; [`fit`] says `None` otherwise.
//!
//! **Why the pixel's square.** An edge along the pixel grid meets every pixel along it at the
//! same phase, so a profile of the wrong shape (an erf sampled at pixel centres) does not
//! average out: it moved the corners of a board parallel to the image by up to 0.25 px.
//!
//! **Why the bend.** The lens's distortion bends the board's straight lines (`k1 = −0.06` on
//! the bench: ~3e-5 px⁻¹ 100 px from the image centre). A straight edge fitted over ±17 px of
//! a bent one is off by `κ · 17²/6` ≈ 0.0015 px, towards the image centre, the same way at
//! every corner: on the bench, the corners of each board were pulled in by 13 ppm, i.e. a
//! scale error. Fitting `κ` per corner removes it but raises the noise by half. So [`detect`] fits
//! twice: first with straight edges, then with each edge bent as its whole grid line of corners
//! is ([`bends`]: a polynomial through 6–9 corners, ~1e-6 px⁻¹ uncertain).
//!
//! Measured on the simulator's bench, the white frames of the 17 poses of
//! `tests/end_to_end.rs`, RMS distance from the true corners (`cornerSubPix` alone in
//! brackets): with 16 × 16 rays per pixel, 0.0014 px without sensor noise (0.011) and 0.0031 px
//! with the default sensor (0.019); with the renderer's default 4 × 4 rays 0.0084 px (0.026),
//! where the renderer's own ray sampling of the edges, not the sensor, is most of the error.

use nalgebra::{Point2, SMatrix, SVector, Vector2};

use super::Image;

/// Half-size of the fitted window, lattice steps.
const WINDOW_STEPS: f64 = 0.75;
/// Pixels farther than this from both edges, lattice steps, start the levels.
const INNER_STEPS: f64 = 0.2;
/// Least blur fitted, px.
const MIN_BLUR_PX: f64 = 0.05;
/// Fewest pixels a window must hold.
const MIN_PIXELS: usize = 60;
/// Parameters: `δc` (2, from the start), `θa`, `θb`, `σ`, `L0`, `gL` (2), `D0`, `gD` (2).
const N: usize = 11;

type Params = SVector<f64, N>;

/// One pixel of the window: its offset from the starting corner and its value.
struct Pixel {
    r0: Vector2<f64>,
    value: f64,
}

/// A blurred edge as one pixel sees it: the mean of `E = erf(d / (√2 σ))` over the pixel's
/// square footprint, whose distances from an edge of normal `n` spread as the sum of two
/// uniform variables of widths `|nx|` and `|ny|`. With `Φ` the normal distribution,
/// `G = ∫Φ = xΦ + φ` and `H = ∫G = ½((x² + 1)Φ + xφ)`, the mean of `Φ((d + a + b)/σ)` is
/// `σ²/(w1 w2) · Σ ±H((d ± w1/2 ± w2/2)/σ)` (and `σ/w1 · ΔG` when `w2 → 0`: an edge along
/// the pixel grid); [`PixelEdge::mean`] gives it with its derivatives in `d`, `θ` (the
/// normal's angle, through the widths) and `σ`.
#[derive(Clone, Copy, Debug)]
struct PixelEdge {
    /// The wider and the narrower spread, px, and their derivatives in `θ`.
    w1: f64,
    dw1: f64,
    w2: f64,
    dw2: f64,
    sigma: f64,
}

impl PixelEdge {
    /// The edge whose normal is at angle `θ` (`(−sin θ, cos θ)`), blurred by `σ` px.
    fn new(theta: f64, sigma: f64) -> PixelEdge {
        let (st, ct) = theta.sin_cos();
        let (ws, dws) = (st.abs(), st.signum() * ct);
        let (wc, dwc) = (ct.abs(), -ct.signum() * st);
        let ((w1, dw1), (w2, dw2)) = if ws >= wc {
            ((ws, dws), (wc, dwc))
        } else {
            ((wc, dwc), (ws, dws))
        };
        PixelEdge {
            w1,
            dw1,
            w2,
            dw2,
            sigma,
        }
    }

    /// The mean of `E` over the pixel at distance `d` px, and its derivatives in `d`, `θ` and
    /// `σ`.
    fn mean(&self, d: f64) -> [f64; 4] {
        let PixelEdge {
            w1,
            dw1,
            w2,
            dw2,
            sigma,
        } = *self;
        let phi = |x: f64| (-0.5 * x * x).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let cdf = |x: f64| 0.5 * libm::erfc(-x / std::f64::consts::SQRT_2);
        let g = |x: f64| x * cdf(x) + phi(x);
        let h = |x: f64| 0.5 * ((x * x + 1.0) * cdf(x) + x * phi(x));
        // Beyond the footprint's reach plus 8σ the mean is ±1 to 1e-15: most pixels of a window.
        if d.abs() > 0.5 * (w1 + w2) + 8.0 * sigma {
            return [d.signum(), 0.0, 0.0, 0.0];
        }
        let (f, df_dd, df_dw1, df_dw2, df_ds) = if w2 < 1e-4 {
            let (x1, x2) = ((d + 0.5 * w1) / sigma, (d - 0.5 * w1) / sigma);
            let f = sigma / w1 * (g(x1) - g(x2));
            let df_dd = (cdf(x1) - cdf(x2)) / w1;
            let df_dw1 = -f / w1 + 0.5 * (cdf(x1) + cdf(x2)) / w1;
            // d/dσ of σ·G(x/σ) is G − x·Φ = φ.
            let df_ds = (phi(x1) - phi(x2)) / w1;
            (f, df_dd, df_dw1, 0.0, df_ds)
        } else {
            let (k1, k2) = (0.5 * w1, 0.5 * w2);
            let xs = [
                (d + k1 + k2) / sigma,
                (d + k1 - k2) / sigma,
                (d - k1 + k2) / sigma,
                (d - k1 - k2) / sigma,
            ];
            let sign = [1.0, -1.0, -1.0, 1.0];
            let norm = sigma * sigma / (w1 * w2);
            let f = norm * (0..4).map(|i| sign[i] * h(xs[i])).sum::<f64>();
            let gs = xs.map(g);
            let df_dd = norm / sigma * (0..4).map(|i| sign[i] * gs[i]).sum::<f64>();
            let df_dw1 = -f / w1 + 0.5 * norm / sigma * (gs[0] - gs[1] + gs[2] - gs[3]);
            let df_dw2 = -f / w2 + 0.5 * norm / sigma * (gs[0] + gs[1] - gs[2] - gs[3]);
            let df_ds = 2.0 * f / sigma
                - norm / sigma * (0..4).map(|i| sign[i] * xs[i] * gs[i]).sum::<f64>();
            (f, df_dd, df_dw1, df_dw2, df_ds)
        };
        [
            2.0 * f - 1.0,
            2.0 * df_dd,
            2.0 * (df_dw1 * dw1 + df_dw2 * dw2),
            2.0 * df_ds,
        ]
    }
}

/// The junction model at one pixel.
struct Junction {
    /// Sign of each edge's normal: `da > 0` on the `+v` side of edge `a`, `db > 0` on the `+u`
    /// side of edge `b`.
    sign_a: f64,
    sign_b: f64,
    /// +1 when the squares at `+u + v` and `−u − v` are the light ones.
    s: f64,
    /// Curvature of each edge, 1/px, towards its normal `±n`: `d = n·r − κ/2 (t·r)²`.
    curvature_a: f64,
    curvature_b: f64,
}

/// What the model's value at every pixel shares for one parameter vector.
struct Edges {
    /// Signed normals and directions of the edges.
    na: Vector2<f64>,
    nb: Vector2<f64>,
    ta: Vector2<f64>,
    tb: Vector2<f64>,
    a: PixelEdge,
    b: PixelEdge,
}

impl Junction {
    fn edges(&self, p: &Params) -> Edges {
        let (sa, ca) = p[2].sin_cos();
        let (sb, cb) = p[3].sin_cos();
        Edges {
            na: Vector2::new(-sa, ca) * self.sign_a,
            nb: Vector2::new(-sb, cb) * self.sign_b,
            ta: Vector2::new(ca, sa),
            tb: Vector2::new(cb, sb),
            a: PixelEdge::new(p[2], p[4]),
            b: PixelEdge::new(p[3], p[4]),
        }
    }

    /// The model's value at `px` (`e` = `self.edges(p)`) and, with `jac`, its gradient in the
    /// parameters.
    fn value(&self, p: &Params, e: &Edges, px: &Pixel, jac: Option<&mut Params>) -> f64 {
        let r = px.r0 - Vector2::new(p[0], p[1]);
        let Edges { na, nb, ta, tb, .. } = *e;
        // The edges as parabolas through the corner (the lens's distortion bends them):
        // d = n·r − κ/2 (t·r)², t the edge's direction.
        let (ua, ub) = (ta.dot(&r), tb.dot(&r));
        let (ka, kb) = (self.curvature_a, self.curvature_b);
        let da = na.dot(&r) - 0.5 * ka * ua * ua;
        let db = nb.dot(&r) - 0.5 * kb * ub * ub;
        let [ea, dea_dd, dea_dt, dea_ds] = e.a.mean(da);
        let [eb, deb_dd, deb_dt, deb_ds] = e.b.mean(db);
        let share = 0.5 * (1.0 + self.s * ea * eb);
        let light = p[5] + p[6] * r.x + p[7] * r.y;
        let dark = p[8] + p[9] * r.x + p[10] * r.y;
        if let Some(j) = jac {
            let half = 0.5 * self.s * (light - dark);
            // r = r0 − δc: dd/dδc = −n, dL/dδc = −gL, dD/dδc = −gD.
            let gl = Vector2::new(p[6], p[7]);
            let gd = Vector2::new(p[9], p[10]);
            let (dda_dr, ddb_dr) = (na - ka * ua * ta, nb - kb * ub * tb);
            let dc = -half * (dea_dd * eb * dda_dr + ea * deb_dd * ddb_dr)
                - gl * share
                - gd * (1.0 - share);
            j[0] = dc.x;
            j[1] = dc.y;
            // dn/dθ = −t (times the sign), dt/dθ = the unsigned normal; the widths of the
            // pixel's spread move with θ too.
            let dda = -(ta * self.sign_a).dot(&r) - ka * ua * (na * self.sign_a).dot(&r);
            let ddb = -(tb * self.sign_b).dot(&r) - kb * ub * (nb * self.sign_b).dot(&r);
            j[2] = half * (dea_dd * dda + dea_dt) * eb;
            j[3] = half * ea * (deb_dd * ddb + deb_dt);
            j[4] = half * (dea_ds * eb + ea * deb_ds);
            j[5] = share;
            j[6] = share * r.x;
            j[7] = share * r.y;
            j[8] = 1.0 - share;
            j[9] = (1.0 - share) * r.x;
            j[10] = (1.0 - share) * r.y;
        }
        dark + (light - dark) * share
    }

    fn cost(&self, p: &Params, pixels: &[Pixel]) -> f64 {
        let e = self.edges(p);
        pixels
            .iter()
            .map(|px| (self.value(p, &e, px, None) - px.value).powi(2))
            .sum()
    }
}

/// The corner near `start` (lattice steps `u`, `v` there; `bend` the second derivatives, px⁻¹,
/// of the board's row and column lines through it, from [`bends`]) as the centre of the fitted
/// junction, or `None` when the fit fails its checks (module docs). The window may be cut by
/// the image's border: the levels and which diagonal is light are taken from the pixels it
/// holds, well inside the squares.
pub(super) fn fit(
    image: &Image,
    start: Point2<f64>,
    u: Vector2<f64>,
    v: Vector2<f64>,
    bend: [Vector2<f64>; 2],
) -> Option<Point2<f64>> {
    let lattice = nalgebra::Matrix2::from_columns(&[u, v]);
    let to_lattice = lattice.try_inverse()?;
    let reach = WINDOW_STEPS * (u.abs() + v.abs());
    let (x0, x1) = (
        (start.x - reach.x).floor().max(0.0) as usize,
        ((start.x + reach.x).ceil() as usize).min(image.w - 1),
    );
    let (y0, y1) = (
        (start.y - reach.y).floor().max(0.0) as usize,
        ((start.y + reach.y).ceil() as usize).min(image.h - 1),
    );
    let mut pixels = Vec::with_capacity((x1 + 1 - x0) * (y1 + 1 - y0));
    // Sums and counts of the values well inside the squares on the `+u + v`, `−u − v`
    // diagonal and on the other one.
    let mut inside = [(0.0, 0usize); 2];
    for y in y0..=y1 {
        for x in x0..=x1 {
            let r0 = Vector2::new(x as f64 - start.x, y as f64 - start.y);
            let ab = to_lattice * r0;
            if ab.x.abs() <= WINDOW_STEPS && ab.y.abs() <= WINDOW_STEPS {
                let value = image.at(x, y) as f64;
                if ab.x.abs() >= INNER_STEPS && ab.y.abs() >= INNER_STEPS {
                    let k = usize::from(ab.x * ab.y < 0.0);
                    inside[k].0 += value;
                    inside[k].1 += 1;
                }
                pixels.push(Pixel { r0, value });
            }
        }
    }
    if pixels.len() < MIN_PIXELS || inside.iter().any(|&(_, n)| n == 0) {
        return None;
    }
    let (plus, minus) = (
        inside[0].0 / inside[0].1 as f64,
        inside[1].0 / inside[1].1 as f64,
    );
    let (light, dark) = (plus.max(minus), plus.min(minus));
    let (theta_a, theta_b) = (u.y.atan2(u.x), v.y.atan2(v.x));
    let normal = |t: f64| Vector2::new(-t.sin(), t.cos());
    let (sign_a, sign_b) = (
        normal(theta_a).dot(&v).signum(),
        normal(theta_b).dot(&u).signum(),
    );
    let model = Junction {
        sign_a,
        sign_b,
        s: if plus >= minus { 1.0 } else { -1.0 },
        curvature_a: bend[0].dot(&(normal(theta_a) * sign_a)),
        curvature_b: bend[1].dot(&(normal(theta_b) * sign_b)),
    };
    let mut p = Params::from_column_slice(&[
        0.0, 0.0, theta_a, theta_b, 0.6, light, 0.0, 0.0, dark, 0.0, 0.0,
    ]);
    let mut cost = model.cost(&p, &pixels);
    let mut lambda = 1e-3;
    let mut converged = false;
    for _ in 0..100 {
        let mut jtj = SMatrix::<f64, N, N>::zeros();
        let mut jtr = Params::zeros();
        let mut j = Params::zeros();
        let edges = model.edges(&p);
        for px in &pixels {
            let res = model.value(&p, &edges, px, Some(&mut j)) - px.value;
            jtj.syger(1.0, &j, &j, 1.0);
            jtr.axpy(res, &j, 1.0);
        }
        jtj.fill_upper_triangle_with_lower_triangle();
        // The blur has a floor (a sharp edge on a pixel border has no partial pixel, and its
        // cost no gradient): at the floor, and pushing below it, the blur is held.
        if p[4] <= MIN_BLUR_PX && jtr[4] > 0.0 {
            for i in 0..N {
                jtj[(4, i)] = 0.0;
                jtj[(i, 4)] = 0.0;
            }
            jtj[(4, 4)] = 1.0;
            jtr[4] = 0.0;
        }
        let before = cost;
        let accepted = loop {
            let mut a = jtj;
            for i in 0..N {
                a[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
            }
            if let Some(step) = a.cholesky().map(|c| c.solve(&-jtr)) {
                let mut next = p + step;
                next[4] = next[4].max(MIN_BLUR_PX);
                let next_cost = model.cost(&next, &pixels);
                if next_cost <= cost {
                    p = next;
                    cost = next_cost;
                    lambda = (lambda / 3.0).max(1e-9);
                    break true;
                }
            }
            lambda *= 4.0;
            if lambda > 1e9 {
                break false;
            }
        };
        // Done when no step lowers the cost, or the last one lowered it by a part in 10¹⁰.
        if !accepted || before - cost <= 1e-10 * before {
            converged = true;
            break;
        }
    }
    let moved = Vector2::new(p[0], p[1]);
    let sane = converged
        && moved.norm() < 1.0
        && p[4] < 4.0
        && p[5] - p[8] > 0.02
        && (p[2] - theta_a).abs() < 0.3
        && (p[3] - theta_b).abs() < 0.3;
    sane.then(|| start + moved)
}

/// The bend of a grid line at each of its corners (in order along the line): the second
/// derivative of the line, px⁻¹, as a vector along its normal, from a polynomial fitted to the
/// corners (cubic with 6 corners or more, quadratic with 3–5; zero with 2). A straight line
/// stays straight in a pinhole camera, so the bend is the lens's distortion; 0.01 px of corner
/// noise leaves it uncertain by ~1e-6 px⁻¹ on the bench's 9-corner rows, against a bend of
/// ~3e-5 px⁻¹ 100 px from the image centre at `k1 = −0.06`.
pub(super) fn bends(corners: &[Point2<f64>]) -> Vec<Vector2<f64>> {
    let n = corners.len();
    let degree = match n {
        0..=2 => return vec![Vector2::zeros(); n],
        3..=5 => 2,
        _ => 3,
    };
    let chord = corners[n - 1] - corners[0];
    let length = chord.norm();
    if length <= 0.0 {
        return vec![Vector2::zeros(); n];
    }
    let t_dir = chord / length;
    let normal = Vector2::new(-t_dir.y, t_dir.x);
    // Along the chord in units of its length (conditioning), across it in px.
    let ts: Vec<f64> = corners
        .iter()
        .map(|p| (p - corners[0]).dot(&t_dir) / length)
        .collect();
    let vander = nalgebra::DMatrix::from_fn(n, degree + 1, |i, k| ts[i].powi(k as i32));
    let across =
        nalgebra::DVector::from_iterator(n, corners.iter().map(|p| (p - corners[0]).dot(&normal)));
    let Ok(coef) = vander.svd(true, true).solve(&across, 1e-12) else {
        return vec![Vector2::zeros(); n];
    };
    ts.iter()
        .map(|&t| {
            let second = 2.0 * coef[2] + if degree == 3 { 6.0 * coef[3] * t } else { 0.0 };
            normal * (second / (length * length))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::{refine, Gradient, Shading, REFINE_SMOOTHING_PX};
    use super::*;
    use std::f64::consts::{FRAC_PI_2, SQRT_2};

    /// Area of the unit pixel square centred at `centre` on the side `n·(p − o) ≥ 0` of each
    /// half-plane `(n, o)` (Sutherland–Hodgman clipping).
    fn clipped_area(centre: Vector2<f64>, planes: &[(Vector2<f64>, Vector2<f64>)]) -> f64 {
        let mut poly: Vec<Vector2<f64>> = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
            .iter()
            .map(|&(x, y)| centre + Vector2::new(x, y))
            .collect();
        for (n, o) in planes {
            let side = |p: &Vector2<f64>| n.dot(&(p - o));
            let mut out = Vec::new();
            for i in 0..poly.len() {
                let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
                let (sa, sb) = (side(&a), side(&b));
                if sa >= 0.0 {
                    out.push(a);
                }
                if (sa >= 0.0) != (sb >= 0.0) {
                    out.push(a + (b - a) * (sa / (sa - sb)));
                }
            }
            poly = out;
            if poly.is_empty() {
                return 0.0;
            }
        }
        let mut twice = 0.0;
        for i in 0..poly.len() {
            let (a, b) = (poly[i], poly[(i + 1) % poly.len()]);
            twice += a.x * b.y - b.x * a.y;
        }
        0.5 * twice.abs()
    }

    /// A 64 × 64 X-junction at `c` of straight edges at angles `t1`, `t2`, each pixel its exact
    /// area share of each colour (dark 0.05, light 0.85), lit with a relative gradient `gain`
    /// per px along x, plus Gaussian noise of std `noise` (seeded).
    fn exact_junction(
        c: Point2<f64>,
        t1: f64,
        t2: f64,
        gain: f64,
        noise: f64,
        seed: u64,
    ) -> Vec<f32> {
        let (a, b) = (
            Vector2::new(-t1.sin(), t1.cos()),
            Vector2::new(-t2.sin(), t2.cos()),
        );
        let mut state = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let mut uniform = move || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let mut out = vec![0.0f32; 64 * 64];
        for y in 0..64 {
            for x in 0..64 {
                let p = Vector2::new(x as f64, y as f64);
                let o = c.coords;
                let light =
                    clipped_area(p, &[(a, o), (b, o)]) + clipped_area(p, &[(-a, o), (-b, o)]);
                let gauss =
                    (-2.0 * uniform().ln()).sqrt() * (2.0 * std::f64::consts::PI * uniform()).cos();
                let albedo = 0.05 + 0.8 * light;
                out[y * 64 + x] = (albedo * (1.0 + gain * (x as f64 - c.x)) + noise * gauss) as f32;
            }
        }
        out
    }

    /// The straight-edge fit of a 64 × 64 junction at angles `t1`, `t2` from `start`.
    fn fit_at(image: &[f32], t1: f64, t2: f64, start: Point2<f64>) -> Option<Point2<f64>> {
        let image = Image::normalised(image, 64, 64).unwrap();
        let u = Vector2::new(t1.cos(), t1.sin()) * 24.0;
        let v = Vector2::new(t2.cos(), t2.sin()) * 24.0;
        fit(&image, start, u, v, [Vector2::zeros(); 2])
    }

    /// The closed form against the mean of `erf` over 256 × 256 points of the pixel, along the
    /// pixel grid (`w2 = 0`), at 45° and between, for sharp and for blurred edges.
    #[test]
    fn pixel_edge_is_the_mean_over_the_pixel() {
        let k = 256;
        for theta in [
            0.0,
            0.1,
            0.25 * std::f64::consts::PI,
            1.2,
            FRAC_PI_2,
            2.8,
            -0.4,
        ] {
            let n = Vector2::new(-f64::sin(theta), theta.cos());
            for sigma in [0.02, 0.3, 1.0] {
                for d in [-1.3, -0.4, -0.05, 0.0, 0.2, 0.6, 1.1] {
                    let mut sum = 0.0;
                    for i in 0..k {
                        for j in 0..k {
                            let o = Vector2::new(
                                (i as f64 + 0.5) / k as f64 - 0.5,
                                (j as f64 + 0.5) / k as f64 - 0.5,
                            );
                            sum += libm::erf((d + n.dot(&o)) / (SQRT_2 * sigma));
                        }
                    }
                    let want = sum / (k * k) as f64;
                    let got = PixelEdge::new(theta, sigma).mean(d)[0];
                    // The sampled mean of a sharp edge is itself off by up to 1/k.
                    let tol = if sigma < 0.1 { 2.0 / k as f64 } else { 1e-4 };
                    assert!(
                        (got - want).abs() < tol,
                        "θ {theta}, σ {sigma}, d {d}: {got} against {want}"
                    );
                }
            }
        }
    }

    /// The analytic Jacobian against central differences, including the bends and an edge
    /// nearly along the pixel grid.
    #[test]
    fn model_gradient_matches_finite_differences() {
        let model = Junction {
            sign_a: 1.0,
            sign_b: -1.0,
            s: 1.0,
            curvature_a: 0.01,
            curvature_b: -0.02,
        };
        for angles in [(0.3, 1.9), (0.001, 1.5)] {
            let p = Params::from_column_slice(&[
                0.1, -0.2, angles.0, angles.1, 0.4, 0.8, 0.01, -0.02, 0.1, 0.003, 0.004,
            ]);
            for r0 in [
                Vector2::new(0.3, 0.5),
                Vector2::new(-1.2, 0.4),
                Vector2::new(2.0, -0.1),
            ] {
                let px = Pixel { r0, value: 0.0 };
                let mut j = Params::zeros();
                model.value(&p, &model.edges(&p), &px, Some(&mut j));
                for i in 0..N {
                    let (mut hi, mut lo) = (p, p);
                    hi[i] += 1e-6;
                    lo[i] -= 1e-6;
                    let at = |q: &Params| model.value(q, &model.edges(q), &px, None);
                    let fd = (at(&hi) - at(&lo)) / 2e-6;
                    assert!(
                        (j[i] - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                        "{angles:?} {r0:?} parameter {i}: {} against {fd}",
                        j[i]
                    );
                }
            }
        }
    }

    /// Exactly integrated junctions at any sub-pixel phase, with their edges along the pixel
    /// grid (where a wrong pixel profile biases most), rolled and sheared, under uniform and
    /// graded light: the fit lands on the corner.
    #[test]
    fn fit_finds_exact_junctions_at_any_phase() {
        let mut worst = 0.0f64;
        for gain in [0.0, 0.003] {
            for (t1, t2) in [
                (0.0, FRAC_PI_2),
                (0.1, 1.6),
                (0.3, 1.5),
                (0.2, 1.1),
                (-0.4, 0.9),
                (0.05, 2.2),
            ] {
                for (ox, oy) in [
                    (0.0, 0.0),
                    (0.25, 0.5),
                    (0.5, 0.125),
                    (0.81, 0.13),
                    (0.375, 0.875),
                ] {
                    let c = Point2::new(31.0 + ox, 30.0 + oy);
                    let image = exact_junction(c, t1, t2, gain, 0.0, 0);
                    let start = Point2::new(31.2, 30.3);
                    let q = fit_at(&image, t1, t2, start)
                        .unwrap_or_else(|| panic!("no fit at {c} ({t1}, {t2})"));
                    worst = worst.max((q - c).norm());
                }
            }
        }
        eprintln!("exact junctions: worst error {worst:.5} px");
        // Measured: 0.0035 px, at the most sheared junctions (edges 123° apart: the product
        // form near the corner).
        assert!(worst < 0.004, "worst {worst} px");
    }

    /// With 1% noise on the contrast, the fit's error against `cornerSubPix`'s on the same
    /// images (20 noisy images × 6 junctions). Measured: 0.0026 px against 0.0151 px RMS.
    #[test]
    fn fit_beats_corner_sub_pix_under_noise() {
        let (mut fit_sq, mut sub_sq, mut n) = (0.0, 0.0, 0);
        for seed in 0..20u64 {
            for (t1, t2) in [(0.0, FRAC_PI_2), (0.3, 1.5), (-0.4, 0.9)] {
                for (ox, oy) in [(0.3, 0.7), (0.5, 0.5)] {
                    let c = Point2::new(31.0 + ox, 30.0 + oy);
                    let raw = exact_junction(c, t1, t2, 0.0, 0.008, seed);
                    let image = Image::normalised(&raw, 64, 64).unwrap();
                    let smooth = image.gaussian(REFINE_SMOOTHING_PX);
                    let grad = Gradient::of(&smooth);
                    let u = Vector2::new(t1.cos(), t1.sin()) * 24.0;
                    let v = Vector2::new(t2.cos(), t2.sin()) * 24.0;
                    let shading = Shading::around(&image, c, u, v).unwrap();
                    let start = Point2::new(31.0, 30.0);
                    let sub = refine(&grad, &smooth, start, 18.0, Some(&shading)).unwrap();
                    let q = fit(&image, sub, u, v, [Vector2::zeros(); 2]).unwrap();
                    fit_sq += (q - c).norm_squared();
                    sub_sq += (sub - c).norm_squared();
                    n += 1;
                }
            }
        }
        let (fit_rms, sub_rms) = ((fit_sq / n as f64).sqrt(), (sub_sq / n as f64).sqrt());
        eprintln!("1% noise: fit {fit_rms:.4} px, cornerSubPix {sub_rms:.4} px RMS");
        assert!(
            fit_rms < 0.5 * sub_rms,
            "fit {fit_rms}, cornerSubPix {sub_rms}"
        );
    }

    /// Edges bent by 3e-4 px⁻¹ (ten times the bench lens's bend at 100 px from the centre),
    /// each pixel sampled at 64 × 64 points: fitted as straight the corner is off by about
    /// `κ · R²/6`; given the bend, it is on the corner.
    #[test]
    fn bent_edges_need_their_bend() {
        let (t1, t2, kappa): (f64, f64, f64) = (0.3, 1.9, 3e-4);
        let c = Point2::new(31.4, 30.7);
        let (ta, tb) = (
            Vector2::new(t1.cos(), t1.sin()),
            Vector2::new(t2.cos(), t2.sin()),
        );
        let (na, nb) = (
            Vector2::new(-t1.sin(), t1.cos()),
            Vector2::new(-t2.sin(), t2.cos()),
        );
        let image = super::super::tests::bent_junction(c, t1, t2, 0.0, kappa, 64);
        let image = Image::normalised(&image, 64, 64).unwrap();
        let (u, v) = (ta * 24.0, tb * 24.0);
        let start = Point2::new(31.0, 31.0);
        let straight = fit(&image, start, u, v, [Vector2::zeros(); 2]).unwrap();
        let bent = fit(&image, start, u, v, [na * kappa, nb * kappa]).unwrap();
        let (e_straight, e_bent) = ((straight - c).norm(), (bent - c).norm());
        eprintln!("bent edges: straight fit {e_straight:.4} px off, bent fit {e_bent:.4} px");
        assert!(e_straight > 0.01, "straight fit {e_straight} px off");
        assert!(e_bent < 0.002, "bent fit {e_bent} px off");
    }

    /// The bend of a line of corners: a parabola's second derivative, unevenly spaced as
    /// perspective spaces corners, with 9 corners (cubic) and 4 (quadratic); zero for a
    /// straight line and for two corners.
    #[test]
    fn bends_of_bent_and_straight_lines() {
        let dir = Vector2::new(0.96, 0.28);
        let normal = Vector2::new(-dir.y, dir.x);
        let origin = Point2::new(40.0, 60.0);
        for count in [9, 4] {
            let ts: Vec<f64> = (0..count)
                .map(|i| 200.0 * i as f64 / (count as f64 + 0.3 * i as f64))
                .collect();
            let bent: Vec<Point2<f64>> = ts
                .iter()
                .map(|&t| origin + dir * t + normal * (2e-5 * t * t))
                .collect();
            for b in bends(&bent) {
                assert!((b - normal * 4e-5).norm() < 4e-7, "{count} corners: {b:?}");
            }
            let straight: Vec<Point2<f64>> = ts.iter().map(|&t| origin + dir * t).collect();
            for b in bends(&straight) {
                assert!(b.norm() < 1e-12, "{count} corners: {b:?}");
            }
        }
        assert_eq!(bends(&[origin, origin + dir]), vec![Vector2::zeros(); 2]);
    }
}
