//! Checkpoints: the state a run needs to continue exactly where it stopped.
//!
//! A [`Simulation`]'s evolving state is its particles, time and step count; everything else
//! (neighbour lists, matrices, the gauge) is rebuilt every step from them, and the pressure warm
//! start is the particles' pressure. So restoring a [`Checkpoint`] into a simulation built from
//! the same scene continues the run bit for bit (tested). Serialisation is the caller's: the
//! type is `serde`-ready, the library does no I/O.

use crate::simulation::Simulation;
use serde::{Deserialize, Serialize};
use sph_core::{CoreError, Dim, ParticleSet, VectorOps};

/// A simulation's evolving state.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Checkpoint {
    /// Spatial dimension (2 or 3).
    pub dim: usize,
    /// Simulated time.
    pub t: f64,
    /// Completed steps.
    pub step: usize,
    /// Positions (`[x, y, z]`, z = 0 in 2D).
    pub positions: Vec<[f64; 3]>,
    /// Velocities.
    pub velocities: Vec<[f64; 3]>,
    /// Masses.
    pub masses: Vec<f64>,
    /// Densities.
    pub densities: Vec<f64>,
    /// Pressures (the next solve's warm start).
    pub pressures: Vec<f64>,
}

/// Why a checkpoint cannot be restored.
#[derive(Debug, thiserror::Error)]
pub enum RestoreError {
    /// The checkpoint is of another dimension.
    #[error("checkpoint is {found}D, the simulation {expected}D")]
    Dimension {
        /// The simulation's dimension.
        expected: usize,
        /// The checkpoint's.
        found: usize,
    },
    /// The checkpoint holds another number of particles, or a non-finite value.
    #[error("checkpoint particles: {0}")]
    Particles(#[from] CoreError),
}

impl<D: Dim> Simulation<D> {
    /// The state to continue this run from.
    pub fn checkpoint(&self) -> Checkpoint {
        let p = &self.particles;
        Checkpoint {
            dim: D::DIM,
            t: self.t,
            step: self.step,
            positions: p.positions.iter().map(|x| x.to_array3()).collect(),
            velocities: p.velocities.iter().map(|x| x.to_array3()).collect(),
            masses: p.masses.clone(),
            densities: p.densities.clone(),
            pressures: p.pressures.clone(),
        }
    }

    /// Continues from `checkpoint`, which must come from a simulation of the same scene (same
    /// particle count and dimension; fluid and wall particles in the same order). On error the
    /// simulation is unchanged.
    pub fn restore(&mut self, checkpoint: &Checkpoint) -> Result<(), RestoreError> {
        if checkpoint.dim != D::DIM {
            return Err(RestoreError::Dimension {
                expected: D::DIM,
                found: checkpoint.dim,
            });
        }
        let n = self.particles.len();
        let vec = |v: &[[f64; 3]]| -> Vec<D::Vector> {
            v.iter().map(|a| D::Vector::from_fn(|k| a[k])).collect()
        };
        let particles = ParticleSet::<D> {
            positions: vec(&checkpoint.positions),
            velocities: vec(&checkpoint.velocities),
            masses: checkpoint.masses.clone(),
            densities: checkpoint.densities.clone(),
            pressures: checkpoint.pressures.clone(),
        };
        particles.validate()?;
        if particles.len() != n {
            return Err(CoreError::LengthMismatch {
                field: "positions",
                expected: n,
                found: particles.len(),
            }
            .into());
        }
        self.particles = particles;
        self.t = checkpoint.t;
        self.step = checkpoint.step;
        Ok(())
    }
}
