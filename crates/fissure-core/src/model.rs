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

/// How a body's mass is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mass {
    /// Total mass [kg], lumped onto vertices by area (each vertex takes a third of its triangles' area).
    Total(f64),
    /// Surface density [kg/m^2], lumped by area.
    AreaDensity(f64),
    /// The same mass [kg] on every vertex.
    PerParticle(f64),
}

/// How spring stiffness is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stiffness {
    /// Every spring gets this constant [N/m]. Depends on the mesh resolution: a finer mesh of the same
    /// springs is softer (more springs in series).
    PerSpring(f64),
    /// The membrane's stretching stiffness `E·h` [N/m] (2D Young's modulus, independent of resolution).
    /// Each edge spring gets `k = E·h Σ A_t / L²` over its one or two triangles (Van Gelder 1998): a regular
    /// triangle lattice of such springs has the 2D Young's modulus `E·h` (Poisson ratio 1/3) at any
    /// resolution. Bending springs get the same formula with their own length.
    Membrane(f64),
}

/// How spring damping is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Damping {
    /// Every spring gets this coefficient [N·s/m].
    PerSpring(f64),
    /// A fraction ζ of each spring's critical damping `2 √(k m_red)`, `m_red` the reduced mass of its ends.
    Ratio(f64),
}

/// The seed's eq. (2) damping in two forms.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DampingModel {
    /// `kd ((v_j - v_i)·d̂) d̂`: damps stretching only. Rigid rotation is undamped (default).
    #[default]
    Projected,
    /// The paper's `kd (v_j - v_i)`: also damps rotation and shear of the spring.
    Unprojected,
}

/// Gas inside a closed body (the closed pressure model, seed eqs. 6–9).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Gas {
    /// No gas: a hollow membrane.
    None,
    /// The constant `nRT` [J] of `P V = nRT`.
    Amount(f64),
    /// The pressure [Pa] at the rest shape; `nRT = P0 · V0`.
    Pressure(f64),
}

/// What a spring represents.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpringKind {
    /// A mesh edge (structural); the springs the fracture code splits.
    Edge,
    /// A shear spring across a quad (cloth grids).
    Shear,
    /// A bending spring: across two triangles, or skipping a vertex on a grid.
    Bend,
    /// A spring that broke: it keeps its slot (so indices and cloth spring runs stay valid) with zero stiffness
    /// and damping, and is in no particle's spring list.
    Broken,
}

/// How a body breaks (see the `fracture` module). Limits of `f64::INFINITY` switch a mode off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Breakable {
    /// Strain `(l - L0) / L0` past which a spring breaks (spring mode). Default infinity (off).
    pub strain_limit: f64,
    /// Load [N] past which a vertex breaks out as a core block (core mode): the magnitude of the net elastic
    /// force (springs and gas) on it. Default infinity (off).
    pub load_limit: f64,
    /// Keep the gas in when the body is punctured (its volume is still taken with caps over the openings).
    /// Default false: gas leaks through the openings.
    pub sealed: bool,
}

impl Default for Breakable {
    fn default() -> Self {
        Breakable { strain_limit: f64::INFINITY, load_limit: f64::INFINITY, sealed: false }
    }
}

impl Breakable {
    fn check(&self) -> Result<(), ModelError> {
        for (name, v) in [("fracture.strain_limit", self.strain_limit), ("fracture.load_limit", self.load_limit)] {
            if v.is_nan() || v <= 0.0 {
                return Err(ModelError::Parameter { name, value: v, expected: "> 0 (infinity: off)" });
            }
        }
        Ok(())
    }
}

/// An opening of a gas body: a boundary loop of its surface, in the direction its faces traverse it. The body's
/// volume is taken with a virtual cap over it (a fan from the loop's centroid), so the volume does not depend on
/// the origin, and its gas leaks out through it (see the `fracture` module).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Opening {
    /// The body.
    pub body: u32,
    /// The loop's particles.
    pub vertices: Vec<u32>,
}

/// What a body is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BodyKind {
    /// A closed surface, possibly with gas.
    SoftBody,
    /// An open (or closed) sheet without gas.
    Cloth,
}

