//! Structure-of-arrays particle storage.

use crate::{CoreError, Dim, VectorOps};

/// Particles stored as a structure of arrays: one `Vec` per field, index `i` is particle `i`.
///
/// Method-specific scratch data (pressure-equation right-hand sides, correction matrices) lives
/// in the method that needs it, never here.
#[derive(Clone, Debug, Default)]
pub struct ParticleSet<D: Dim> {
    /// Positions `x_i`.
    pub positions: Vec<D::Vector>,
    /// Velocities `u_i`.
    pub velocities: Vec<D::Vector>,
    /// Masses `m_i`.
    pub masses: Vec<f64>,
    /// Densities `ρ_i`.
    pub densities: Vec<f64>,
    /// Pressures `p_i`.
    pub pressures: Vec<f64>,
}

impl<D: Dim> ParticleSet<D> {
    /// Particles at `positions` with zero velocity and pressure, density `rho0` and mass
    /// `rho0 · volume` each.
    pub fn from_positions(positions: Vec<D::Vector>, volume: f64, rho0: f64) -> Self {
        let n = positions.len();
        Self {
            positions,
            velocities: vec![D::Vector::ZERO; n],
            masses: vec![rho0 * volume; n],
            densities: vec![rho0; n],
            pressures: vec![0.0; n],
        }
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True if there are no particles.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Checks that every field has one entry per particle and that positions and velocities are
    /// finite; names the first offending field and particle.
    pub fn validate(&self) -> Result<(), CoreError> {
        let n = self.len();
        let lens = [
            ("velocities", self.velocities.len()),
            ("masses", self.masses.len()),
            ("densities", self.densities.len()),
            ("pressures", self.pressures.len()),
        ];
        for (field, found) in lens {
            if found != n {
                return Err(CoreError::LengthMismatch {
                    field,
                    expected: n,
                    found,
                });
            }
        }
        if let Some(index) = self.positions.iter().position(|x| !x.is_finite()) {
            return Err(CoreError::NonFinite {
                field: "positions",
                index,
            });
        }
        if let Some(index) = self.velocities.iter().position(|x| !x.is_finite()) {
            return Err(CoreError::NonFinite {
                field: "velocities",
                index,
            });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::D2;
    use glam::DVec2;

    #[test]
    fn validate_names_field_and_particle() {
        let mut p = ParticleSet::<D2>::from_positions(vec![DVec2::ZERO, DVec2::ONE], 1.0, 1.0);
        assert_eq!(p.validate(), Ok(()));
        p.velocities[1].x = f64::NAN;
        assert_eq!(
            p.validate(),
            Err(CoreError::NonFinite {
                field: "velocities",
                index: 1
            })
        );
        p.masses.pop();
        let e = p.validate().unwrap_err();
        assert_eq!(
            e.to_string(),
            "field `masses` has 1 entries, expected 2 (one per particle)"
        );
    }
}
