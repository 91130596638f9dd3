//! Where walls are: a union of axis-aligned boxes, each a container the fluid stays inside (any
//! faces open) or a solid obstacle the fluid stays out of.
//!
//! The geometry answers two questions for any wall layout, in 2D and 3D alike: how deep a fluid
//! particle has gone into wall material ([`WallGeometry::depth`], the penetration measure), and how
//! far a particle may be shifted towards a wall ([`WallGeometry::limit_shift`]). Wall particles
//! themselves (their positions, mirrors and velocities) are built by the caller, e.g.
//! `sph-cases`' scene geometry.

use sph_core::{Dim, VectorOps};

/// Whether a box holds the fluid in or keeps it out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WallBoxKind {
    /// The fluid stays inside the box; wall particles lie outside its closed faces.
    Container,
    /// The fluid stays outside the box; wall particles fill it.
    Solid,
}

/// An axis-aligned box of a [`WallGeometry`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WallBox<D: Dim> {
    /// Container or solid.
    pub kind: WallBoxKind,
    /// Lower corner.
    pub lo: D::Vector,
    /// Upper corner.
    pub hi: D::Vector,
    /// `open[k] = [lower, upper]`: faces of a container without a wall (fluid may leave through
    /// them). Ignored for solids.
    pub open: [[bool; 2]; 3],
}

impl<D: Dim> WallBox<D> {
    /// A container `[lo, hi]` with every face closed.
    pub fn closed_container(lo: D::Vector, hi: D::Vector) -> Self {
        Self {
            kind: WallBoxKind::Container,
            lo,
            hi,
            open: [[false; 2]; 3],
        }
    }

    /// A solid obstacle `[lo, hi]`.
    pub fn solid(lo: D::Vector, hi: D::Vector) -> Self {
        Self {
            kind: WallBoxKind::Solid,
            lo,
            hi,
            open: [[false; 2]; 3],
        }
    }

    fn closed(&self, k: usize, upper: bool) -> bool {
        !self.open[k][usize::from(upper)]
    }

    /// Container: how far `x` lies past its closed faces, `max_k max(lo_k − x_k, x_k − hi_k, 0)`
    /// over closed faces; 0 when `x` lies beyond an open face (it left through the opening).
    fn container_depth(&self, x: D::Vector) -> f64 {
        if (0..D::DIM).any(|k| self.past_open_face(x, k)) {
            return 0.0;
        }
        (0..D::DIM)
            .map(|k| {
                let below = if self.closed(k, false) {
                    self.lo.get(k) - x.get(k)
                } else {
                    0.0
                };
                let above = if self.closed(k, true) {
                    x.get(k) - self.hi.get(k)
                } else {
                    0.0
                };
                below.max(above)
            })
            .fold(0.0, f64::max)
    }

    /// Container: whether `x` lies past the plane of an open face but outside the face itself
    /// (beside the opening along another axis): above the rim of an open tank, over its wall
    /// layers or further out.
    fn over_rim(&self, x: D::Vector) -> bool {
        (0..D::DIM).any(|k| {
            self.past_open_face(x, k)
                && (0..D::DIM)
                    .any(|j| j != k && (x.get(j) < self.lo.get(j) || x.get(j) > self.hi.get(j)))
        })
    }

    /// Container: whether `x` lies past the plane of an open face normal to axis `k`.
    fn past_open_face(&self, x: D::Vector, k: usize) -> bool {
        (x.get(k) < self.lo.get(k) && !self.closed(k, false))
            || (x.get(k) > self.hi.get(k) && !self.closed(k, true))
    }

    /// Solid: the distance from `x` to the nearest face when `x` is inside, 0 otherwise.
    fn solid_depth(&self, x: D::Vector) -> f64 {
        (0..D::DIM)
            .map(|k| (x.get(k) - self.lo.get(k)).min(self.hi.get(k) - x.get(k)))
            .fold(f64::INFINITY, f64::min)
            .max(0.0)
    }

    fn valid(&self) -> bool {
        (0..D::DIM).all(|k| {
            let (a, b) = (self.lo.get(k), self.hi.get(k));
            a.is_finite() && b.is_finite() && a < b
        })
    }
}

/// The walls' shape: containers (the fluid may be in any of them) and solids (the fluid may be
/// in none). With no container the fluid region is unbounded except for the solids.
#[derive(Clone, Debug, PartialEq)]
pub struct WallGeometry<D: Dim> {
    /// The boxes, containers and solids in any order.
    pub boxes: Vec<WallBox<D>>,
}

impl<D: Dim> WallGeometry<D> {
    /// One closed container box `[lo, hi]` (the lid-driven cavity).
    pub fn closed_box(lo: D::Vector, hi: D::Vector) -> Self {
        Self {
            boxes: vec![WallBox::closed_container(lo, hi)],
        }
    }

