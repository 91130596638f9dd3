//! Initial particle arrangements: the paper's drop lattice, and the general scene geometry of
//! `[[fluid]]` and `[[wall]]` blocks ([`build_blocks`]), the same code in 2D and 3D.
//!
//! **Lattice.** Every block is filled on the scene's lattice of spacing `dx`: sites at
//! `(k + ½) dx` (the default, "staggered") or `c + k dx` about a block's centre ("centered").
//! Walls always use the staggered lattice, so a box whose faces lie on multiples of `dx` is
//! filled with fluid `dx/2` inside its faces and wall particles `dx/2` outside them.
//!
//! **Walls.** A container box gets `layers` layers of wall particles outside each closed face
//! (corners included, so every fluid particle near a wall sees a full kernel support of
//! particles); a solid box is filled with wall particles. Each wall particle carries its mirror
//! (`−1` along the axes normal to the wall(s) it sits behind, `+1` along the others: a
//! container's corner block flips two axes; a solid's particle flips the axis of its nearest
//! face) and its surface velocity. Sites generated twice, or lying in the fluid region of the
//! union of boxes (where two containers overlap), are dropped.
//!
//! **Fluid.** Sites inside a block's shape, except those inside an earlier block, those in wall
//! material (so a solid obstacle carves its volume out of a fluid box), and, with periodic axes,
//! those outside the periodic box.

use crate::blocks::{
    FieldKind, FluidBlock, FluidShape, LatticeKind, WallBlock, WallKind, face_index,
};
use crate::{CaseError, Scene};
use sph_core::testing::SplitMix64;
use sph_core::{Dim, MatrixOps, ParticleSet, VectorOps};
use sph_integrators::{WallBox, WallBoxKind, WallCondition, WallGeometry, WallModel, Walls};
use std::collections::HashSet;

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

/// The initial state a scene's blocks describe: fluid particles followed by wall particles.
pub struct Built<D: Dim> {
    /// Fluid particles `0..walls.first` (or all, without walls), then the wall particles.
    pub particles: ParticleSet<D>,
    /// The walls, if the scene has any.
    pub walls: Option<Walls<D>>,
    /// Lattice sites of fluid blocks left out because they lie in wall material.
    pub carved: usize,
    /// The `[[fluid]]` block of each fluid particle (initial numbering).
    pub block_of: Vec<usize>,
}

fn vector<D: Dim>(v: &[f64]) -> D::Vector {
    D::Vector::from_fn(|k| v[k])
}

/// Calls `f` with every lattice site (x fastest) in the box `[lo, hi]` (inclusive, with a
/// relative tolerance of 1e-9 of `dx`), for the staggered lattice `(k + ½) dx` or, with
/// `center`, the lattice `center + k dx`.
fn for_each_site<D: Dim>(
    lo: D::Vector,
    hi: D::Vector,
    dx: f64,
    center: Option<D::Vector>,
    mut f: impl FnMut(D::Vector),
) {
    let offset = |k: usize| center.map_or(0.5 * dx, |c| c.get(k));
    let range = |k: usize| {
        let (a, b, o) = (lo.get(k), hi.get(k), offset(k));
        let first = ((a - o) / dx - 1e-9).ceil() as i64;
        let last = ((b - o) / dx + 1e-9).floor() as i64;
        (first, last)
    };
    let r: Vec<(i64, i64)> = (0..3)
        .map(|k| if k < D::DIM { range(k) } else { (0, 0) })
        .collect();
    for kz in r[2].0..=r[2].1 {
        for ky in r[1].0..=r[1].1 {
            for kx in r[0].0..=r[0].1 {
                let idx = [kx, ky, kz];
                f(D::Vector::from_fn(|k| match center {
                    None => (idx[k] as f64 + 0.5) * dx,
                    Some(c) => c.get(k) + idx[k] as f64 * dx,
                }));
            }
        }
    }
}

/// A fluid block's shape as a membership test and bounding box.
struct Shape<D: Dim> {
    block: FluidBlock,
    lo: D::Vector,
    hi: D::Vector,
    center: D::Vector,
}