/// Options of [`ModelBuilder::add_soft_body`].
#[derive(Clone, Debug, PartialEq)]
pub struct SoftBodyOptions {
    /// Mass. Default `Total(1.0)` kg.
    pub mass: Mass,
    /// Edge spring stiffness. Default `Membrane(2000.0)` N/m.
    pub stiffness: Stiffness,
    /// Spring damping. Default `Ratio(0.05)`.
    pub damping: Damping,
    /// Bending springs across each interior edge, if any. Default `None`.
    pub bending: Option<Stiffness>,
    /// Gas. Default `Pressure(2000.0)` Pa.
    pub gas: Gas,
    /// Pressure outside [Pa], subtracted from the gas pressure. Default 0 (the seed's model).
    pub external_pressure: f64,
    /// Aerodynamic coefficients (only used if the model has wind). Default none.
    pub aero: Aero,
    /// Flip an inward-facing closed mesh instead of failing. Default true.
    pub reorient: bool,
    /// Initial velocity [m/s]. Default 0.
    pub velocity: DVec3,
    /// How the body breaks. Default `None`: it never does.
    pub fracture: Option<Breakable>,
}

impl Default for SoftBodyOptions {
    fn default() -> Self {
        SoftBodyOptions {
            mass: Mass::Total(1.0),
            stiffness: Stiffness::Membrane(2000.0),
            damping: Damping::Ratio(0.05),
            bending: None,
            gas: Gas::Pressure(2000.0),
            external_pressure: 0.0,
            aero: Aero::NONE,
            reorient: true,
            velocity: DVec3::ZERO,
            fracture: None,
        }
    }
}

/// Options of [`ModelBuilder::add_cloth`] and [`ModelBuilder::add_cloth_grid`].
#[derive(Clone, Debug, PartialEq)]
pub struct ClothOptions {
    /// Mass. Default `AreaDensity(0.2)` kg/m^2.
    pub mass: Mass,
    /// Edge (structural) stiffness. Default `PerSpring(1000.0)` N/m.
    pub stiffness: Stiffness,
    /// Shear springs (grids: both quad diagonals). Default `Some(PerSpring(1000.0))`. Ignored for general meshes.
    pub shear: Option<Stiffness>,
    /// Bending springs. Default `Some(PerSpring(1000.0))`.
    pub bending: Option<Stiffness>,
    /// Spring damping. Default `PerSpring(0.1)` N·s/m.
    pub damping: Damping,
    /// Vertex indices (of this mesh) held fixed. Default none.
    pub pins: Vec<usize>,
    /// Aerodynamic coefficients. Default `Aero::default()`.
    pub aero: Aero,
    /// How the cloth tears. Default `None`: it never does.
    pub fracture: Option<Breakable>,
}

impl Default for ClothOptions {
    fn default() -> Self {
        ClothOptions {
            mass: Mass::AreaDensity(0.2),
            stiffness: Stiffness::PerSpring(1000.0),
            shear: Some(Stiffness::PerSpring(1000.0)),
            bending: Some(Stiffness::PerSpring(1000.0)),
            damping: Damping::PerSpring(0.1),
            pins: Vec::new(),
            aero: Aero::default(),
            fracture: None,
        }
    }
}

/// A handle to a body added to a builder: its index and the range of its particles and triangles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BodyHandle {
    /// Body index.
    pub index: usize,
    /// First particle.
    pub first_particle: usize,
    /// Number of particles.
    pub particle_count: usize,
    /// First triangle.
    pub first_triangle: usize,
}

impl BodyHandle {
    /// The range of this body's particles.
    pub fn particles(&self) -> std::ops::Range<usize> {
        self.first_particle..self.first_particle + self.particle_count
    }
}

/// Accumulates bodies, colliders, gravity and wind in `f64`; [`ModelBuilder::finalize`] produces a [`Model`].
#[derive(Clone, Debug)]
pub struct ModelBuilder {
    q: Vec<DVec3>,
    qd: Vec<DVec3>,
    mass: Vec<f64>,
    pinned: Vec<bool>,
    particle_body: Vec<u32>,
    springs: Vec<([u32; 2], f64, f64, f64, SpringKind)>,
    tris: Vec<[u32; 3]>,
    tri_body: Vec<u32>,
    bodies: Vec<BodyDesc>,
    gravity: DVec3,
    damping_model: DampingModel,
    wind: Option<WindField>,
    colliders: Vec<Collider>,
}

#[derive(Clone, Debug)]
struct BodyDesc {
    kind: BodyKind,
    gas: f64,
    external_pressure: f64,
    rest_volume: f64,
    aero: Aero,
    anchor: u32,
    fracture: Option<Breakable>,
}

impl Default for ModelBuilder {
    fn default() -> Self {
        Self::new()
    }
}

fn check_pos(name: &'static str, v: f64) -> Result<(), ModelError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ModelError::Parameter { name, value: v, expected: "finite and > 0" })
    }
}

fn check_nonneg(name: &'static str, v: f64) -> Result<(), ModelError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(ModelError::Parameter { name, value: v, expected: "finite and >= 0" })
    }
}