    /// True if every box is non-empty and finite.
    pub fn is_valid(&self) -> bool {
        !self.boxes.is_empty() && self.boxes.iter().all(WallBox::valid)
    }

    fn containers(&self) -> impl Iterator<Item = &WallBox<D>> {
        self.boxes
            .iter()
            .filter(|b| b.kind == WallBoxKind::Container)
    }

    fn solids(&self) -> impl Iterator<Item = &WallBox<D>> {
        self.boxes.iter().filter(|b| b.kind == WallBoxKind::Solid)
    }

    /// How deep `x` lies in wall material: the depth past the closed faces of the nearest
    /// container (0 inside any container, or with none), or inside a solid (the distance to its
    /// nearest face), whichever is larger. 0 for a point in the fluid region.
    pub fn depth(&self, x: D::Vector) -> f64 {
        let container = self
            .containers()
            .map(|b| b.container_depth(x))
            .fold(None, |m: Option<f64>, d| Some(m.map_or(d, |m| m.min(d))))
            .unwrap_or(0.0);
        self.solids()
            .map(|b| b.solid_depth(x))
            .fold(container, f64::max)
    }

    /// Whether `x` lies outside every container, either further than `thickness` past one of
    /// its closed faces (beyond the wall layers, where a particle can only have arrived over an
    /// open face's rim: one step moves a particle less than the layers are thick) or over the
    /// rim itself (past an open face's plane, beside the opening: on top of the wall layers or
    /// further out). False without containers, and when a container has no open face (nothing
    /// can leave a closed box: a particle out there has passed through a wall). Solids do not
    /// enter.
    pub fn beyond_walls(&self, x: D::Vector, thickness: f64) -> bool {
        let mut any = false;
        for b in self.containers() {
            let open = b.open.iter().flatten().any(|o| *o);
            if !open || (b.container_depth(x) <= thickness && !b.over_rim(x)) {
                return false;
            }
            any = true;
        }
        any
    }