impl<D: Dim> Shape<D> {
    fn new(block: &FluidBlock) -> Self {
        let v = |o: &Option<Vec<f64>>| vector::<D>(o.as_deref().expect("validated"));
        let (lo, hi, center) = match block.shape {
            FluidShape::Box => {
                let (lo, hi) = (v(&block.min), v(&block.max));
                (lo, hi, (lo + hi) * 0.5)
            }
            FluidShape::Ellipse | FluidShape::Ellipsoid => {
                let (c, s) = (v(&block.center), v(&block.semi_axes));
                (c - s, c + s, c)
            }
            FluidShape::Circle | FluidShape::Sphere => {
                let c = v(&block.center);
                let r = D::Vector::from_fn(|_| block.radius.expect("validated"));
                (c - r, c + r, c)
            }
            FluidShape::Polygon => {
                let p = block.vertices.as_ref().expect("validated");
                let lo =
                    D::Vector::from_fn(|k| p.iter().map(|q| q[k]).fold(f64::INFINITY, f64::min));
                let hi = D::Vector::from_fn(|k| {
                    p.iter().map(|q| q[k]).fold(f64::NEG_INFINITY, f64::max)
                });
                let n = p.len() as f64;
                let c = D::Vector::from_fn(|k| p.iter().map(|q| q[k]).sum::<f64>() / n);
                (lo, hi, c)
            }
        };
        Self {
            block: block.clone(),
            lo,
            hi,
            center,
        }
    }

    fn contains(&self, x: D::Vector) -> bool {
        let b = &self.block;
        match b.shape {
            FluidShape::Box => {
                (0..D::DIM).all(|k| x.get(k) >= self.lo.get(k) && x.get(k) <= self.hi.get(k))
            }
            FluidShape::Ellipse | FluidShape::Ellipsoid => {
                let s = b.semi_axes.as_ref().expect("validated");
                let r: f64 = (0..D::DIM)
                    .map(|k| ((x.get(k) - self.center.get(k)) / s[k]).powi(2))
                    .sum();
                r <= 1.0 + 1e-12
            }
            FluidShape::Circle | FluidShape::Sphere => {
                let r = b.radius.expect("validated");
                (x - self.center).length_squared() <= r * r * (1.0 + 1e-12)
            }
            FluidShape::Polygon => {
                // Even–odd rule.
                let p = b.vertices.as_ref().expect("validated");
                let (px, py) = (x.get(0), x.get(1));
                let mut inside = false;
                let mut j = p.len() - 1;
                for i in 0..p.len() {
                    let (a, c) = (p[i], p[j]);
                    if (a[1] > py) != (c[1] > py)
                        && px < (c[0] - a[0]) * (py - a[1]) / (c[1] - a[1]) + a[0]
                    {
                        inside = !inside;
                    }
                    j = i;
                }
                inside
            }
        }
    }

    fn lattice_center(&self) -> Option<D::Vector> {
        (self.block.lattice == LatticeKind::Centered).then_some(self.center)
    }

    /// The block's initial velocity at `x`.
    fn velocity(&self, x: D::Vector) -> D::Vector {
        let b = &self.block;
        let mut u = b.velocity.as_deref().map_or(D::Vector::ZERO, vector::<D>);
        if let Some(g) = &b.velocity_gradient {
            let m = D::Matrix::from_fn(|i, j| g[i][j]);
            u += m * (x - self.center);
        }
        if let Some(f) = &b.velocity_field {
            match f.kind {
                FieldKind::RigidRotation => {
                    let w = f.omega.expect("validated");
                    let c = f.center.as_deref().map_or(self.center, vector::<D>);
                    let r = x - c;
                    u += D::Vector::from_fn(|k| match k {
                        0 => -w * r.get(1),
                        1 => w * r.get(0),
                        _ => 0.0,
                    });
                }
                FieldKind::TaylorGreen => {
                    let a = f.amplitude.unwrap_or(1.0);
                    let l = f.wavelength.unwrap_or(1.0);
                    let tau = 2.0 * std::f64::consts::PI / l;
                    let (px, py) = (tau * x.get(0), tau * x.get(1));
                    u += D::Vector::from_fn(|k| match k {
                        0 => -a * px.cos() * py.sin(),
                        1 => a * px.sin() * py.cos(),
                        _ => 0.0,
                    });
                }
            }
        }
        u
    }
}

/// The wall particles of one wall block, appended to `out` (see the module docs).
struct WallSites<D: Dim> {
    positions: Vec<D::Vector>,
    mirrors: Vec<D::Vector>,
    inward: Vec<D::Vector>,
    velocities: Vec<D::Vector>,
}

