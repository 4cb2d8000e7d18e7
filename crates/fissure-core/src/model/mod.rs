//! `ModelBuilder` → `finalize()` → [`Model`] → `model.state()` → [`State`].
//!
//! The model is struct-of-arrays with prefix-first names and SI units. It holds everything that does not change
//! during a step: masses, springs with their rest lengths and coefficients, triangles, bodies with their gas,
//! the adjacency lists the force gathers walk, gravity, wind and colliders. The state holds only positions and
//! velocities.

use crate::collision::Collider;
use crate::csr::Csr;
use crate::error::{MeshError, ModelError};
use crate::mesh::{Mesh, tri_area};
use crate::real::{Real, Vector3};
use crate::topology::{NONE, Topology, connected_components};
use crate::wind::{Aero, WindField};
use glam::DVec3;

mod builder;
pub(crate) mod edit;
mod invariants;
mod options;
mod state;

pub use builder::ModelBuilder;
pub use invariants::check_invariants;
pub use options::{
    BodyHandle, BodyKind, Breakable, ClothOptions, Damping, DampingModel, Gas, Handle, Mass, Opening, SoftBodyOptions,
    SpringKind, Stiffness,
};
pub use state::{Energy, State};

/// Declares [`Model`] once: each group of per-item arrays (per particle, per spring, per triangle, per body) is
/// listed here alone, and the macro derives from that list the struct's fields, a row type holding one item of
/// the group (`ParticleRow`, ...), `push_*` (append one row to every array of the group) and `reserve_*`. Adding an
/// attribute is one edit here; the compiler then points at every place that must give it a value (the builder's
/// `finalize` and the row constructors of the fracture edits).
macro_rules! model_arrays {
    (
        $(#[$meta:meta])*
        pub struct Model<R: Real = f32> {
            $(
                group $row:ident $(<$g:ident>)? ($gdoc:literal), $push:ident, $reserve:ident {
                    $( $(#[$fdoc:meta])* $field:ident / $rf:ident : $ty:ty, )*
                }
            )*
            others {
                $( $(#[$odoc:meta])* $other:ident : $oty:ty, )*
            }
        }
    ) => {
        $(#[$meta])*
        pub struct Model<R: Real = f32> {
            $( $( $(#[$fdoc])* pub $field: Vec<$ty>, )* )*
            $( $(#[$odoc])* pub $other: $oty, )*
        }

        $(
            #[doc = $gdoc]
            #[derive(Clone, Debug, PartialEq)]
            pub struct $row $(<$g: Real = f32>)? {
                $( $(#[$fdoc])* pub $rf: $ty, )*
            }
        )*

        impl<R: Real> Model<R> {
            $(
                /// Appends one item to every array of its group; returns its index.
                pub fn $push(&mut self, row: $row $(<$g>)?) -> usize {
                    $( self.$field.push(row.$rf); )*
                    model_arrays!(@first self, $($field),*).len() - 1
                }

                /// Reserves room for `n` more items in every array of the group.
                pub fn $reserve(&mut self, n: usize) {
                    $( self.$field.reserve(n); )*
                }
            )*
        }
    };
    (@first $s:ident, $f:ident $(, $rest:ident)*) => { $s.$f };
}

model_arrays! {
    /// Everything a step reads but does not write. See the crate docs for units.
    #[derive(Clone, Debug, Default)]
    #[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
    #[cfg_attr(feature = "serde", serde(bound(serialize = "R: serde::Serialize, R::V: serde::Serialize", deserialize = "R: serde::Deserialize<'de>, R::V: serde::Deserialize<'de>")))]
    pub struct Model<R: Real = f32> {
        group ParticleRow<R> ("One particle (a mass point) of a [`Model`]."), push_particle, reserve_particles {
            /// Initial positions \[m\].
            particle_q0 / q0: R::V,
            /// Initial velocities \[m/s\].
            particle_qd0 / qd0: R::V,
            /// Mass \[kg\] (pinned particles keep theirs for accounting).
            particle_mass / mass: R,
            /// Inverse mass [1/kg]; 0 pins a particle.
            particle_inv_mass / inv_mass: R,
            /// Owning body, or `u32::MAX` for free particles.
            particle_body / body: u32,
            /// Load \[N\] past which each particle breaks out as a core block (infinity: never); see the `fracture`
            /// module.
            particle_load_limit / load_limit: R,
            /// The particle each one was split from by fracture (itself for the builder's particles): contact
            /// ignores pairs of elements that share an origin (see the `contact` module).
            particle_origin / origin: u32,
            /// The [`Handle`] moving each particle (an index into `handles`), or `u32::MAX` for none.
            particle_handle / handle: u32,
        }
        group SpringRow<R> ("One spring of a [`Model`]."), push_spring, reserve_springs {
            /// Spring ends `[i, j]`.
            spring_indices / indices: [u32; 2],
            /// Rest length `L0` \[m\].
            spring_rest_length / rest_length: R,
            /// Stiffness `ks` \[N/m\].
            spring_stiffness / stiffness: R,
            /// Damping `kd` \[N·s/m\].
            spring_damping / damping: R,
            /// What each spring represents.
            spring_kind / kind: SpringKind,
            /// Strain `(l - L0) / L0` past which each spring breaks (infinity: never).
            spring_strain_limit / strain_limit: R,
        }
        group TriRow ("One triangle of a [`Model`]."), push_tri, reserve_tris {
            /// Triangles, counter-clockwise from outside.
            tri_indices / indices: [u32; 3],
            /// Owning body of each triangle.
            tri_body / body: u32,
        }
        group BodyRow<R> ("One body of a [`Model`]."), push_body, reserve_bodies {
            /// Kind of each body.
            body_kind / kind: BodyKind,
            /// `nRT` \[J\] of each body's gas (0: none).
            body_gas_amount / gas_amount: R,
            /// Gas pumped in per second while the body has no opening, as `nRT` \[J/s\].
            body_gas_inflow / gas_inflow: R,
            /// Outside pressure \[Pa\].
            body_pressure_external / pressure_external: R,
            /// Volume at rest \[m^3\] (0 for open bodies). Volumes are clamped at
            /// [`crate::forces::pressure::MIN_VOLUME_FRACTION`] of it so an inverted body's pressure stays finite.
            body_rest_volume / rest_volume: R,
            /// Drag coefficient.
            body_drag / drag: R,
            /// Lift coefficient.
            body_lift / lift: R,
            /// A particle of each body about which its volume is summed (round-off control only).
            body_anchor / anchor: u32,
            /// Whether each body keeps its gas when punctured.
            body_sealed / sealed: bool,
            /// Contact thickness \[m\] of each body; 0: the body takes no part in contact (see the `contact`
            /// module).
            body_contact_thickness / contact_thickness: R,
            /// Whether each body's surface also collides with itself.
            body_self_contact / self_contact: bool,
            /// Coulomb friction coefficient of each body's contacts.
            body_contact_friction / contact_friction: R,
        }
        others {
        /// Openings of the gas bodies (none until something breaks).
        openings: Vec<Opening>,
        /// Derived: some spring or particle can break (only then does the fracture pass do any work).
        breakable: bool,
        /// Springs of each particle: entry `s << 1 | end`, `end` 0 for `spring_indices[s]\[0\]`.
        particle_springs: Csr,
        /// Triangles of each particle.
        particle_tris: Csr,
        /// Maximal runs of consecutive springs whose ends advance together (see [`SpringRun`]); derived. Empty when
        /// the runs would be too short to pay (irregular meshes): the gather kernel is used then.
        spring_runs: Vec<SpringRun>,
        /// The cloth grids among the triangles, as [`crate::Mesh::grid`] lays them out (recorded by
        /// [`ModelBuilder::add_cloth_grid`]; see [`TriGrid`]). Fracture may change some of their triangles
        /// afterwards: the wind pass checks each one.
        tri_grids: Vec<TriGrid>,
        /// Gravity \[m/s^2\].
        gravity: R::V,
        /// Damping form.
        damping_model: DampingModel,
        /// Wind, if any.
        wind: Option<WindField>,
        /// Colliders.
        colliders: Vec<Collider>,
        /// Moving pins; their particles are marked in `particle_handle`.
        handles: Vec<Handle>,
        }
    }
}

/// An `nx × ny` cloth grid's triangles as [`crate::Mesh::grid`] lays them out: particle `base + j nx + i` at
/// column `i`, row `j`; quad `(i, j)`'s two triangles at `first + 2 (j (nx - 1) + i)`, split along one diagonal
/// or the other by the parity of `i + j` ([`TriGrid::quad`]). The wind pass computes such triangles a row of
/// quads at a time from contiguous rows of particles, and sums them per particle without a gather
/// (`forces::wind_grid`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct TriGrid {
    /// First triangle.
    pub first: u32,
    /// Particle at column 0, row 0.
    pub base: u32,
    /// Particles per row.
    pub nx: u32,
    /// Rows.
    pub ny: u32,
}

impl TriGrid {
    /// Triangles in the grid.
    pub fn tri_count(&self) -> usize {
        2 * (self.nx as usize - 1) * (self.ny as usize - 1)
    }

    /// The two triangles of quad `(i, j)` as laid out (`i < nx - 1`, `j < ny - 1`), corners counter-clockwise as
    /// in [`crate::Mesh::grid`].
    pub fn quad(&self, i: u32, j: u32) -> [[u32; 3]; 2] {
        let v = |a: u32, b: u32| self.base + b * self.nx + a;
        let (p00, p10, p01, p11) = (v(i, j), v(i + 1, j), v(i, j + 1), v(i + 1, j + 1));
        if (i + j).is_multiple_of(2) { [[p00, p01, p11], [p00, p11, p10]] } else { [[p00, p01, p10], [p10, p01, p11]] }
    }
}

/// Springs `first + k` for `k < len` with ends `(i + k, j + k)`. Cloth grids consist of a few hundred such runs;
/// the solver then computes spring forces on contiguous slices, per block of particles, without the per-spring
/// force buffer and index gather that an irregular mesh needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct SpringRun {
    /// First spring.
    pub first: u32,
    /// End 0 of the first spring.
    pub i: u32,
    /// End 1 of the first spring.
    pub j: u32,
    /// Number of springs.
    pub len: u32,
}

impl SpringRun {
    /// [`SpringRun::detect`] if the runs are long enough for the run kernel (average ≥ 16), else empty: a model
    /// keeps runs only while it uses them.
    pub fn detect_if_useful(springs: &[[u32; 2]]) -> Vec<SpringRun> {
        let runs = Self::detect(springs);
        if springs.len() >= 16 * runs.len() { runs } else { Vec::new() }
    }

    /// Splits `springs` into maximal runs.
    pub fn detect(springs: &[[u32; 2]]) -> Vec<SpringRun> {
        let mut runs: Vec<SpringRun> = Vec::new();
        for (s, &[i, j]) in springs.iter().enumerate() {
            match runs.last_mut() {
                Some(r) if r.i.wrapping_add(r.len) == i && r.j.wrapping_add(r.len) == j => r.len += 1,
                _ => runs.push(SpringRun { first: s as u32, i, j, len: 1 }),
            }
        }
        runs
    }
}

impl<R: Real> Model<R> {
    /// The initial state.
    pub fn state(&self) -> State<R> {
        State { particle_q: self.particle_q0.clone(), particle_qd: self.particle_qd0.clone(), time: 0.0 }
    }
    /// Number of particles.
    pub fn particle_count(&self) -> usize {
        self.particle_q0.len()
    }
    /// Number of springs.
    pub fn spring_count(&self) -> usize {
        self.spring_indices.len()
    }
    /// Number of triangles.
    pub fn tri_count(&self) -> usize {
        self.tri_indices.len()
    }
    /// Number of bodies.
    pub fn body_count(&self) -> usize {
        self.body_kind.len()
    }
    /// Number of springs that have not broken.
    pub fn live_spring_count(&self) -> usize {
        self.spring_kind.iter().filter(|&&k| k != SpringKind::Broken).count()
    }
    /// True if something can break (a finite strain or load limit): only then does the fracture pass run.
    pub fn has_fracture(&self) -> bool {
        self.breakable
    }
    /// Scans the limits for [`Model::breakable`].
    pub fn compute_breakable(&self) -> bool {
        self.spring_strain_limit.iter().zip(&self.spring_kind).any(|(l, &k)| l.is_finite() && k != SpringKind::Broken)
            || self.particle_load_limit.iter().any(|l| l.is_finite())
    }
    /// True if any body holds gas: only then is the pressure pass run.
    pub fn has_pressure(&self) -> bool {
        self.body_gas_amount.iter().any(|&g| g > R::ZERO)
    }
    /// True if there is wind and a body that feels it: only then is the aerodynamics pass run.
    pub fn has_wind(&self) -> bool {
        self.wind.is_some() && self.body_drag.iter().zip(&self.body_lift).any(|(&d, &l)| d != R::ZERO || l != R::ZERO)
    }
    /// True if some body takes part in contact: only then is the contact pass run.
    pub fn has_contact(&self) -> bool {
        self.body_contact_thickness.iter().any(|&h| h > R::ZERO)
    }
    /// True if some particles move on a [`Handle`]'s path: only then does the solver move them.
    pub fn has_handles(&self) -> bool {
        !self.handles.is_empty()
    }
    /// True if there are colliders: only then is the collision pass run.
    pub fn has_colliders(&self) -> bool {
        !self.colliders.is_empty()
    }
    /// Total mass \[kg\], summed in `f64`.
    pub fn total_mass(&self) -> f64 {
        self.particle_mass.iter().map(|m| m.to_f64()).sum()
    }

    /// Enclosed volume of each body \[m^3\] (0 for bodies without gas), `f64`.
    pub fn body_volumes(&self, state: &State<R>) -> Vec<f64> {
        let mut vol = vec![0.0; self.body_count()];
        // Runs of triangles of one body (the usual layout) accumulate in a register.
        let mut run = (u32::MAX, DVec3::ZERO, 0.0);
        for (tri, &b) in self.tri_indices.iter().zip(&self.tri_body) {
            if b != run.0 {
                if run.0 != u32::MAX {
                    vol[run.0 as usize] += run.2;
                }
                run = (b, state.particle_q[self.body_anchor[b as usize] as usize].to_dvec3(), 0.0);
            }
            let c = run.1;
            let [x0, x1, x2] = tri.map(|i| state.particle_q[i as usize].to_dvec3() - c);
            run.2 += x0.dot(x1.cross(x2));
        }
        if run.0 != u32::MAX {
            vol[run.0 as usize] += run.2;
        }
        for v in &mut vol {
            *v /= 6.0;
        }
        for o in &self.openings {
            let b = o.body as usize;
            let c = state.particle_q[self.body_anchor[b] as usize].to_dvec3();
            let x = |i: u32| state.particle_q[i as usize].to_dvec3() - c;
            let n = o.vertices.len();
            let centre = o.vertices.iter().map(|&i| x(i)).sum::<DVec3>() / n as f64;
            for k in 0..n {
                let (i, j) = (o.vertices[k], o.vertices[(k + 1) % n]);
                vol[b] += x(j).dot(x(i).cross(centre)) / 6.0;
            }
        }
        vol
    }

    /// Total area \[m^2\] of the openings of body `b` (the area of their caps' vector sums), `f64`.
    pub fn opening_area(&self, state: &State<R>, b: usize) -> f64 {
        self.openings
            .iter()
            .filter(|o| o.body as usize == b)
            .map(|o| {
                let n = o.vertices.len();
                let x = |k: usize| state.particle_q[o.vertices[k % n] as usize].to_dvec3();
                let a: DVec3 = (0..n).map(|k| x(k).cross(x(k + 1))).sum();
                0.5 * a.length()
            })
            .sum()
    }

    /// Gas pressure `nRT / V` of each body \[Pa\] (0 without gas).
    pub fn body_pressures(&self, state: &State<R>) -> Vec<f64> {
        self.body_volumes(state).iter().enumerate().map(|(b, &v)| self.gas_pressure(b, v)).collect()
    }

    /// Gas pressure `nRT / V` \[Pa\] of body `b` at volume `v` \[m^3\] (clamped at
    /// [`crate::forces::pressure::MIN_VOLUME_FRACTION`] of the rest volume, as the force pass does); 0 without gas.
    pub fn gas_pressure(&self, b: usize, v: f64) -> f64 {
        let g = self.body_gas_amount[b].to_f64();
        crate::forces::pressure::gas_pressure(g, v, self.body_rest_volume[b].to_f64(), 0.0)
    }

    /// Linear momentum [kg·m/s] of the free particles, `f64`.
    pub fn momentum(&self, state: &State<R>) -> DVec3 {
        (0..self.particle_count())
            .filter(|&i| self.particle_inv_mass[i] > R::ZERO)
            .map(|i| state.particle_qd[i].to_dvec3() * self.particle_mass[i].to_f64())
            .sum()
    }

    /// Centre of mass \[m\], `f64`.
    pub fn center_of_mass(&self, state: &State<R>) -> DVec3 {
        let m = self.total_mass();
        (0..self.particle_count())
            .map(|i| state.particle_q[i].to_dvec3() * self.particle_mass[i].to_f64())
            .sum::<DVec3>()
            / m
    }
    /// Recomputes the derived adjacency (particle → springs, particle → triangles, spring runs) after the
    /// spring or triangle arrays were edited by hand.
    pub fn refresh_derived(&mut self) {
        let n = self.particle_count();
        self.particle_springs = Csr::from_pairs(
            n,
            self.spring_indices
                .iter()
                .enumerate()
                .filter(|(s, _)| self.spring_kind[*s] != SpringKind::Broken)
                .flat_map(|(s, ij)| [(ij[0], (s as u32) << 1), (ij[1], ((s as u32) << 1) | 1)]),
        );
        self.particle_tris = Csr::from_pairs(
            n,
            self.tri_indices.iter().enumerate().flat_map(|(t, tri)| tri.iter().map(move |&v| (v, t as u32))),
        );
        self.spring_runs = SpringRun::detect_if_useful(&self.spring_indices);
        self.breakable = self.compute_breakable();
    }

    /// Orders the triangles by body, stably (each body's in their order), as a builder lays them out; returns
    /// whether any moved (a solver or mirror then needs [`crate::fracture::TopologyDelta::whole`]). The particle →
    /// triangle rows are renumbered in place (their order and room kept). The fracture pass calls it once enough
    /// triangles went to new bodies where they lay (see `Fracture`'s docs); the physics is the same, its sums in
    /// another order.
    pub fn order_triangles_by_body(&mut self) -> bool {
        if self.tri_body.is_sorted() {
            return false;
        }
        let mut order: Vec<u32> = (0..self.tri_count() as u32).collect();
        order.sort_by_key(|&t| self.tri_body[t as usize]);
        let mut new_of_old = vec![0u32; order.len()];
        for (new, &old) in order.iter().enumerate() {
            new_of_old[old as usize] = new as u32;
        }
        self.tri_indices = order.iter().map(|&t| self.tri_indices[t as usize]).collect();
        self.tri_body = order.iter().map(|&t| self.tri_body[t as usize]).collect();
        let c = &mut self.particle_tris;
        for i in 0..c.len.len() {
            let s = c.start[i] as usize;
            for t in &mut c.items[s..s + c.len[i] as usize] {
                *t = new_of_old[*t as usize];
            }
        }
        true
    }

    /// Reserves room for `particles`, `springs` and `triangles` more (fracture appends them), so that growing
    /// does not reallocate mid-simulation.
    pub fn reserve(&mut self, particles: usize, springs: usize, triangles: usize) {
        self.reserve_particles(particles);
        for c in [&mut self.particle_springs, &mut self.particle_tris] {
            c.start.reserve(particles);
            c.len.reserve(particles);
            c.cap.reserve(particles);
        }
        self.particle_springs.items.reserve(8 * springs);
        self.particle_tris.items.reserve(12 * triangles);
        self.reserve_springs(springs);
        self.reserve_tris(triangles);
    }

    /// True when the springs form long runs (average ≥ 16), so the run kernel is used.
    pub fn springs_are_runs(&self) -> bool {
        !self.spring_runs.is_empty() && self.spring_count() >= 16 * self.spring_runs.len()
    }

    /// How many springs the CPU step reads their own rest length, stiffness and damping for. On a model of runs
    /// (a grid cloth) the run kernel reads a run's shared parameters once for every span of springs that has
    /// them (bit for bit), so only the others count; otherwise every spring does. (The memory a step must move:
    /// the harness's bandwidth floor.)
    pub fn springs_with_own_parameters(&self) -> usize {
        if self.springs_are_runs() {
            crate::forces::runs::SharedParameters::of_model(self).own_count(self)
        } else {
            self.spring_count()
        }
    }

    /// Connected pieces of the surface (particles joined by springs): `(count, label per particle)`.
    pub fn components(&self) -> (usize, Vec<u32>) {
        connected_components(
            self.particle_count(),
            self.spring_indices
                .iter()
                .zip(&self.spring_kind)
                .filter(|(_, k)| **k != SpringKind::Broken)
                .map(|(s, _)| *s),
        )
    }
}