fn check_stiffness(name: &'static str, s: Stiffness) -> Result<(), ModelError> {
    match s {
        Stiffness::PerSpring(k) | Stiffness::Membrane(k) => check_nonneg(name, k),
    }
}

impl ModelBuilder {
    /// An empty builder: gravity (0, -9.81, 0) m/s^2, projected damping, no wind, no colliders.
    pub fn new() -> Self {
        ModelBuilder {
            q: Vec::new(),
            qd: Vec::new(),
            mass: Vec::new(),
            pinned: Vec::new(),
            particle_body: Vec::new(),
            springs: Vec::new(),
            tris: Vec::new(),
            tri_body: Vec::new(),
            bodies: Vec::new(),
            gravity: DVec3::new(0.0, -9.81, 0.0),
            damping_model: DampingModel::Projected,
            wind: None,
            colliders: Vec::new(),
        }
    }

    /// Sets gravity [m/s^2].
    pub fn gravity(&mut self, g: DVec3) -> &mut Self {
        self.gravity = g;
        self
    }

    /// Chooses the damping form (seed eq. 2).
    pub fn damping_model(&mut self, m: DampingModel) -> &mut Self {
        self.damping_model = m;
        self
    }

    /// Sets the wind field.
    pub fn wind(&mut self, w: WindField) -> &mut Self {
        self.wind = Some(w);
        self
    }

    /// Adds a collider.
    pub fn add_collider(&mut self, c: Collider) -> &mut Self {
        self.colliders.push(c);
        self
    }

    /// Number of particles so far.
    pub fn particle_count(&self) -> usize {
        self.q.len()
    }

    /// Adds a single particle of mass `mass` [kg] (0 pins it) at `x` with velocity `v`; returns its index.
    /// For point-mass experiments; see [`ModelBuilder::add_spring`].
    pub fn add_particle(&mut self, x: DVec3, v: DVec3, mass: f64) -> Result<usize, ModelError> {
        check_nonneg("mass", mass)?;
        if !x.is_finite() || !v.is_finite() {
            return Err(ModelError::Parameter {
                name: "particle position/velocity",
                value: f64::NAN,
                expected: "finite",
            });
        }
        self.q.push(x);
        self.qd.push(v);
        self.mass.push(mass);
        self.pinned.push(mass == 0.0);
        self.particle_body.push(NONE);
        Ok(self.q.len() - 1)
    }

    /// Adds a spring between particles `i` and `j` with stiffness [N/m] and damping [N·s/m]; its rest length is
    /// their current distance.
    pub fn add_spring(&mut self, i: usize, j: usize, stiffness: f64, damping: f64) -> Result<usize, ModelError> {
        let n = self.q.len();
        for idx in [i, j] {
            if idx >= n {
                return Err(ModelError::ParticleOutOfRange { name: "spring end", index: idx, count: n });
            }
        }
        check_nonneg("stiffness", stiffness)?;
        check_nonneg("damping", damping)?;
        let l = (self.q[j] - self.q[i]).length();
        check_pos("spring rest length", l)?;
        self.springs.push(([i as u32, j as u32], l, stiffness, damping, SpringKind::Edge));
        Ok(self.springs.len() - 1)
    }

    /// Adds a closed soft body (a balloon: membrane springs on the edges, gas inside). The mesh must be closed
    /// when it has gas; an inward-facing mesh is flipped if `opts.reorient`, rejected otherwise.
    pub fn add_soft_body(&mut self, mesh: &Mesh, opts: &SoftBodyOptions) -> Result<BodyHandle, ModelError> {
        let mut mesh = mesh.clone();
        let topo = mesh.topology();
        let gas = !matches!(opts.gas, Gas::None);
        if gas && !topo.is_closed() {
            let e = topo.boundary_edges().next().map(|e| topo.edges[e]).unwrap_or([0, 0]);
            return Err(MeshError::Open { boundary_edges: topo.boundary_edges().count(), a: e[0], b: e[1] }.into());
        }
        if topo.is_closed() {
            let v = mesh.signed_volume();
            if v < 0.0 {
                if !opts.reorient {
                    return Err(MeshError::InwardFacing { volume: v }.into());
                }
                mesh.flip_winding();
            }
        }
        check_nonneg("external_pressure", opts.external_pressure)?;
        let v0 = if topo.is_closed() { mesh.signed_volume() } else { 0.0 };
        let nrt = match opts.gas {
            Gas::None => 0.0,
            Gas::Amount(a) => {
                check_pos("gas amount nRT", a)?;
                a
            }
            Gas::Pressure(p) => {
                check_pos("gas pressure", p)?;
                p * v0
            }
        };
        let h = self.add_surface(
            &mesh,
            &topo,
            BodyKind::SoftBody,
            opts.mass,
            opts.stiffness,
            None,
            opts.bending,
            opts.damping,
            &[],
            opts.aero,
            None,
            opts.fracture,
        )?;
        let b = &mut self.bodies[h.index];
        b.gas = nrt;
        b.external_pressure = opts.external_pressure;
        b.rest_volume = v0;
        if !opts.velocity.is_finite() {
            return Err(ModelError::Parameter { name: "velocity", value: f64::NAN, expected: "finite" });
        }
        for v in &mut self.qd[h.particles()] {
            *v = opts.velocity;
        }
        Ok(h)
    }