fn wall_sites<D: Dim>(
    w: &WallBlock,
    dx: f64,
    layers: usize,
    geometry: &WallGeometry<D>,
    taken: &mut HashSet<[i64; 3]>,
    out: &mut WallSites<D>,
) {
    let (lo, hi) = (vector::<D>(&w.min), vector::<D>(&w.max));
    let t = layers as f64 * dx;
    let pad = D::Vector::from_fn(|_| t);
    let open = |k: usize, upper: bool| {
        w.open
            .iter()
            .filter_map(|f| face_index(f))
            .any(|(a, u)| a == k && u == upper)
    };
    let base = w.velocity.as_deref().map_or(D::Vector::ZERO, vector::<D>);
    let faces: Vec<((usize, bool), D::Vector)> = w
        .face_velocity
        .iter()
        .filter_map(|(f, v)| Some((face_index(f)?, vector::<D>(v))))
        .collect();
    let (start, end) = match w.kind {
        WallKind::Container => (lo - pad, hi + pad),
        WallKind::Solid => (lo, hi),
    };
    for_each_site::<D>(start, end, dx, None, |x| {
        let inside_k = |k: usize| x.get(k) >= lo.get(k) && x.get(k) <= hi.get(k);
        // The direction from the fluid into the wall along each flipped axis.
        let inward = match w.kind {
            WallKind::Container => {
                if (0..D::DIM).all(inside_k) {
                    return;
                }
                let beyond_open = (0..D::DIM).any(|k| {
                    (x.get(k) < lo.get(k) && open(k, false))
                        || (x.get(k) > hi.get(k) && open(k, true))
                });
                if beyond_open {
                    return;
                }
                D::Vector::from_fn(|k| {
                    if x.get(k) < lo.get(k) {
                        -1.0
                    } else if x.get(k) > hi.get(k) {
                        1.0
                    } else {
                        0.0
                    }
                })
            }
            WallKind::Solid => {
                let below: Vec<f64> = (0..D::DIM).map(|k| x.get(k) - lo.get(k)).collect();
                let above: Vec<f64> = (0..D::DIM).map(|k| hi.get(k) - x.get(k)).collect();
                let near = below
                    .iter()
                    .chain(&above)
                    .cloned()
                    .fold(f64::INFINITY, f64::min);
                let tol = 1e-9 * dx;
                D::Vector::from_fn(|k| {
                    // Nearest face below: the fluid lies at x_k < lo_k, the wall towards +e_k.
                    if below[k] <= near + tol {
                        1.0
                    } else if above[k] <= near + tol {
                        -1.0
                    } else {
                        0.0
                    }
                })
            }
        };
        let mirror = D::Vector::from_fn(|k| if inward.get(k) != 0.0 { -1.0 } else { 1.0 });
        let key: [i64; 3] = std::array::from_fn(|k| {
            if k < D::DIM {
                (x.get(k) / dx - 0.5).round() as i64
            } else {
                0
            }
        });
        if geometry.depth(x) <= 0.0 || !taken.insert(key) {
            return;
        }
        // A face's velocity applies to the sites beyond that face within the box's extent
        // along the other axes (a lid; the corner blocks continue the side walls at rest).
        let face = faces.iter().find(|((k, upper), _)| {
            let beyond = if *upper {
                x.get(*k) > hi.get(*k)
            } else {
                x.get(*k) < lo.get(*k)
            };
            beyond && (0..D::DIM).filter(|m| m != k).all(inside_k)
        });
        out.positions.push(x);
        out.mirrors.push(mirror);
        out.inward.push(inward);
        out.velocities.push(face.map_or(base, |(_, v)| *v));
    });
}

/// The default number of wall layers: enough to fill the kernel support.
pub fn default_layers(scene: &Scene) -> usize {
    (scene.support() / scene.dx - 1e-9).ceil().max(1.0) as usize
}

/// The wall geometry (boxes) of a scene's `[[wall]]` blocks.
pub fn wall_geometry<D: Dim>(walls: &[WallBlock]) -> WallGeometry<D> {
    WallGeometry {
        boxes: walls
            .iter()
            .map(|w| {
                let mut open = [[false; 2]; 3];
                for (k, upper) in w.open.iter().filter_map(|f| face_index(f)) {
                    open[k][usize::from(upper)] = true;
                }
                WallBox {
                    kind: match w.kind {
                        WallKind::Container => WallBoxKind::Container,
                        WallKind::Solid => WallBoxKind::Solid,
                    },
                    lo: vector::<D>(&w.min),
                    hi: vector::<D>(&w.max),
                    open,
                }
            })
            .collect(),
    }
}

