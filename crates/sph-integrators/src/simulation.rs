use crate::StepError;
use crate::config::SimConfig;
use crate::walls::{WallError, Walls};
use sph_core::{CoreError, Dim, MatrixOps, ParticleSet, Periodic, VectorOps};
use sph_kernels::{AnyKernel, Kernel};
use sph_neighbors::{AnySearch, CellGrid, NeighborList, NeighborSearch};
use sph_pressure::{AnySolver, CsrMatrix, LinearSolver, MeanZeroGauge};

/// A running simulation: the particles plus everything the schemes share (kernel, neighbour
/// search and lists, linear solver, scratch buffers). Buffers are allocated on the first step
/// and reused, so the step loop does not allocate once sizes are stable.
pub struct Simulation<D: Dim> {
    /// The particles (structure of arrays).
    pub particles: ParticleSet<D>,
    /// Simulated time.
    pub t: f64,
    /// Number of completed steps.
    pub step: usize,
    pub(crate) engine: Engine<D>,
    pub(crate) buf: Buffers<D>,
    pub(crate) order: Order<D>,
}

/// The particles' numbering under [`SimConfig::reorder_every`]: which particle of the initial
/// state each slot of [`Simulation::particles`] holds, the inverse map, and the renumbering's
/// scratch (kept, so renumbering does not allocate once sizes are stable).
pub(crate) struct Order<D: Dim> {
    /// `ids[slot]`: the particle's index in the initial state.
    pub(crate) ids: Vec<u32>,
    /// `slots[id]`: the slot particle `id` is in now.
    pub(crate) slots: Vec<u32>,
    grid: CellGrid<D>,
    perm: Vec<u32>,
    vectors: Vec<D::Vector>,
    scalars: Vec<f64>,
    indices: Vec<u32>,
}

impl<D: Dim> Order<D> {
    fn new() -> Self {
        Self {
            ids: Vec::new(),
            slots: Vec::new(),
            grid: CellGrid::new(),
            perm: Vec::new(),
            vectors: Vec::new(),
            scalars: Vec::new(),
            indices: Vec::new(),
        }
    }

    /// `slots` as the inverse of `ids` (a permutation).
    pub(crate) fn index_slots(&mut self) {
        self.slots.resize(self.ids.len(), 0);
        for (slot, &id) in self.ids.iter().enumerate() {
            self.slots[id as usize] = slot as u32;
        }
    }

    /// The identity numbering of `n` particles, unless the numbering already has that size.
    fn ensure(&mut self, n: usize) {
        if self.ids.len() != n || self.slots.len() != n {
            self.ids.clear();
            self.ids.extend(0..n as u32);
            self.slots.clone_from(&self.ids);
        }
    }
}

/// `v[k] = v_old[perm[k]]` for `k < perm.len()` (the rest of `v` unchanged), through `scratch`.
fn gather<T: Copy>(v: &mut [T], perm: &[u32], scratch: &mut Vec<T>) {
    scratch.clear();
    scratch.extend(perm.iter().map(|&i| v[i as usize]));
    v[..perm.len()].copy_from_slice(scratch);
}