    /// Adds a cloth from any mesh: edge springs, bending springs across interior edges, pins.
    pub fn add_cloth(&mut self, mesh: &Mesh, opts: &ClothOptions) -> Result<BodyHandle, ModelError> {
        let topo = mesh.topology();
        self.add_surface(
            mesh,
            &topo,
            BodyKind::Cloth,
            opts.mass,
            opts.stiffness,
            None,
            opts.bending,
            opts.damping,
            &opts.pins,
            opts.aero,
            None,
            opts.fracture,
        )
    }

    /// Adds an `nx × ny` cloth grid (see [`Mesh::grid`]) placed by `place` (applied to each rest position),
    /// with the classic layout of Provot 1995: structural springs on grid lines, shear springs on both
    /// diagonals of every quad, bending springs skipping one vertex. For 128 × 128: 32,512 + 32,258 + 32,256 =
    /// 97,026 springs.
    pub fn add_cloth_grid(
        &mut self,
        nx: usize,
        ny: usize,
        spacing: f64,
        place: impl Fn(DVec3) -> DVec3,
        opts: &ClothOptions,
    ) -> Result<BodyHandle, ModelError> {
        if nx < 2 || ny < 2 {
            return Err(ModelError::Parameter {
                name: "grid size",
                value: nx.min(ny) as f64,
                expected: "at least 2 × 2",
            });
        }
        check_pos("spacing", spacing)?;
        let mesh = Mesh::grid(nx, ny, spacing).map_positions(place)?;
        let topo = mesh.topology();
        let grid = GridLayout { nx, ny };
        self.add_surface(
            &mesh,
            &topo,
            BodyKind::Cloth,
            opts.mass,
            opts.stiffness,
            opts.shear,
            opts.bending,
            opts.damping,
            &opts.pins,
            opts.aero,
            Some(grid),
            opts.fracture,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn add_surface(
        &mut self,
        mesh: &Mesh,
        topo: &Topology,
        kind: BodyKind,
        mass: Mass,
        stiffness: Stiffness,
        shear: Option<Stiffness>,
        bending: Option<Stiffness>,
        damping: Damping,
        pins: &[usize],
        aero: Aero,
        grid: Option<GridLayout>,
        fracture: Option<Breakable>,
    ) -> Result<BodyHandle, ModelError> {
        check_stiffness("stiffness", stiffness)?;
        if let Some(f) = &fracture {
            f.check()?;
        }
        if let Some(s) = shear {
            check_stiffness("shear", s)?;
        }
        if let Some(s) = bending {
            check_stiffness("bending", s)?;
        }
        match damping {
            Damping::PerSpring(d) | Damping::Ratio(d) => check_nonneg("damping", d)?,
        }
        for (name, c) in [("aero.drag", aero.drag), ("aero.lift", aero.lift)] {
            if !c.is_finite() {
                return Err(ModelError::Parameter { name, value: c, expected: "finite" });
            }
        }
        let p = mesh.positions();
        let n = p.len();
        if let Some(&bad) = pins.iter().find(|&&i| i >= n) {
            return Err(ModelError::ParticleOutOfRange { name: "pins", index: bad, count: n });
        }
        // Lumped masses: a third of each triangle's area to each corner.
        let mut area = vec![0.0; n];
        for t in mesh.triangles() {
            let a = tri_area(p, t) / 3.0;
            for &v in t {
                area[v as usize] += a;
            }
        }
        let total_area: f64 = area.iter().sum();
        let m: Vec<f64> = match mass {
            Mass::Total(mt) => {
                check_pos("mass", mt)?;
                area.iter().map(|a| mt * a / total_area).collect()
            }
            Mass::AreaDensity(rho) => {
                check_pos("area density", rho)?;
                area.iter().map(|a| rho * a).collect()
            }
            Mass::PerParticle(mp) => {
                check_pos("particle mass", mp)?;
                vec![mp; n]
            }
        };
        if let Some(i) = m.iter().position(|&mi| mi <= 0.0) {
            return Err(ModelError::Parameter {
                name: "vertex mass (vertex used by no triangle?)",
                value: i as f64,
                expected: "every vertex in a triangle",
            });
        }
        let base = self.q.len() as u32;
        let body = self.bodies.len() as u32;
        let first_triangle = self.tris.len();
        self.q.extend_from_slice(p);
        self.qd.extend(std::iter::repeat_n(DVec3::ZERO, n));
        self.mass.extend_from_slice(&m);
        let mut pinned = vec![false; n];
        for &i in pins {
            pinned[i] = true;
        }
        self.pinned.extend_from_slice(&pinned);
        self.particle_body.extend(std::iter::repeat_n(body, n));
        self.tris.extend(mesh.triangles().iter().map(|t| t.map(|v| v + base)));
        self.tri_body.extend(std::iter::repeat_n(body, mesh.triangle_count()));

        let tris = mesh.triangles();
        let resolve = |s: Stiffness, l: f64, area_sum: f64| match s {
            Stiffness::PerSpring(k) => k,
            Stiffness::Membrane(eh) => eh * area_sum / (l * l),
        };
        let damp = |k: f64, i: usize, j: usize| match damping {
            Damping::PerSpring(d) => d,
            Damping::Ratio(z) => {
                let (mi, mj) = (m[i], m[j]);
                let mred = match (pinned[i], pinned[j]) {
                    (true, false) => mj,
                    (false, true) => mi,
                    _ => mi * mj / (mi + mj),
                };
                2.0 * z * (k * mred).sqrt()
            }
        };
        let push = |i: usize, j: usize, s: Stiffness, area_sum: f64, kind: SpringKind, out: &mut Vec<_>| {
            let l = (p[j] - p[i]).length();
            let k = resolve(s, l, area_sum);
            out.push(([i as u32 + base, j as u32 + base], l, k, damp(k, i, j), kind));
        };
        let mut new_springs = Vec::new();
        for (e, &[a, b]) in topo.edges.iter().enumerate() {
            let faces = topo.edge_faces[e];
            let area_sum: f64 = faces.iter().filter(|&&f| f != NONE).map(|&f| tri_area(p, &tris[f as usize])).sum();
            // On a grid, the mesh diagonals are shear springs.
            let diagonal = grid.is_some_and(|g| g.is_diagonal(a as usize, b as usize));
            let s = if diagonal { shear.unwrap_or(stiffness) } else { stiffness };
            push(
                a as usize,
                b as usize,
                s,
                area_sum,
                if diagonal { SpringKind::Shear } else { SpringKind::Edge },
                &mut new_springs,
            );
        }
        match grid {
            Some(g) => {
                if let Some(s) = shear {
                    // The other diagonal of each quad.
                    for j in 0..g.ny - 1 {
                        for i in 0..g.nx - 1 {
                            let (p00, p10, p01, p11) = (g.v(i, j), g.v(i + 1, j), g.v(i, j + 1), g.v(i + 1, j + 1));
                            let (a, b) = if (i + j) % 2 == 0 { (p10, p01) } else { (p00, p11) };
                            push(a, b, s, 0.0, SpringKind::Shear, &mut new_springs);
                        }
                    }
                }
                if let Some(s) = bending {
                    for j in 0..g.ny {
                        for i in 0..g.nx - 2 {
                            push(g.v(i, j), g.v(i + 2, j), s, 0.0, SpringKind::Bend, &mut new_springs);
                        }
                    }
                    for j in 0..g.ny - 2 {
                        for i in 0..g.nx {
                            push(g.v(i, j), g.v(i, j + 2), s, 0.0, SpringKind::Bend, &mut new_springs);
                        }
                    }
                }
            }
            None => {
                if let Some(s) = bending {
                    // Across each interior edge, between the two opposite vertices.
                    for (e, &[a, b]) in topo.edges.iter().enumerate() {
                        let [f0, f1] = topo.edge_faces[e];
                        if f1 == NONE {
                            continue;
                        }
                        let opp = |f: u32| *tris[f as usize].iter().find(|&&v| v != a && v != b).expect("triangle");
                        let (c, d) = (opp(f0) as usize, opp(f1) as usize);
                        let area_sum = tri_area(p, &tris[f0 as usize]) + tri_area(p, &tris[f1 as usize]);
                        if (p[d] - p[c]).length() > 0.0 {
                            push(c, d, s, area_sum, SpringKind::Bend, &mut new_springs);
                        }
                    }
                }
            }
        }
        if grid.is_some() {
            // Order grid springs by direction, then by first particle: every row (or the whole sheet) of one
            // direction becomes a run of springs `(i0 + k, j0 + k)`, which the spring kernel walks as contiguous
            // slices instead of gathering through indices.
            for sp in &mut new_springs {
                if sp.0[0] > sp.0[1] {
                    sp.0.swap(0, 1);
                }
            }
            new_springs.sort_by_key(|sp| (sp.0[1] - sp.0[0], sp.0[0]));
        }
        self.springs.extend(new_springs);
        self.bodies.push(BodyDesc {
            kind,
            gas: 0.0,
            external_pressure: 0.0,
            rest_volume: 0.0,
            aero,
            anchor: base,
            fracture,
        });
        Ok(BodyHandle { index: body as usize, first_particle: base as usize, particle_count: n, first_triangle })
    }

    /// Produces the model in precision `R` (`f32` or `f64`).
    pub fn finalize<R: Real>(&self) -> Result<Model<R>, ModelError> {
        if self.q.is_empty() {
            return Err(ModelError::Empty);
        }
        if !self.gravity.is_finite() {
            return Err(ModelError::Parameter { name: "gravity", value: f64::NAN, expected: "finite" });
        }
        let n = self.q.len();
        let particle_springs = Csr::from_pairs(
            n,
            self.springs
                .iter()
                .enumerate()
                .flat_map(|(s, (ij, ..))| [(ij[0], (s as u32) << 1), (ij[1], ((s as u32) << 1) | 1)]),
        );
        let particle_tris = Csr::from_pairs(
            n,
            self.tris.iter().enumerate().flat_map(|(t, tri)| tri.iter().map(move |&v| (v, t as u32))),
        );
        let r = R::from_f64;
        let v = R::V::from_dvec3;
        let breakable = |p: u32| self.bodies.get(p as usize).and_then(|b| b.fracture).unwrap_or_default();
        let mut model = Model {
            particle_q0: self.q.iter().map(|&x| v(x)).collect(),
            particle_qd0: self.qd.iter().map(|&x| v(x)).collect(),
            particle_mass: self.mass.iter().map(|&m| r(m)).collect(),
            particle_inv_mass: self
                .mass
                .iter()
                .zip(&self.pinned)
                // The inverse of the rounded mass, so `inv_mass == 1 / mass` holds exactly in `R` (fracture re-derives
                // it that way and `check_invariants` checks it).
                .map(|(&m, &p)| if p || m == 0.0 { R::ZERO } else { R::ONE / r(m) })
                .collect(),
            particle_body: self.particle_body.clone(),
            spring_indices: self.springs.iter().map(|s| s.0).collect(),
            spring_rest_length: self.springs.iter().map(|s| r(s.1)).collect(),
            spring_stiffness: self.springs.iter().map(|s| r(s.2)).collect(),
            spring_damping: self.springs.iter().map(|s| r(s.3)).collect(),
            spring_kind: self.springs.iter().map(|s| s.4).collect(),
            spring_strain_limit: self
                .springs
                .iter()
                .map(|s| {
                    let (bi, bj) = (self.particle_body[s.0[0] as usize], self.particle_body[s.0[1] as usize]);
                    if bi == bj { r(breakable(bi).strain_limit) } else { R::infinity() }
                })
                .collect(),
            particle_load_limit: self.particle_body.iter().map(|&b| r(breakable(b).load_limit)).collect(),
            tri_indices: self.tris.clone(),
            tri_body: self.tri_body.clone(),
            body_kind: self.bodies.iter().map(|b| b.kind).collect(),
            body_gas_amount: self.bodies.iter().map(|b| r(b.gas)).collect(),
            body_pressure_external: self.bodies.iter().map(|b| r(b.external_pressure)).collect(),
            body_rest_volume: self.bodies.iter().map(|b| r(b.rest_volume)).collect(),
            body_drag: self.bodies.iter().map(|b| r(b.aero.drag)).collect(),
            body_lift: self.bodies.iter().map(|b| r(b.aero.lift)).collect(),
            body_anchor: self.bodies.iter().map(|b| b.anchor).collect(),
            body_sealed: self.bodies.iter().map(|b| b.fracture.is_some_and(|f| f.sealed)).collect(),
            openings: Vec::new(),
            breakable: false,
            spring_runs: SpringRun::detect_if_useful(&self.springs.iter().map(|s| s.0).collect::<Vec<_>>()),
            particle_springs,
            particle_tris,
            gravity: v(self.gravity),
            damping_model: self.damping_model,
            wind: self.wind.clone(),
            colliders: self.colliders.clone(),
        };
        model.breakable = model.compute_breakable();
        Ok(model)
    }
}

#[derive(Clone, Copy, Debug)]
struct GridLayout {
    nx: usize,
    ny: usize,
}

impl GridLayout {
    fn v(&self, i: usize, j: usize) -> usize {
        j * self.nx + i
    }
    fn is_diagonal(&self, a: usize, b: usize) -> bool {
        a % self.nx != b % self.nx && a / self.nx != b / self.nx
    }
}

/// Everything a step reads but does not write. See the crate docs for units.
#[derive(Clone, Debug)]
pub struct Model<R: Real = f32> {
    /// Initial positions [m].
    pub particle_q0: Vec<R::V>,
    /// Initial velocities [m/s].
    pub particle_qd0: Vec<R::V>,
    /// Mass [kg] (pinned particles keep theirs for accounting).
    pub particle_mass: Vec<R>,
    /// Inverse mass [1/kg]; 0 pins a particle.
    pub particle_inv_mass: Vec<R>,
    /// Owning body, or `u32::MAX` for free particles.
    pub particle_body: Vec<u32>,
    /// Spring ends `[i, j]`.
    pub spring_indices: Vec<[u32; 2]>,
    /// Rest length `L0` [m].
    pub spring_rest_length: Vec<R>,
    /// Stiffness `ks` [N/m].
    pub spring_stiffness: Vec<R>,
    /// Damping `kd` [N·s/m].
    pub spring_damping: Vec<R>,
    /// What each spring represents.
    pub spring_kind: Vec<SpringKind>,
    /// Strain `(l - L0) / L0` past which each spring breaks (infinity: never).
    pub spring_strain_limit: Vec<R>,
    /// Load [N] past which each particle breaks out as a core block (infinity: never); see the `fracture` module.
    pub particle_load_limit: Vec<R>,
    /// Triangles, counter-clockwise from outside.
    pub tri_indices: Vec<[u32; 3]>,
    /// Owning body of each triangle.
    pub tri_body: Vec<u32>,
    /// Kind of each body.
    pub body_kind: Vec<BodyKind>,
    /// `nRT` [J] of each body's gas (0: none).
    pub body_gas_amount: Vec<R>,
    /// Outside pressure [Pa].
    pub body_pressure_external: Vec<R>,
    /// Volume at rest [m^3] (0 for open bodies). Volumes are clamped at 1e-3 of it so an inverted body's
    /// pressure stays finite.
    pub body_rest_volume: Vec<R>,
    /// Drag coefficient.
    pub body_drag: Vec<R>,
    /// Lift coefficient.
    pub body_lift: Vec<R>,
    /// A particle of each body about which its volume is summed (round-off control only).
    pub body_anchor: Vec<u32>,
    /// Whether each body keeps its gas when punctured.
    pub body_sealed: Vec<bool>,
    /// Openings of the gas bodies (none until something breaks).
    pub openings: Vec<Opening>,
    /// Derived: some spring or particle can break (only then does the fracture pass do any work).
    pub breakable: bool,
    /// Springs of each particle: entry `s << 1 | end`, `end` 0 for `spring_indices[s][0]`.
    pub particle_springs: Csr,
    /// Triangles of each particle.
    pub particle_tris: Csr,
    /// Maximal runs of consecutive springs whose ends advance together (see [`SpringRun`]); derived. Empty when
    /// the runs would be too short to pay (irregular meshes): the gather kernel is used then.
    pub spring_runs: Vec<SpringRun>,
    /// Gravity [m/s^2].
    pub gravity: R::V,
    /// Damping form.
    pub damping_model: DampingModel,
    /// Wind, if any.
    pub wind: Option<WindField>,
    /// Colliders.
    pub colliders: Vec<Collider>,
}

/// Springs `first + k` for `k < len` with ends `(i + k, j + k)`. Cloth grids consist of a few hundred such runs;
/// the solver then computes spring forces on contiguous slices, per block of particles, without the per-spring
/// force buffer and index gather that an irregular mesh needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
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

/// Positions and velocities: the only data a step changes.
#[derive(Clone, Debug, PartialEq)]
pub struct State<R: Real = f32> {
    /// Positions [m].
    pub particle_q: Vec<R::V>,
    /// Velocities [m/s].
    pub particle_qd: Vec<R::V>,
    /// Simulation time [s].
    pub time: f64,
}

/// Energies of a state [J], each summed in `f64`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energy {
    /// `Σ ½ m v²` of free particles.
    pub kinetic: f64,
    /// `Σ ½ ks (l - L0)²`.
    pub spring: f64,
    /// `Σ -nRT ln(V / V0)` (0 at rest volume) plus `P_ext (V - V0)`.
    pub gas: f64,
    /// `-Σ m g·x` of free particles.
    pub gravity: f64,
}

impl Energy {
    /// Sum of all terms.
    pub fn total(&self) -> f64 {
        self.kinetic + self.spring + self.gas + self.gravity
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
    /// True if there are colliders: only then is the collision pass run.
    pub fn has_colliders(&self) -> bool {
        !self.colliders.is_empty()
    }
    /// Total mass [kg], summed in `f64`.
    pub fn total_mass(&self) -> f64 {
        self.particle_mass.iter().map(|m| m.to_f64()).sum()
    }

    /// Enclosed volume of each body [m^3] (0 for bodies without gas), `f64`.
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

    /// Total area [m^2] of the openings of body `b` (the area of their caps' vector sums), `f64`.
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

    /// Gas pressure `nRT / V` of each body [Pa] (0 without gas).
    pub fn body_pressures(&self, state: &State<R>) -> Vec<f64> {
        self.body_volumes(state).iter().enumerate().map(|(b, &v)| self.gas_pressure(b, v)).collect()
    }

    /// Gas pressure `nRT / V` [Pa] of body `b` at volume `v` [m^3] (clamped at 1e-3 of the rest volume, as the
    /// force pass does); 0 without gas.
    pub fn gas_pressure(&self, b: usize, v: f64) -> f64 {
        let g = self.body_gas_amount[b].to_f64();
        if g > 0.0 { g / v.max(1e-3 * self.body_rest_volume[b].to_f64()) } else { 0.0 }
    }

    /// Linear momentum [kg·m/s] of the free particles, `f64`.
    pub fn momentum(&self, state: &State<R>) -> DVec3 {
        (0..self.particle_count())
            .filter(|&i| self.particle_inv_mass[i] > R::ZERO)
            .map(|i| state.particle_qd[i].to_dvec3() * self.particle_mass[i].to_f64())
            .sum()
    }

    /// Centre of mass [m], `f64`.
    pub fn center_of_mass(&self, state: &State<R>) -> DVec3 {
        let m = self.total_mass();
        (0..self.particle_count())
            .map(|i| state.particle_q[i].to_dvec3() * self.particle_mass[i].to_f64())
            .sum::<DVec3>()
            / m
    }

    /// The energies of `state` (wind and colliders do work and are not included).
    pub fn energy(&self, state: &State<R>) -> Energy {
        let mut e = Energy::default();
        let g = self.gravity.to_dvec3();
        for i in 0..self.particle_count() {
            if self.particle_inv_mass[i] > R::ZERO {
                let m = self.particle_mass[i].to_f64();
                e.kinetic += 0.5 * m * state.particle_qd[i].to_dvec3().length_squared();
                e.gravity -= m * g.dot(state.particle_q[i].to_dvec3());
            }
        }
        for (s, &[i, j]) in self.spring_indices.iter().enumerate() {
            let l = (state.particle_q[j as usize].to_dvec3() - state.particle_q[i as usize].to_dvec3()).length();
            let d = l - self.spring_rest_length[s].to_f64();
            e.spring += 0.5 * self.spring_stiffness[s].to_f64() * d * d;
        }
        for (b, v) in self.body_volumes(state).into_iter().enumerate() {
            let gas = self.body_gas_amount[b].to_f64();
            let v0 = self.body_rest_volume[b].to_f64();
            if gas > 0.0 {
                e.gas += -gas * (v.max(1e-3 * v0) / v0).ln() + self.body_pressure_external[b].to_f64() * (v - v0);
            }
        }
        e
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

    /// Reserves room for `particles`, `springs` and `triangles` more (fracture appends them), so that growing
    /// does not reallocate mid-simulation.
    pub fn reserve(&mut self, particles: usize, springs: usize, triangles: usize) {
        self.particle_q0.reserve(particles);
        self.particle_qd0.reserve(particles);
        self.particle_mass.reserve(particles);
        self.particle_inv_mass.reserve(particles);
        self.particle_body.reserve(particles);
        self.particle_load_limit.reserve(particles);
        for c in [&mut self.particle_springs, &mut self.particle_tris] {
            c.start.reserve(particles);
            c.len.reserve(particles);
            c.cap.reserve(particles);
        }
        self.particle_springs.items.reserve(8 * springs);
        self.particle_tris.items.reserve(12 * triangles);
        self.spring_indices.reserve(springs);
        self.spring_rest_length.reserve(springs);
        self.spring_stiffness.reserve(springs);
        self.spring_damping.reserve(springs);
        self.spring_kind.reserve(springs);
        self.spring_strain_limit.reserve(springs);
        self.tri_indices.reserve(triangles);
        self.tri_body.reserve(triangles);
    }

    /// True when the springs form long runs (average ≥ 16), so the run kernel is used.
    pub fn springs_are_runs(&self) -> bool {
        !self.spring_runs.is_empty() && self.spring_count() >= 16 * self.spring_runs.len()
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
