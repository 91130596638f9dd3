//! Checkpoints: the state a run needs to continue exactly where it stopped.
//!
//! A [`Simulation`]'s evolving state is its particles (in their current numbering, with each
//! slot's initial index), time and step count; everything else
//! (neighbour lists, matrices, the gauge) is rebuilt every step from them, and the pressure warm
//! start is the particles' pressure. So restoring a [`Checkpoint`] into a simulation built from
//! the same scene continues the run bit for bit.
//!
//! [`Checkpoint::encode`] writes a self-checking binary image (every float as its exact bit
//! pattern, then an FNV-1a 64-bit checksum of everything before it); [`Checkpoint::decode`]
//! refuses a truncated, corrupted or inconsistent image with a [`RestoreError`] saying what is
//! wrong. The library does no I/O: the caller writes and reads the bytes.
//!
//! Layout (little-endian): `b"DGSPHCKP"`, format version `u32`, dimension `u32`, step `u64`,
//! `t` `f64`, particle count `n` `u64`, metadata length `u64` and its UTF-8 bytes, then positions
//! and velocities (`3n` `f64` each, `z = 0` in 2D), masses, densities and pressures (`n` each),
//! the particles' initial indices (`n` `u32`; format version 2 — version 1 images, which have
//! none, are read with the identity numbering), the caller's run state (length `u64` and its
//! bytes; format version 3 — older images are read with none), then the checksum `u64`.

use crate::simulation::Simulation;
use sph_core::{CoreError, Dim, ParticleSet, VectorOps};

/// A simulation's evolving state, plus free-form metadata of the caller (e.g. the scene it was
/// written under).
#[derive(Clone, Debug, PartialEq)]
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
    /// Each slot's index in the initial state ([`Simulation::ids`]): a permutation of `0..n`.
    pub ids: Vec<u32>,
    /// The caller's metadata (not interpreted here).
    pub meta: String,
    /// The caller's run state at this step (what its measurements have accumulated so far), as
    /// opaque bytes: not interpreted here; empty when there is none.
    pub state: Vec<u8>,
}

/// Why a checkpoint cannot be decoded or restored.
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
    /// The bytes are not a checkpoint of this format (wrong magic or version, truncated).
    #[error("not a dgsph checkpoint: {0}")]
    Format(String),
    /// The checksum does not match: the file was corrupted or modified.
    #[error(
        "checkpoint checksum mismatch (stored {stored:016x}, computed {computed:016x}): the file is corrupted"
    )]
    Checksum {
        /// Checksum stored in the file.
        stored: u64,
        /// Checksum of the bytes read.
        computed: u64,
    },
    /// A value is out of its physical range (negative time, a mass or density not positive).
    #[error("checkpoint holds an invalid {what}: {detail}")]
    Invalid {
        /// Which quantity.
        what: &'static str,
        /// What is wrong.
        detail: String,
    },
}

const MAGIC: &[u8; 8] = b"DGSPHCKP";
const VERSION: u32 = 3;

/// FNV-1a, 64 bit (Fowler–Noll–Vo): every single-byte change changes the hash.
fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in bytes {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h
}

/// A little-endian reader over a byte slice that reports truncation as an error.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize, what: &str) -> Result<&[u8], RestoreError> {
        let end = self.at.checked_add(n).filter(|e| *e <= self.bytes.len());
        let Some(end) = end else {
            return Err(RestoreError::Format(format!("truncated in {what}")));
        };
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn u32(&mut self, what: &str) -> Result<u32, RestoreError> {
        Ok(u32::from_le_bytes(
            self.take(4, what)?.try_into().expect("4 bytes"),
        ))
    }
    fn u64(&mut self, what: &str) -> Result<u64, RestoreError> {
        Ok(u64::from_le_bytes(
            self.take(8, what)?.try_into().expect("8 bytes"),
        ))
    }
    /// `n` little-endian values of `W` bytes each.
    fn array<const W: usize, T>(
        &mut self,
        n: usize,
        what: &str,
        from: fn([u8; W]) -> T,
    ) -> Result<Vec<T>, RestoreError> {
        let len = n
            .checked_mul(W)
            .ok_or_else(|| RestoreError::Format(format!("{what}: count overflows")))?;
        Ok(self
            .take(len, what)?
            .chunks_exact(W)
            .map(|c| from(c.try_into().expect("W bytes")))
            .collect())
    }
    fn f64s(&mut self, n: usize, what: &str) -> Result<Vec<f64>, RestoreError> {
        self.array(n, what, f64::from_le_bytes)
    }
    fn u32s(&mut self, n: usize, what: &str) -> Result<Vec<u32>, RestoreError> {
        self.array(n, what, u32::from_le_bytes)
    }
}

