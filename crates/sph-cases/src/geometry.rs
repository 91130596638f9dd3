//! Initial particle arrangements.

use sph_core::{Dim, VectorOps};

/// Lattice points `(i dx, j dx[, k dx])` inside the ellipsoid `Σ_k (x_k / s_k)² ≤ 1` with
/// semi-axes `s` (the paper's "rectangular array", centred so one particle sits at the origin).
/// Ordered with x fastest, which is also cell order.
pub fn ellipsoid_lattice<D: Dim>(semi_axes: D::Vector, dx: f64) -> Vec<D::Vector> {
    let reach: Vec<i64> = (0..D::DIM)
        .map(|k| (semi_axes.get(k) / dx).floor() as i64)
        .collect();
    let mut out = Vec::new();
    let zr = if D::DIM == 3 { reach[2] } else { 0 };
    for kz in -zr..=zr {
        for ky in -reach[1]..=reach[1] {
            for kx in -reach[0]..=reach[0] {
                let idx = [kx, ky, kz];
                let x = D::Vector::from_fn(|k| idx[k] as f64 * dx);
                let r: f64 = (0..D::DIM)
                    .map(|k| (x.get(k) / semi_axes.get(k)).powi(2))
                    .sum();
                if r <= 1.0 + 1e-12 {
                    out.push(x);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec2, DVec3};
    use sph_core::{D2, D3};

    #[test]
    fn lattice_fills_the_ellipse() {
        let dx = 0.025;
        let pts = ellipsoid_lattice::<D2>(DVec2::new(1.0, 0.7), dx);
        // Particle count × cell area ≈ ellipse area (to the boundary's O(dx) error).
        let area = pts.len() as f64 * dx * dx;
        assert!(
            (area / (std::f64::consts::PI * 0.7) - 1.0).abs() < 0.01,
            "{area}"
        );
        assert!(pts.contains(&DVec2::ZERO));
        let pts3 = ellipsoid_lattice::<D3>(DVec3::new(1.0, 0.7, 0.7), 0.05);
        let vol = pts3.len() as f64 * 0.05f64.powi(3);
        assert!(
            (vol / (4.0 / 3.0 * std::f64::consts::PI * 0.49) - 1.0).abs() < 0.02,
            "{vol}"
        );
    }
}