/// Kernel, search, solver and per-step scratch of the projection.
pub(crate) struct Engine<D: Dim> {
    pub(crate) config: SimConfig,
    /// Number of fluid particles (the first ones); the rest are wall particles.
    pub(crate) fluid: usize,
    pub(crate) walls: Option<Walls<D>>,
    /// Periodic axes of the domain, if any.
    pub(crate) periodic: Option<Periodic<D>>,
    /// Velocities the divergence reads (fluid: u; walls: free-slip mirror).
    pub(crate) u_div: Vec<D::Vector>,
    /// Neumann data `∇p/ρ` of each wall particle's pressure row.
    pub(crate) wall_grad: Vec<D::Vector>,
    pub(crate) kernel: AnyKernel<D>,
    pub(crate) search: AnySearch<D>,
    pub(crate) neighbors: NeighborList,
    /// Kernel-gradient factors `(dW/dr)/r` of every entry of `neighbors`, computed with the
    /// lists and read by every pass of the step (through `engine_context!`).
    pub(crate) grad_factors: Vec<f64>,
    /// Kernel values `W_ij` of every entry of `neighbors`, computed with the factors when the
    /// scene declares shifting (whose concentration term reads them); empty otherwise.
    pub(crate) kernel_values: Vec<f64>,
    pub(crate) solver: AnySolver,
    pub(crate) volumes: Vec<f64>,
    pub(crate) corrections: Vec<D::Matrix>,
    pub(crate) div_r: Vec<f64>,
    pub(crate) dirichlet: Vec<bool>,
    /// All `false`: the flags the assembly gets when the surface rows are Robin rows.
    pub(crate) no_dirichlet: Vec<bool>,
    pub(crate) source: Vec<f64>,
    /// Density correction: each fluid particle's kernel-sum excess, and whether a free-surface
    /// particle is in its support (then its excess is not corrected).
    pub(crate) excess: Vec<f64>,
    pub(crate) surface_band: Vec<bool>,
    /// Where each free-surface particle's Robin row puts `p = 0`: `FreeSurface::zero_pressure_depth`,
    /// or as its truncation says (`FreeSurface::measured_depth`); fluid only.
    pub(crate) surface_depth: Vec<f64>,
    /// The cut-lattice table of the band's completed pressure rows and the particle volume it
    /// was built for (rebuilt only when the volume changes).
    pub(crate) cut_lattice: Option<(f64, sph_operators::CutLattice)>,
    /// Density correction: the solver of its equation when the projection's is another one
    /// (DG-ISPH), its potential `q` and the displacements `−Δt² ∇q/ρ` it hands the scheme.
    pub(crate) correction_solver: AnySolver,
    pub(crate) potential: Vec<f64>,
    pub(crate) correction: Vec<D::Vector>,
    pub(crate) a: Vec<D::Matrix>,
    pub(crate) rhs: Vec<f64>,
    pub(crate) matrix: CsrMatrix,
    pub(crate) grad_p: Vec<D::Vector>,
    /// Level-consistent projection: `p ≡ 1` and its symmetric gradient `c_i` per particle (zero in
    /// the free surface's band, `surface_band`, which it shares with the density correction).
    pub(crate) ones: Vec<f64>,
    pub(crate) level: Vec<D::Vector>,
    pub(crate) scalar: Vec<f64>,
    pub(crate) gauge: MeanZeroGauge,
    /// Lists prepared at `xⁿ` and set aside while the predictor–corrector scheme projects at the
    /// predicted positions, so its det F diagnostics need no second build at `xⁿ`.
    pub(crate) saved: SavedLists<D>,
}

/// The operators' view of configuration `x` from engine `e`: its volumes, neighbour lists,
/// kernel, periodic axes and the lists' kernel-gradient factors. `x` must be the configuration
/// the lists were last built for by [`prepare`](crate::projection::prepare). A macro, not a
/// method, so the engine's other fields stay free to borrow mutably beside it.
macro_rules! engine_context {
    ($e:expr, $x:expr) => {
        engine_context!($e, $x, &$e.kernel)
    };
    // With the concrete kernel `$k` taken out of the engine's `AnyKernel` by
    // `sph_kernels::with_kernel!`, for passes that still evaluate the kernel per pair.
    ($e:expr, $x:expr, $k:expr) => {{
        let ctx = sph_operators::SphContext::new($x, &$e.volumes, &$e.neighbors, $k)
            .with_periodic($e.periodic)
            .with_grad_factors(&$e.grad_factors);
        if $e.kernel_values.is_empty() {
            ctx
        } else {
            ctx.with_kernel_values(&$e.kernel_values)
        }
    }};
}
pub(crate) use engine_context;

/// Neighbour lists, volumes, corrections and `∇·r` of one configuration, kept for later reuse
/// (swapped with the engine's, never copied).
pub(crate) struct SavedLists<D: Dim> {
    pub(crate) neighbors: NeighborList,
    pub(crate) grad_factors: Vec<f64>,
    pub(crate) kernel_values: Vec<f64>,
    pub(crate) volumes: Vec<f64>,
    pub(crate) corrections: Vec<D::Matrix>,
    pub(crate) div_r: Vec<f64>,
    /// Whether the saved lists belong to the current step's `xⁿ`.
    pub(crate) valid: bool,
}