impl Checkpoint {
    /// The checkpoint as a self-checking binary image (see the module docs).
    pub fn encode(&self) -> Vec<u8> {
        let n = self.masses.len();
        let mut out =
            Vec::with_capacity(72 + self.meta.len() + self.state.len() + n * (9 * 8 + 4) + 8);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&(self.dim as u32).to_le_bytes());
        out.extend_from_slice(&(self.step as u64).to_le_bytes());
        out.extend_from_slice(&self.t.to_le_bytes());
        out.extend_from_slice(&(n as u64).to_le_bytes());
        out.extend_from_slice(&(self.meta.len() as u64).to_le_bytes());
        out.extend_from_slice(self.meta.as_bytes());
        for v in [&self.positions, &self.velocities] {
            for a in v.iter() {
                for c in a {
                    out.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        for v in [&self.masses, &self.densities, &self.pressures] {
            for c in v.iter() {
                out.extend_from_slice(&c.to_le_bytes());
            }
        }
        for id in &self.ids {
            out.extend_from_slice(&id.to_le_bytes());
        }
        out.extend_from_slice(&(self.state.len() as u64).to_le_bytes());
        out.extend_from_slice(&self.state);
        let sum = fnv1a(&out);
        out.extend_from_slice(&sum.to_le_bytes());
        out
    }

    /// Decodes and validates an image written by [`Checkpoint::encode`]: format and version,
    /// checksum, lengths, finite values, `t ≥ 0`, masses and densities positive, `z = 0` in 2D.
    pub fn decode(bytes: &[u8]) -> Result<Self, RestoreError> {
        if bytes.len() < MAGIC.len() + 8 || &bytes[..MAGIC.len()] != MAGIC {
            return Err(RestoreError::Format("no checkpoint header".into()));
        }
        let (body, tail) = bytes.split_at(bytes.len() - 8);
        let stored = u64::from_le_bytes(tail.try_into().expect("8 bytes"));
        let computed = fnv1a(body);
        if stored != computed {
            return Err(RestoreError::Checksum { stored, computed });
        }
        let mut r = Reader {
            bytes: body,
            at: MAGIC.len(),
        };
        let version = r.u32("version")?;
        if !(1..=VERSION).contains(&version) {
            return Err(RestoreError::Format(format!(
                "format version {version}, this build reads 1 to {VERSION}"
            )));
        }
        let dim = r.u32("dimension")? as usize;
        if dim != 2 && dim != 3 {
            return Err(RestoreError::Invalid {
                what: "dimension",
                detail: dim.to_string(),
            });
        }
        let step = usize::try_from(r.u64("step")?)
            .map_err(|_| RestoreError::Format("step does not fit".into()))?;
        let t = f64::from_le_bytes(r.take(8, "time")?.try_into().expect("8 bytes"));
        let n = usize::try_from(r.u64("particle count")?)
            .map_err(|_| RestoreError::Format("particle count does not fit".into()))?;
        let meta_len = usize::try_from(r.u64("metadata length")?)
            .map_err(|_| RestoreError::Format("metadata length does not fit".into()))?;
        let meta = String::from_utf8(r.take(meta_len, "metadata")?.to_vec())
            .map_err(|_| RestoreError::Format("metadata is not UTF-8".into()))?;
        let triples = |v: Vec<f64>| -> Vec<[f64; 3]> {
            v.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        };
        let three_n = n
            .checked_mul(3)
            .ok_or_else(|| RestoreError::Format("particle count overflows".into()))?;
        let positions = triples(r.f64s(three_n, "positions")?);
        let velocities = triples(r.f64s(three_n, "velocities")?);
        let masses = r.f64s(n, "masses")?;
        let densities = r.f64s(n, "densities")?;
        let pressures = r.f64s(n, "pressures")?;
        let ids = if version == 1 {
            (0..n)
                .map(|i| {
                    u32::try_from(i).map_err(|_| RestoreError::Format("too many particles".into()))
                })
                .collect::<Result<_, _>>()?
        } else {
            r.u32s(n, "particle ids")?
        };
        let state = if version >= 3 {
            let len = usize::try_from(r.u64("run state length")?)
                .map_err(|_| RestoreError::Format("run state length does not fit".into()))?;
            r.take(len, "run state")?.to_vec()
        } else {
            Vec::new()
        };
        if r.at != body.len() {
            return Err(RestoreError::Format(format!(
                "{} bytes after the particle data",
                body.len() - r.at
            )));
        }
        let c = Checkpoint {
            dim,
            t,
            step,
            positions,
            velocities,
            masses,
            densities,
            pressures,
            ids,
            meta,
            state,
        };
        c.validate()?;
        Ok(c)
    }

    /// Range checks of the restored state.
    fn validate(&self) -> Result<(), RestoreError> {
        let invalid = |what, detail: String| Err(RestoreError::Invalid { what, detail });
        if !(self.t.is_finite() && self.t >= 0.0) {
            return invalid("time", format!("t = {}", self.t));
        }
        if self.step == 0 && self.t != 0.0 {
            return invalid("time", format!("t = {} at step 0", self.t));
        }
        if let Some(i) = self
            .masses
            .iter()
            .position(|m| !(m.is_finite() && *m > 0.0))
        {
            return invalid("mass", format!("particle {i}: {}", self.masses[i]));
        }
        if let Some(i) = self
            .densities
            .iter()
            .position(|m| !(m.is_finite() && *m > 0.0))
        {
            return invalid("density", format!("particle {i}: {}", self.densities[i]));
        }
        if let Some(i) = self.pressures.iter().position(|p| !p.is_finite()) {
            return invalid("pressure", format!("particle {i} is not finite"));
        }
        let n = self.masses.len();
        if self.ids.len() != n {
            return invalid(
                "particle numbering",
                format!("{} ids for {n} particles", self.ids.len()),
            );
        }
        let mut seen = vec![false; n];
        for (slot, &id) in self.ids.iter().enumerate() {
            match seen.get_mut(id as usize) {
                Some(s) if !*s => *s = true,
                _ => {
                    return invalid(
                        "particle numbering",
                        format!("slot {slot} holds id {id}: not a permutation of 0..{n}"),
                    );
                }
            }
        }
        if self.dim == 2
            && let Some(i) = self
                .positions
                .iter()
                .chain(&self.velocities)
                .position(|a| a[2] != 0.0)
        {
            return invalid("2D state", format!("entry {i} has a non-zero z component"));
        }
        Ok(())
    }
}

impl<D: Dim> Simulation<D> {
    /// The state to continue this run from, with the caller's `meta`.
    pub fn checkpoint(&self, meta: &str) -> Checkpoint {
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
            ids: self.order.ids.clone(),
            meta: meta.to_string(),
            state: Vec::new(),
        }
    }

    /// Continues from `checkpoint`, which must come from a simulation of the same scene (same
    /// particle count and dimension; the fluid particles first, the wall particles in their
    /// initial slots). On error the simulation is unchanged.
    pub fn restore(&mut self, checkpoint: &Checkpoint) -> Result<(), RestoreError> {
        if checkpoint.dim != D::DIM {
            return Err(RestoreError::Dimension {
                expected: D::DIM,
                found: checkpoint.dim,
            });
        }
        checkpoint.validate()?;
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
        let nf = self.engine.fluid.min(n);
        if let Some(slot) = (nf..n).find(|&k| checkpoint.ids[k] as usize != k) {
            return Err(RestoreError::Invalid {
                what: "particle numbering",
                detail: format!(
                    "slot {slot} of the walls holds particle {} (wall particles keep their slots)",
                    checkpoint.ids[slot]
                ),
            });
        }
        self.particles = particles;
        self.order.ids.clone_from(&checkpoint.ids);
        self.order.index_slots();
        self.t = checkpoint.t;
        self.step = checkpoint.step;
        // Mirror ghosts: their sources follow the restored fluid (the values they get are the
        // checkpoint's, which were placed the same way).
        self.refresh_walls().map_err(|e| RestoreError::Invalid {
            what: "ghost walls",
            detail: e.to_string(),
        })?;
        self.invalidate_solver_setup();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Checkpoint {
        Checkpoint {
            dim: 2,
            t: 0.1 + 0.2, // not exactly representable in decimal
            step: 30,
            positions: vec![[0.1, 1.0 / 3.0, 0.0], [f64::MIN_POSITIVE, -2.5e-310, 0.0]],
            velocities: vec![[1e300, -0.0, 0.0], [std::f64::consts::PI, 1e-17, 0.0]],
            masses: vec![0.0025, 0.0025],
            densities: vec![1.0, 1.0 + f64::EPSILON],
            pressures: vec![-3.3e3, 7.0 / 9.0],
            ids: vec![1, 0],
            meta: "{\"scene\": \"é\"}".into(),
            state: vec![0, 255, 7, 1],
        }
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let c = sample();
        let bytes = c.encode();
        let back = Checkpoint::decode(&bytes).unwrap();
        assert_eq!(back, c);
        let bits = |v: &[[f64; 3]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back.positions), bits(&c.positions));
        assert_eq!(bits(&back.velocities), bits(&c.velocities));
        assert_eq!(back.t.to_bits(), c.t.to_bits());
    }

    /// `body` (an image without its checksum) announced as format `version`, the checksum
    /// appended.
    fn as_version(body: &[u8], version: u32) -> Vec<u8> {
        let mut b = body.to_vec();
        b[8..12].copy_from_slice(&version.to_le_bytes());
        let sum = fnv1a(&b);
        b.extend_from_slice(&sum.to_le_bytes());
        b
    }

    /// An image without its checksum.
    fn body(image: &[u8]) -> &[u8] {
        &image[..image.len() - 8]
    }

    /// A version-2 image (written before runs saved their state) is read with no run state; a
    /// version-1 image (written before particles were renumbered: no ids) also with the
    /// identity numbering.
    #[test]
    fn older_images_read_with_no_run_state_and_the_identity_numbering() {
        let mut c = sample();
        let v3 = c.encode();
        let n = c.masses.len();
        let state = 8 + c.state.len();
        let v2 = as_version(&body(&v3)[..body(&v3).len() - state], 2);
        c.state.clear();
        assert_eq!(Checkpoint::decode(&v2).unwrap(), c);
        let v1 = as_version(&body(&v2)[..body(&v2).len() - 4 * n], 1);
        let back = Checkpoint::decode(&v1).unwrap();
        c.ids = vec![0, 1];
        assert_eq!(back, c);
        // The same bytes announced as version 2 lack the ids; version-2 bytes announced as
        // version 3 lack the run state.
        let e = Checkpoint::decode(&as_version(body(&v1), 2))
            .unwrap_err()
            .to_string();
        assert!(e.contains("particle ids"), "{e}");
        let e = Checkpoint::decode(&as_version(body(&v2), 3))
            .unwrap_err()
            .to_string();
        assert!(e.contains("run state"), "{e}");
    }

    #[test]
    fn damaged_images_are_refused() {
        let bytes = sample().encode();
        // Every single flipped bit in the body is caught by the checksum (or the header check).
        for at in [0, 9, 20, 40, bytes.len() / 2, bytes.len() - 9] {
            let mut b = bytes.clone();
            b[at] ^= 0x10;
            assert!(Checkpoint::decode(&b).is_err(), "flip at {at} accepted");
        }
        // Truncation anywhere.
        for len in [0, 7, 30, bytes.len() - 1] {
            assert!(
                Checkpoint::decode(&bytes[..len]).is_err(),
                "length {len} accepted"
            );
        }
        // Physically invalid values, with a valid checksum, are refused naming the quantity.
        for (what, edit) in [
            (
                "time",
                Box::new(|c: &mut Checkpoint| c.t = -5.0) as Box<dyn Fn(&mut Checkpoint)>,
            ),
            ("mass", Box::new(|c: &mut Checkpoint| c.masses[1] = 0.0)),
            (
                "density",
                Box::new(|c: &mut Checkpoint| c.densities[0] = -1.0),
            ),
            (
                "pressure",
                Box::new(|c: &mut Checkpoint| c.pressures[0] = f64::NAN),
            ),
            (
                "2D state",
                Box::new(|c: &mut Checkpoint| c.positions[0][2] = 1.0),
            ),
            (
                "particle numbering",
                Box::new(|c: &mut Checkpoint| c.ids[1] = 1),
            ),
            (
                "particle numbering",
                Box::new(|c: &mut Checkpoint| c.ids[0] = 7),
            ),
        ] {
            let mut c = sample();
            edit(&mut c);
            let e = Checkpoint::decode(&c.encode()).unwrap_err().to_string();
            assert!(e.contains(what), "{what}: {e}");
        }
    }

    /// Mutated images whose checksum is made valid again reach the structural decoder: 100 000
    /// of them (bytes overwritten, length fields set to extreme values, cuts and insertions),
    /// seeded, none may panic, and whatever decodes satisfies the restored-state rules.
    #[test]
    fn mutated_images_with_valid_checksums_never_panic() {
        let good = sample().encode();
        let body_len = good.len() - 8;
        let mut state = 0x0c4e_c4b0_1e57_u64;
        let mut next = move || {
            // splitmix64
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^ (z >> 31)
        };
        // Offsets of the header's integer fields: version, dim, step, t, n, meta length.
        let fields = [8usize, 12, 16, 24, 32, 40];
        let extremes = [
            0u64,
            1,
            2,
            3,
            u64::MAX,
            u64::MAX / 8,
            1 << 32,
            1 << 61,
            u32::MAX as u64,
        ];
        let (mut decoded, mut refused) = (0usize, 0usize);
        for _ in 0..100_000 {
            let mut body = good[..body_len].to_vec();
            for _ in 0..1 + next() % 3 {
                match next() % 4 {
                    0 => {
                        let at = (next() as usize) % body.len().max(1);
                        if let Some(b) = body.get_mut(at) {
                            *b = next() as u8;
                        }
                    }
                    1 => {
                        let f = fields[(next() as usize) % fields.len()];
                        let v = extremes[(next() as usize) % extremes.len()];
                        let w = if f < 16 { 4 } else { 8 };
                        if body.len() >= f + w {
                            body[f..f + w].copy_from_slice(&v.to_le_bytes()[..w]);
                        }
                    }
                    2 => body.truncate((next() as usize) % (body.len() + 1)),
                    _ => {
                        let at = (next() as usize) % (body.len() + 1);
                        let extra: Vec<u8> = (0..next() % 24).map(|_| next() as u8).collect();
                        body.splice(at..at, extra);
                    }
                }
            }
            let sum = fnv1a(&body);
            body.extend_from_slice(&sum.to_le_bytes());
            match Checkpoint::decode(&body) {
                Ok(c) => {
                    decoded += 1;
                    let n = c.masses.len();
                    assert!(c.t.is_finite() && c.t >= 0.0);
                    assert!(c.positions.len() == n && c.velocities.len() == n);
                    assert!(c.densities.len() == n && c.pressures.len() == n);
                    assert_eq!(c.ids.len(), n);
                    assert!(
                        c.masses
                            .iter()
                            .chain(&c.densities)
                            .all(|m| m.is_finite() && *m > 0.0)
                    );
                }
                Err(_) => refused += 1,
            }
        }
        assert_eq!(decoded + refused, 100_000);
        assert!(refused > 50_000, "decoded {decoded}, refused {refused}");
    }
}
