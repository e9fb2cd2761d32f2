//! Whether a candidate continues the surface a pixel's neighbours measured.
//!
//! A plane fitted to the depths of the points near a pixel predicts the pixel's depth; its
//! scatter about the plane (the points' noise and the surface's curvature over the window)
//! says how far a point of the same surface may lie from the prediction. A candidate within
//! [`SCATTER_FACTOR`] times that (widened by the prediction's own uncertainty, which is as
//! large as the scatter where the plane extrapolates from one side) continues the surface. A
//! wrong light is off by a fraction of a column or more, many times the noise of a point.
//!
//! The plane is trusted only where three scatters stay below `ε/4`
//! ([`LocalPlane::discriminates`]): then the light of another surface, `ε` or more away (the
//! selection's discrimination distance), cannot pass for this one.

use nalgebra::{Matrix3, Vector3};

/// A point of the surface passes 99.7% of the time (Gaussian scatter).
pub const SCATTER_FACTOR: f64 = 3.0;

/// Half-width of the window of neighbours, pixels.
pub const HALF_WINDOW_PX: usize = 2;

/// Least number of neighbours with a point: the plane's three parameters and as many degrees
/// of freedom for its scatter.
pub const MIN_NEIGHBOURS: usize = 6;

/// Which neighbours of a pixel, within [`HALF_WINDOW_PX`], the plane is fitted to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Window {
    /// All of them.
    Around,
    /// The columns left of the pixel.
    Left,
    /// The columns right of it.
    Right,
    /// The rows above it.
    Above,
    /// The rows below it.
    Below,
}

impl Window {
    /// The four one-sided windows.
    pub const SIDES: [Window; 4] = [Window::Left, Window::Right, Window::Above, Window::Below];

    fn holds(self, dx: isize, dy: isize) -> bool {
        match self {
            Window::Around => (dx, dy) != (0, 0),
            Window::Left => dx < 0,
            Window::Right => dx > 0,
            Window::Above => dy < 0,
            Window::Below => dy > 0,
        }
    }
}

/// The plane of the points near a pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalPlane {
    /// The depth the plane predicts at the pixel, camera frame, mm.
    pub depth_mm: f64,
    /// RMS of the neighbours' depths about the plane, mm.
    pub scatter_mm: f64,
    /// The prediction's variance in units of the scatter's (its leverage): about `1/n` in
    /// the middle of the window, about 1 one step beyond a one-sided window.
    pub leverage: f64,
}

impl LocalPlane {
    /// The plane of the points (`points[y·width + x]`, camera frame, mm) in `window` of
    /// pixel `i`, if at least [`MIN_NEIGHBOURS`] have one.
    pub fn fit(
        points: &[Option<[f32; 3]>],
        width: usize,
        i: usize,
        window: Window,
    ) -> Option<LocalPlane> {
        let height = points.len() / width.max(1);
        let (x, y) = ((i % width) as isize, (i / width) as isize);
        let r = HALF_WINDOW_PX as isize;
        let mut near = [(0.0f64, 0.0f64, 0.0f64); (2 * HALF_WINDOW_PX + 1).pow(2)];
        let mut n = 0;
        for dy in -r..=r {
            for dx in -r..=r {
                let (nx, ny) = (x + dx, y + dy);
                let inside = nx >= 0 && ny >= 0 && (nx as usize) < width && (ny as usize) < height;
                if !window.holds(dx, dy) || !inside {
                    continue;
                }
                let Some(p) = points[ny as usize * width + nx as usize] else {
                    continue;
                };
                near[n] = (dx as f64, dy as f64, p[2] as f64);
                n += 1;
            }
        }
        if n < MIN_NEIGHBOURS {
            return None;
        }
        let near = &near[..n];
        // Least squares of z = a + b·dx + c·dy about the first neighbour's depth (the scatter
        // is a millionth of the depth).
        let z0 = near[0].2;
        let (mut normal, mut rhs) = (Matrix3::<f64>::zeros(), Vector3::<f64>::zeros());
        for &(dx, dy, z) in near {
            let u = Vector3::new(1.0, dx, dy);
            normal += u * u.transpose();
            rhs += u * (z - z0);
        }
        // A window whose points lie on one line (a single row or column) fixes no plane.
        let inverse = normal.try_inverse()?;
        let plane = inverse * rhs;
        let squares: f64 = near
            .iter()
            .map(|&(dx, dy, z)| (z - z0 - plane.dot(&Vector3::new(1.0, dx, dy))).powi(2))
            .sum();
        Some(LocalPlane {
            depth_mm: z0 + plane[0],
            scatter_mm: (squares / (n - 3) as f64).sqrt(),
            leverage: inverse[(0, 0)],
        })
    }