impl<D: Dim> Engine<D> {
    /// Exchanges the engine's lists (neighbours, volumes, corrections, `∇·r`) with the saved set.
    /// The saved buffers are sized on first use (allocation-free from the second step on).
    pub(crate) fn swap_saved(&mut self) {
        let s = &mut self.saved;
        let n = self.volumes.len();
        s.volumes.resize(n, 0.0);
        s.corrections.resize(n, D::Matrix::IDENTITY);
        s.div_r.resize(n, 0.0);
        std::mem::swap(&mut self.neighbors, &mut s.neighbors);
        std::mem::swap(&mut self.grad_factors, &mut s.grad_factors);
        std::mem::swap(&mut self.kernel_values, &mut s.kernel_values);
        std::mem::swap(&mut self.volumes, &mut s.volumes);
        std::mem::swap(&mut self.corrections, &mut s.corrections);
        std::mem::swap(&mut self.div_r, &mut s.div_r);
    }
}

/// Velocity and position buffers of the schemes.
pub(crate) struct Buffers<D: Dim> {
    pub(crate) u_star: Vec<D::Vector>,
    pub(crate) u_new: Vec<D::Vector>,
    pub(crate) x_pred: Vec<D::Vector>,
    pub(crate) disp: Vec<D::Vector>,
    pub(crate) det_f: Vec<D::Matrix>,
    pub(crate) p_work: Vec<f64>,
    pub(crate) flags: Vec<bool>,
    /// Explicit acceleration (viscosity, gravity) and the velocity the viscous term reads.
    pub(crate) acc: Vec<D::Vector>,
    pub(crate) u_visc: Vec<D::Vector>,
    /// The uncorrected viscous acceleration of every particle (walls: zero), for
    /// [`ViscousOperator::Corrected`](crate::ViscousOperator::Corrected).
    pub(crate) visc_acc: Vec<D::Vector>,
    /// The hyperviscous term's gradient and first-pass scratch (fluid).
    pub(crate) hv_grad: Vec<D::Matrix>,
    pub(crate) hv_lap: Vec<D::Vector>,
    /// Shifting: ∇C and ∇uⁿ⁺¹.
    pub(crate) grad_c: Vec<D::Vector>,
    pub(crate) grad_u: Vec<D::Matrix>,
    /// Shifting: the velocities before the shift's correction (the limiter's range).
    pub(crate) u_shift: Vec<D::Vector>,
}

// A simulation can be moved to and shared between threads.
const _: fn() = || {
    fn is_send_sync<T: Send + Sync>() {}
    is_send_sync::<Simulation<sph_core::D2>>();
    is_send_sync::<Simulation<sph_core::D3>>();
};