    /// A shift `dr` of the fluid particle at `x`, shortened so it can bring the particle closer
    /// to a wall but never across one:
    ///
    /// * in the container holding `x` (or the nearest one), each component towards a closed face
    ///   is cut to at most half the distance to that face (zero outside the box);
    /// * for a solid whose slab along axis `k` holds `x` (`x` inside the solid's extent along
    ///   every other axis), a component towards its face is cut likewise;
    /// * if the result still ends deeper in wall material than `x` is (a diagonal move past a
    ///   solid's corner), it is halved until it does not (at most 16 times, then dropped).
    ///
    /// At the lattice distance Δp/2 from a face the allowance (Δp/4) exceeds the shift cap
    /// (0.2 Δp), so ordinary shifting near walls is untouched.
    pub fn limit_shift(&self, x: D::Vector, dr: D::Vector) -> D::Vector {
        let mut out = dr;
        // The container holding x (the nearest one if x is outside all of them).
        let nearest = self
            .containers()
            .fold(None, |best: Option<(&WallBox<D>, f64)>, b| {
                let d = b.container_depth(x);
                match best {
                    Some((_, bd)) if bd <= d => best,
                    _ => Some((b, d)),
                }
            });
        if let Some((c, _)) = nearest {
            out = D::Vector::from_fn(|k| {
                let (d, lo, hi, xk) = (out.get(k), c.lo.get(k), c.hi.get(k), x.get(k));
                if d < 0.0 && c.closed(k, false) {
                    d.max(-0.5 * (xk - lo).max(0.0))
                } else if d > 0.0 && c.closed(k, true) {
                    d.min(0.5 * (hi - xk).max(0.0))
                } else {
                    d
                }
            });
        }
        for s in self.solids() {
            for k in 0..D::DIM {
                let in_slab = (0..D::DIM)
                    .filter(|&m| m != k)
                    .all(|m| x.get(m) >= s.lo.get(m) && x.get(m) <= s.hi.get(m));
                if !in_slab {
                    continue;
                }
                let (d, xk) = (out.get(k), x.get(k));
                if d > 0.0 && xk <= s.lo.get(k) {
                    out.set(k, d.min(0.5 * (s.lo.get(k) - xk)));
                } else if d < 0.0 && xk >= s.hi.get(k) {
                    out.set(k, d.max(-0.5 * (xk - s.hi.get(k))));
                }
            }
        }
        let start = self.depth(x);
        for _ in 0..16 {
            if self.depth(x + out) <= start {
                return out;
            }
            out *= 0.5;
        }
        D::Vector::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sph_core::dim_tests;

    fn at<D: Dim>(v: [f64; 3]) -> D::Vector {
        D::Vector::from_fn(|k| v[k])
    }

    dim_tests! {
        fn open_faces_and_solids_measure_depth<D>() {
            // A tank [0, 4] × [0, 3] (× [0, 1]) open at the top, with a solid step
            // [2, 2.5] × [0, 0.5] (× [0, 1]) on its floor.
            let mut tank = WallBox::<D>::closed_container(at::<D>([0.0; 3]), at::<D>([4.0, 3.0, 1.0]));
            tank.open[1][1] = true;
            let step = WallBox::<D>::solid(at::<D>([2.0, 0.0, 0.0]), at::<D>([2.5, 0.5, 1.0]));
            let g = WallGeometry { boxes: vec![tank, step] };
            assert!(g.is_valid());
            let z = 0.5;
            // In the fluid: 0.
            assert_eq!(g.depth(at::<D>([1.0, 1.0, z])), 0.0);
            // Past the floor and the left wall.
            assert!((g.depth(at::<D>([1.0, -0.1, z])) - 0.1).abs() < 1e-12);
            assert!((g.depth(at::<D>([-0.2, 1.0, z])) - 0.2).abs() < 1e-12);
            // Above the open top (even beside the tank): it left through the opening.
            assert_eq!(g.depth(at::<D>([1.0, 3.5, z])), 0.0);
            assert_eq!(g.depth(at::<D>([-0.5, 3.5, z])), 0.0);
            // Inside the step: the distance to its nearest face.
            assert!((g.depth(at::<D>([2.1, 0.3, z])) - 0.1).abs() < 1e-12);
            assert!((g.depth(at::<D>([2.25, 0.45, z])) - 0.05).abs() < 1e-12);
            // Shifts towards the step stop halfway; towards the open top nothing stops them.
            let x = at::<D>([1.9, 0.25, z]);
            let s = g.limit_shift(x, at::<D>([0.08, 0.0, 0.0]));
            assert!((s.get(0) - 0.05).abs() < 1e-12, "{s:?}");
            let x = at::<D>([2.25, 0.58, z]);
            let s = g.limit_shift(x, at::<D>([0.0, -0.1, 0.0]));
            assert!((s.get(1) + 0.04).abs() < 1e-12, "{s:?}");
            let x = at::<D>([1.0, 2.95, z]);
            let s = g.limit_shift(x, at::<D>([0.0, 0.1, 0.0]));
            assert_eq!(s.get(1), 0.1);
            // A diagonal shift past the step's corner into it is cut until it stays outside.
            let x = at::<D>([1.98, 0.52, z]);
            let s = g.limit_shift(x, at::<D>([0.05, -0.05, 0.0]));
            assert_eq!(g.depth(x + s), 0.0, "{s:?}");
            assert!(s.length() > 0.0);
        }

        fn beyond_walls_is_outside_every_container_past_its_layers<D>() {
            // The open tank of the test above, walls 0.15 thick, with the solid step.
            let mut tank = WallBox::<D>::closed_container(at::<D>([0.0; 3]), at::<D>([4.0, 3.0, 1.0]));
            tank.open[1][1] = true;
            let step = WallBox::<D>::solid(at::<D>([2.0, 0.0, 0.0]), at::<D>([2.5, 0.5, 1.0]));
            let g = WallGeometry { boxes: vec![tank, step] };
            let (t, z) = (0.15, 0.5);
            // In the fluid, in the wall layers, above the opening, inside the solid: not beyond.
            for x in [[1.0, 1.0, z], [-0.1, 1.0, z], [1.0, -0.15, z], [0.01, 3.5, z], [2.25, 0.25, z]] {
                assert!(!g.beyond_walls(at::<D>(x), t), "{x:?}");
            }
            // Past the layers beside or below the tank (spray that came over the rim), or above
            // the rim beside the opening — on top of the wall layers or further out: beyond.
            for x in [[-0.5, 2.9, z], [4.2, 1.0, z], [1.0, -0.2, z], [-0.1, 3.001, z], [-0.5, 3.5, z], [4.1, 3.2, z]] {
                assert!(g.beyond_walls(at::<D>(x), t), "{x:?}");
            }
            // Without a container nothing is beyond, nor outside a closed box.
            let solid_only = WallGeometry { boxes: vec![step] };
            assert!(!solid_only.beyond_walls(at::<D>([-5.0, -5.0, z]), t));
            let closed = WallGeometry::<D>::closed_box(at::<D>([0.0; 3]), at::<D>([1.0; 3]));
            assert!(!closed.beyond_walls(at::<D>([-5.0, 0.5, 0.5]), t));
        }

        fn union_of_containers_is_the_fluid_region<D>() {
            // Two overlapping closed boxes: a point in either is in the fluid region.
            let a = WallBox::<D>::closed_container(at::<D>([0.0; 3]), at::<D>([1.0; 3]));
            let b = WallBox::<D>::closed_container(at::<D>([0.5, 0.0, 0.0]), at::<D>([2.0, 1.0, 1.0]));
            let g = WallGeometry { boxes: vec![a, b] };
            assert_eq!(g.depth(at::<D>([1.5, 0.5, 0.5])), 0.0);
            assert!((g.depth(at::<D>([2.1, 0.5, 0.5])) - 0.1).abs() < 1e-12);
        }
    }
}