    /// Whether three scatters stay below a quarter of `epsilon_mm`, the selection's
    /// discrimination distance `ε`: only then does the plane tell its surface from another.
    pub fn discriminates(&self, epsilon_mm: f32) -> bool {
        SCATTER_FACTOR * self.scatter_mm <= 0.25 * epsilon_mm as f64
    }

    /// How far `point` (camera frame, mm) lies from the prediction, in standard deviations of
    /// a point of the surface there (the scatter, and the prediction's uncertainty); a point
    /// continues the surface up to [`SCATTER_FACTOR`].
    pub fn deviation(&self, point: [f32; 3]) -> f64 {
        (point[2] as f64 - self.depth_mm).abs() / (self.scatter_mm * (1.0 + self.leverage).sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 7 × 7 image of points on the plane `z = 500 + 0.3·x − 0.2·y` mm, with a small
    /// deterministic scatter, and the middle pixel empty.
    fn tilted_plane(scatter_mm: f32) -> Vec<Option<[f32; 3]>> {
        (0..49)
            .map(|i| {
                let (x, y) = ((i % 7) as f32, (i / 7) as f32);
                let wobble = scatter_mm * if (i * 7919) % 3 == 0 { 1.0 } else { -0.5 };
                (i != 24).then_some([x, y, 500.0 + 0.3 * x - 0.2 * y + wobble])
            })
            .collect()
    }

    #[test]
    fn the_plane_of_the_neighbours_predicts_the_depth_and_its_scatter_bounds_a_continuation() {
        let points = tilted_plane(0.01);
        let plane = LocalPlane::fit(&points, 7, 24, Window::Around).expect("24 neighbours");
        // The middle pixel (3, 3) lies at 500.3 mm.
        assert!((plane.depth_mm - 500.3).abs() < 0.01, "{plane:?}");
        assert!(
            plane.scatter_mm > 0.003 && plane.scatter_mm < 0.02,
            "{plane:?}"
        );
        assert!(plane.deviation([3.0, 3.0, 500.3]) < SCATTER_FACTOR);
        // A light of another surface 0.1 mm away does not continue it.
        assert!(plane.deviation([3.0, 3.0, 500.4]) > SCATTER_FACTOR);
    }

    #[test]
    fn a_plane_needs_six_neighbours_and_extrapolates_from_one_side() {
        let mut points = tilted_plane(0.01);
        // Only the window's columns left of the middle keep their points: 10 neighbours.
        for (i, p) in points.iter_mut().enumerate() {
            if i % 7 >= 3 {
                *p = None;
            }
        }
        let plane = LocalPlane::fit(&points, 7, 24, Window::Around).expect("10 neighbours");
        assert!((plane.depth_mm - 500.3).abs() < 0.02, "{plane:?}");
        // Of those, the four below the middle row are not enough.
        for (i, p) in points.iter_mut().enumerate() {
            if i / 7 < 4 {
                *p = None;
            }
        }
        assert_eq!(LocalPlane::fit(&points, 7, 24, Window::Around), None);
    }
}