impl<D: Dim> Simulation<D> {
    /// A simulation of `particles` with `config`; fails if the particle arrays are inconsistent
    /// or hold non-finite values, or if the periodic axes are invalid (an empty box, or a period
    /// not above twice the kernel support). On periodic axes the positions are wrapped into the
    /// periodic box.
    pub fn new(mut particles: ParticleSet<D>, config: SimConfig) -> Result<Self, CoreError> {
        particles.validate()?;
        let kernel = config.kernel.build::<D>(config.h);
        let periodic = match config.periodic {
            Some(a) => {
                let v = |c: [f64; 3]| D::Vector::from_fn(|k| c[k]);
                let p = Periodic::<D>::new(v(a.lo), v(a.hi), a.axes)?;
                p.check_radius(kernel.support_radius())?;
                for x in particles.positions.iter_mut() {
                    *x = p.wrap(*x);
                }
                Some(p)
            }
            None => None,
        };
        let mut search = AnySearch::new(config.search);
        search.set_periodic(periodic);
        let engine = Engine {
            kernel,
            periodic,
            search,
            neighbors: NeighborList::new(),
            grad_factors: Vec::new(),
            kernel_values: Vec::new(),
            solver: AnySolver::new(config.solver),
            volumes: Vec::new(),
            corrections: Vec::new(),
            div_r: Vec::new(),
            dirichlet: Vec::new(),
            no_dirichlet: Vec::new(),
            source: Vec::new(),
            excess: Vec::new(),
            surface_band: Vec::new(),
            surface_depth: Vec::new(),
            cut_lattice: None,
            correction_solver: AnySolver::new(config.solver),
            potential: Vec::new(),
            correction: Vec::new(),
            a: Vec::new(),
            rhs: Vec::new(),
            matrix: CsrMatrix::default(),
            grad_p: Vec::new(),
            ones: Vec::new(),
            level: Vec::new(),
            scalar: Vec::new(),
            gauge: MeanZeroGauge::default(),
            saved: SavedLists {
                neighbors: NeighborList::new(),
                grad_factors: Vec::new(),
                kernel_values: Vec::new(),
                volumes: Vec::new(),
                corrections: Vec::new(),
                div_r: Vec::new(),
                valid: false,
            },
            fluid: particles.len(),
            walls: None,
            u_div: Vec::new(),
            wall_grad: Vec::new(),
            config,
        };
        let buf = Buffers {
            u_star: Vec::new(),
            u_new: Vec::new(),
            x_pred: Vec::new(),
            disp: Vec::new(),
            det_f: Vec::new(),
            p_work: Vec::new(),
            flags: Vec::new(),
            acc: Vec::new(),
            u_visc: Vec::new(),
            visc_acc: Vec::new(),
            hv_grad: Vec::new(),
            hv_lap: Vec::new(),
            grad_c: Vec::new(),
            grad_u: Vec::new(),
            u_shift: Vec::new(),
        };
        let mut order = Order::new();
        order.ensure(particles.len());
        Ok(Self {
            particles,
            t: 0.0,
            step: 0,
            engine,
            buf,
            order,
        })
    }

    /// A simulation of a fluid in walls: `particles` holds the fluid particles `0..walls.first`
    /// followed by the wall particles, whose velocities are set to `walls.velocity`.
    pub fn with_walls(
        mut particles: ParticleSet<D>,
        config: SimConfig,
        walls: Walls<D>,
    ) -> Result<Self, WallError> {
        walls.check(particles.len())?;
        particles.velocities[walls.first..].copy_from_slice(&walls.velocity);
        let mut walls = walls;
        let g = config.effects.gravity.unwrap_or([0.0; 3]);
        walls
            .refresh(&mut particles, D::Vector::from_fn(|k| g[k]))
            .map_err(|(needed, slots)| WallError::GhostCapacity { needed, slots })?;
        let mut sim = Self::new(particles, config)?;
        sim.engine.fluid = walls.first;
        sim.engine.walls = Some(walls);
        Ok(sim)
    }

    /// The walls, if any.
    pub fn walls(&self) -> Option<&Walls<D>> {
        self.engine.walls.as_ref()
    }

    /// Brings mirror ghosts up to date with the fluid particles (see [`Walls::refresh`]);
    /// nothing for dummy wall particles. On failure (too few ghost slots) the particles are
    /// unchanged.
    pub(crate) fn refresh_walls(&mut self) -> Result<(), StepError> {
        let Some(w) = &mut self.engine.walls else {
            return Ok(());
        };
        let g = self.engine.config.effects.gravity.unwrap_or([0.0; 3]);
        w.refresh(&mut self.particles, D::Vector::from_fn(|k| g[k]))
            .map_err(|(needed, slots)| StepError::GhostCapacity {
                step: self.step,
                t: self.t,
                needed,
                slots,
            })
    }

    /// Number of fluid particles (the first ones of [`Simulation::particles`]).
    pub fn fluid_len(&self) -> usize {
        self.engine.fluid
    }

    /// Fluid particles outside the wall container (0 without walls).
    pub fn wall_penetrations(&self) -> usize {
        self.engine
            .walls
            .as_ref()
            .map_or(0, |w| w.penetrations(&self.particles.positions))
    }

    /// Fluid particles that have left the domain over an open container's rim and are held
    /// there ([`Walls::beyond`]; 0 without walls).
    pub fn left_domain(&self) -> usize {
        self.engine
            .walls
            .as_ref()
            .map_or(0, |w| w.left_domain(&self.particles.positions))
    }

    /// Depth of the furthest fluid particle outside the wall container (0 without walls or
    /// when every fluid particle is inside), see [`Walls::max_intrusion`].
    pub fn wall_intrusion(&self) -> f64 {
        self.engine
            .walls
            .as_ref()
            .map_or(0.0, |w| w.max_intrusion(&self.particles.positions))
    }