/// Builds the particles and walls of a scene's `[[fluid]]` and `[[wall]]` blocks (the scene
/// must be valid and `scene.dim == D::DIM`), with the wall condition `condition`.
pub fn build_blocks<D: Dim>(
    scene: &Scene,
    fluid_blocks: &[FluidBlock],
    wall_blocks: &[WallBlock],
    condition: WallCondition,
) -> Result<Built<D>, CaseError> {
    let dx = scene.dx;
    let geometry = wall_geometry::<D>(wall_blocks);
    let periodic = scene.sim_config().periodic;
    let in_periodic_box = |x: D::Vector| {
        periodic.is_none_or(|p| {
            (0..D::DIM).all(|k| !p.axes[k] || (x.get(k) >= p.lo[k] && x.get(k) < p.hi[k]))
        })
    };
    // Fluid.
    let shapes: Vec<Shape<D>> = fluid_blocks.iter().map(Shape::new).collect();
    let mut positions = Vec::new();
    let mut velocities = Vec::new();
    let mut block_of = Vec::new();
    let mut carved = 0;
    for (b, shape) in shapes.iter().enumerate() {
        for_each_site::<D>(shape.lo, shape.hi, dx, shape.lattice_center(), |x| {
            if !shape.contains(x)
                || shapes[..b].iter().any(|s| s.contains(x))
                || !in_periodic_box(x)
            {
                return;
            }
            if !wall_blocks.is_empty() && geometry.depth(x) > 0.0 {
                carved += 1;
                return;
            }
            positions.push(x);
            velocities.push(shape.velocity(x));
            block_of.push(b);
        });
    }
    let fluid = positions.len();
    // Jitter (seeded per block) after the velocities, which stay those of the lattice sites.
    for (b, shape) in shapes.iter().enumerate() {
        if let Some(j) = shape.block.jitter.filter(|j| *j > 0.0) {
            let mut rng = SplitMix64::new(0x5eed_0000 + b as u64);
            for (x, _) in positions
                .iter_mut()
                .zip(&block_of)
                .filter(|(_, k)| **k == b)
            {
                *x += rng.vector::<D>(-j * dx, j * dx);
            }
        }
    }
    let rho0 = scene.rho0();
    // Hydrostatic pressure p = ρ₀ |g| (s_top − s), s = −ĝ·x, s_top half a spacing above the
    // block's highest particle (its free surface).
    let mut pressures = vec![0.0; fluid];
    if let Some(g) = scene.effects.gravity {
        let g = vector::<D>(&g);
        let gn = g.length();
        if gn > 0.0 {
            let up = g * (-1.0 / gn);
            for (b, shape) in shapes.iter().enumerate() {
                if !shape.block.hydrostatic {
                    continue;
                }
                let mine = || (0..fluid).filter(|i| block_of[*i] == b);
                let top = mine()
                    .map(|i| up.dot(positions[i]))
                    .fold(f64::NEG_INFINITY, f64::max)
                    + 0.5 * dx;
                for i in mine() {
                    pressures[i] = rho0 * gn * (top - up.dot(positions[i]));
                }
            }
        }
    }
    // Walls.
    let walls = if wall_blocks.is_empty() {
        None
    } else {
        let default = default_layers(scene);
        let mut sites = WallSites {
            positions: Vec::new(),
            mirrors: Vec::new(),
            inward: Vec::new(),
            velocities: Vec::new(),
        };
        let mut taken = HashSet::new();
        let mut thickness: f64 = 0.0;
        for w in wall_blocks {
            let layers = w.layers.unwrap_or(default);
            thickness = thickness.max(layers as f64 * dx);
            wall_sites(w, dx, layers, &geometry, &mut taken, &mut sites);
        }
        if sites.positions.is_empty() {
            return Err(CaseError::Invalid {
                scene: scene.case.name().into(),
                field: "wall".into(),
                message: "the walls hold no wall particle".into(),
            });
        }
        positions.extend_from_slice(&sites.positions);
        velocities.extend_from_slice(&sites.velocities);
        pressures.resize(positions.len(), 0.0);
        Some(Walls {
            model: WallModel::DummyParticles,
            condition,
            first: fluid,
            velocity: sites.velocities,
            mirror: sites.mirrors,
            inward: sites.inward,
            separation: scene.free_surface.is_some(),
            geometry,
            thickness,
            ghosts: None,
        })
    };
    let mut particles = ParticleSet::<D>::from_positions(positions, dx.powi(D::DIM as i32), rho0);
    particles.velocities = velocities;
    particles.pressures = pressures;
    Ok(Built {
        particles,
        walls,
        carved,
        block_of,
    })
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