    /// Multiplier of the mean-zero pressure gauge in the last step (0 unless the domain is
    /// closed): the part of the pressure equation's right-hand side incompatible with a
    /// constant null space.
    pub fn gauge_multiplier(&self) -> f64 {
        self.engine.gauge.last_multiplier
    }

    /// For each slot of [`Simulation::particles`], the index the particle had in the initial
    /// state. The identity unless [`SimConfig::reorder_every`] renumbers the fluid particles
    /// (wall particles keep their slots); [`Frame`](crate::Frame) presents the particles in
    /// this initial numbering.
    pub fn ids(&self) -> &[u32] {
        &self.order.ids
    }

    /// The slot of [`Simulation::particles`] that holds the particle with initial index `id`
    /// (`id` itself if the particle set was replaced since the last step).
    pub fn slot(&self, id: usize) -> usize {
        match self.order.slots.get(id) {
            Some(&s) if self.order.slots.len() == self.particles.len() => s as usize,
            _ => id,
        }
    }

    /// Renumbers the fluid particles in the neighbour grid's cell order (see
    /// [`SimConfig::reorder_every`]): their positions, velocities, masses, densities, pressures
    /// and ids are permuted alike. The solver's kept set-up (whose aggregates are numbered by
    /// slot) is dropped in any case, so that whether the step after a renumbering starts its
    /// solver afresh is known before it (see [`Simulation::solver_keeps_nothing`]).
    pub(crate) fn reorder_by_cell(&mut self) {
        self.invalidate_solver_setup();
        let n = self.particles.len();
        self.order.ensure(n);
        let nf = self.engine.fluid.min(n);
        let o = &mut self.order;
        let radius = self.engine.kernel.support_radius();
        // The grid over all particles, as the step's search builds it (same origin and cells),
        // so each of its runs of cells holds consecutive fluid slots and rows come out sorted.
        if nf < 2 || o.grid.build(&self.particles.positions, radius).is_err() {
            return;
        }
        o.perm.clear();
        o.perm
            .extend(o.grid.cell_order().iter().filter(|&&i| (i as usize) < nf));
        if o.perm.iter().enumerate().all(|(k, &i)| k == i as usize) {
            return;
        }
        let p = &mut self.particles;
        gather(&mut p.positions, &o.perm, &mut o.vectors);
        gather(&mut p.velocities, &o.perm, &mut o.vectors);
        gather(&mut p.masses, &o.perm, &mut o.scalars);
        gather(&mut p.densities, &o.perm, &mut o.scalars);
        gather(&mut p.pressures, &o.perm, &mut o.scalars);
        gather(&mut o.ids, &o.perm, &mut o.indices);
        o.index_slots();
    }

    /// Forgets the set-up work the linear solvers keep between steps (the AMG hierarchies of the
    /// projection's solver and of the density correction's), so the next step solves as a
    /// simulation restored from a checkpoint of this state would. The run loop calls it after
    /// every periodic checkpoint; [`Simulation::restore`] calls it too.
    pub fn invalidate_solver_setup(&mut self) {
        self.engine.solver.invalidate_setup();
        self.engine.correction_solver.invalidate_setup();
    }

    /// Whether the next step's solves start as a restored simulation's would: neither linear
    /// solver (the projection's, the density correction's) keeps anything from earlier steps
    /// that it would use (an AMG hierarchy is kept for up to 10 solves, then rebuilt). A
    /// checkpoint taken where this holds resumes to the same bits as the run that goes on.
    pub fn solver_keeps_nothing(&self) -> bool {
        self.renumbers_next()
            || (self.engine.solver.next_solve_is_fresh()
                && self.engine.correction_solver.next_solve_is_fresh())
    }

    /// Whether the next step starts by renumbering the particles (every
    /// [`SimConfig::reorder_every`] steps).
    pub(crate) fn renumbers_next(&self) -> bool {
        let every = self.engine.config.reorder_every;
        every > 0 && self.step > 0 && self.step.is_multiple_of(every)
    }

    /// The configuration.
    pub fn config(&self) -> &SimConfig {
        &self.engine.config
    }

    /// The smoothing kernel.
    pub fn kernel(&self) -> &AnyKernel<D> {
        &self.engine.kernel
    }

    /// Free-surface (Dirichlet) flags of the last projection, one per particle (empty before
    /// the first step).
    pub fn free_surface_flags(&self) -> &[bool] {
        &self.engine.dirichlet
    }

    /// `∇·r` of the last projection, one per particle (empty before the first step; zeros when
    /// the configuration has no free surface, since the pass is then skipped).
    pub fn div_r(&self) -> &[f64] {
        &self.engine.div_r
    }

    /// Neighbour lists of the last projection.
    pub fn neighbors(&self) -> &NeighborList {
        &self.engine.neighbors
    }

    /// Kernel support radius.
    pub fn support_radius(&self) -> f64 {
        self.engine.kernel.support_radius()
    }

    /// Periodic axes of the domain, if any.
    pub fn periodic(&self) -> Option<&Periodic<D>> {
        self.engine.periodic.as_ref()
    }

    /// Largest particle speed.
    pub fn max_speed(&self) -> f64 {
        self.particles
            .velocities
            .iter()
            .map(|u| u.length())
            .fold(0.0, f64::max)
    }

    /// Resizes every buffer to the particle count.
    pub(crate) fn ensure_buffers(&mut self) {
        let n = self.particles.len();
        self.order.ensure(n);
        let e = &mut self.engine;
        e.volumes.resize(n, 0.0);
        e.corrections.resize(n, D::Matrix::IDENTITY);
        e.div_r.resize(n, 0.0);
        e.dirichlet.resize(n, false);
        e.no_dirichlet.resize(n, false);
        e.source.resize(n, 0.0);
        if e.config.density_relaxation > 0.0
            || e.config.level_consistent
            || e.config.normalised_gradient
            || e.config.free_surface.is_some_and(|f| f.complete_band)
        {
            e.surface_band.resize(n, false);
        }
        if e.config
            .free_surface
            .is_some_and(|f| f.zero_pressure_depth > 0.0)
        {
            e.surface_depth.resize(n, 0.0);
        }
        if e.config.density_relaxation > 0.0 {
            e.excess.resize(n, 0.0);
            e.potential.resize(n, 0.0);
            e.correction.resize(n, D::Vector::ZERO);
        }
        e.a.resize(n, D::Matrix::IDENTITY);
        e.rhs.resize(n, 0.0);
        e.grad_p.resize(n, D::Vector::ZERO);
        if e.config.level_consistent {
            e.ones.resize(n, 1.0);
            e.level.resize(n, D::Vector::ZERO);
        }
        e.scalar.resize(n, 0.0);
        if let Some(w) = &e.walls {
            e.u_div.resize(n, D::Vector::ZERO);
            e.wall_grad.resize(w.velocity.len(), D::Vector::ZERO);
        }
        let b = &mut self.buf;
        b.u_star.resize(n, D::Vector::ZERO);
        b.u_new.resize(n, D::Vector::ZERO);
        b.x_pred.resize(n, D::Vector::ZERO);
        b.disp.resize(n, D::Vector::ZERO);
        b.det_f.resize(n, D::Matrix::IDENTITY);
        b.p_work.resize(n, 0.0);
        b.flags.resize(n, false);
        let fx = &self.engine.config.effects;
        if fx.viscosity.is_some() || fx.gravity.is_some() || fx.hyperviscosity.is_some() {
            b.acc.resize(n, D::Vector::ZERO);
        }
        // The viscous term's own buffers: not for gravity or hyperviscosity alone.
        if fx.viscosity.is_some() {
            b.u_visc.resize(n, D::Vector::ZERO);
            b.visc_acc.resize(n, D::Vector::ZERO);
        }
        if fx.hyperviscosity.is_some() {
            b.hv_grad.resize(n, D::Matrix::ZERO);
            b.hv_lap.resize(n, D::Vector::ZERO);
        }
        if fx.shifting.is_some() {
            b.grad_c.resize(n, D::Vector::ZERO);
            b.grad_u.resize(n, D::Matrix::IDENTITY);
            b.u_shift.resize(n, D::Vector::ZERO);
        }
    }
}
