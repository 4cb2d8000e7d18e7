//! [`ModelBuilder`]: bodies, springs, colliders, gravity and wind accumulated in `f64`, then `finalize()`.

use super::*;

/// Accumulates bodies, colliders, gravity and wind in `f64`; [`ModelBuilder::finalize`] produces a [`Model`].
#[derive(Clone, Debug)]
pub struct ModelBuilder {
    q: Vec<DVec3>,
    qd: Vec<DVec3>,
    mass: Vec<f64>,
    pinned: Vec<bool>,
    particle_body: Vec<u32>,
    /// `(ends, rest length, ks, kd, kind, strain limit)`.
    springs: Vec<([u32; 2], f64, f64, f64, SpringKind, f64)>,
    tris: Vec<[u32; 3]>,
    tri_body: Vec<u32>,
    tri_grids: Vec<super::TriGrid>,
    bodies: Vec<BodyDesc>,
    gravity: DVec3,
    damping_model: DampingModel,
    wind: Option<WindField>,
    colliders: Vec<Collider>,
    handles: Vec<(Handle, Vec<usize>)>,
}

#[derive(Clone, Debug)]
struct BodyDesc {
    kind: BodyKind,
    gas: f64,
    gas_inflow: f64,
    external_pressure: f64,
    rest_volume: f64,
    aero: Aero,
    anchor: u32,
    fracture: Option<Breakable>,
    contact: Option<crate::contact::Contact>,
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
            tri_grids: Vec::new(),
            tri_body: Vec::new(),
            bodies: Vec::new(),
            gravity: DVec3::new(0.0, -9.81, 0.0),
            damping_model: DampingModel::Projected,
            wind: None,
            colliders: Vec::new(),
            handles: Vec::new(),
        }
    }

    /// Sets gravity \[m/s^2\]; rejects a non-finite vector.
    pub fn gravity(&mut self, g: DVec3) -> Result<&mut Self, ModelError> {
        if let Some(&x) = g.to_array().iter().find(|x| !x.is_finite()) {
            return Err(ModelError::Parameter { name: "gravity", value: x, expected: "finite [m/s^2]" });
        }
        self.gravity = g;
        Ok(self)
    }

    /// Chooses the damping form (seed eq. 2).
    pub fn damping_model(&mut self, m: DampingModel) -> &mut Self {
        self.damping_model = m;
        self
    }

    /// Sets the wind field; rejects bad values ([`WindField::validate`]).
    pub fn wind(&mut self, w: WindField) -> Result<&mut Self, ModelError> {
        w.validate()?;
        self.wind = Some(w);
        Ok(self)
    }

    /// Adds a collider; rejects bad values ([`Collider::validate`]: a zero normal, a radius that is not
    /// positive, a restitution outside [0, 1], ...).
    pub fn add_collider(&mut self, c: Collider) -> Result<&mut Self, ModelError> {
        c.validate()?;
        self.colliders.push(c);
        Ok(self)
    }

    /// Switches contact on for body `body` (an index from its [`BodyHandle`]): its surface then collides with
    /// every other body in contact and, with `self_collision`, with itself (see the [`crate::contact`] module).
    pub fn set_contact(&mut self, body: usize, contact: crate::contact::Contact) -> Result<&mut Self, ModelError> {
        contact.check()?;
        let b = self.bodies.get_mut(body).ok_or(ModelError::Parameter {
            name: "contact body",
            value: body as f64,
            expected: "the index of a body added before",
        })?;
        b.contact = Some(contact);
        Ok(self)
    }

    /// Contact thickness of body `b` \[m\]: its own, else the default from its mean edge length; 0 without contact.
    fn contact_thickness(&self, b: usize) -> f64 {
        match self.bodies[b].contact {
            None => 0.0,
            Some(c) => c.thickness.unwrap_or_else(|| {
                let tris = self.tris.iter().zip(&self.tri_body).filter(|(_, tb)| **tb as usize == b).map(|(t, _)| *t);
                crate::contact::default_thickness(&self.q, tris)
            }),
        }
    }

    /// Moves `particles` on `handle`'s path (a moving pin; see [`Handle`]): they are pinned and the solver
    /// moves them. Returns the handle's index. Errors: a particle out of range or already on a handle, a bad
    /// path.
    pub fn add_handle(&mut self, particles: &[usize], handle: Handle) -> Result<usize, ModelError> {
        handle.check()?;
        let n = self.q.len();
        if let Some(&bad) = particles.iter().find(|&&i| i >= n) {
            return Err(ModelError::ParticleOutOfRange { name: "handle particle", index: bad, count: n });
        }
        if let Some(&twice) = particles.iter().find(|&&i| self.handles.iter().any(|(_, p)| p.contains(&i))) {
            return Err(ModelError::Parameter {
                name: "handle particle",
                value: twice as f64,
                expected: "on one handle at most",
            });
        }
        self.handles.push((handle, particles.to_vec()));
        Ok(self.handles.len() - 1)
    }

    /// Number of particles so far.
    pub fn particle_count(&self) -> usize {
        self.q.len()
    }

    /// Adds a single particle of mass `mass` \[kg\] (0 pins it) at `x` with velocity `v`; returns its index.
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

    /// Adds a spring between particles `i` and `j` with stiffness \[N/m\] and damping \[N·s/m\]; its rest length is
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
        let (bi, bj) = (self.particle_body[i], self.particle_body[j]);
        let limit = match self.bodies.get(bi as usize).and_then(|b| b.fracture) {
            Some(f) if bi == bj => f.strain_limit,
            _ => f64::INFINITY,
        };
        self.springs.push(([i as u32, j as u32], l, stiffness, damping, SpringKind::Edge, limit));
        Ok(self.springs.len() - 1)
    }

    /// Adds a closed soft body (a balloon: membrane springs on the edges, gas inside). The mesh must be closed
    /// when it has gas; an inward-facing mesh is flipped if `opts.reorient`, rejected otherwise.
    ///
    /// Vertex `i` of the mesh becomes particle `handle.first_particle + i`; its triangles follow from
    /// `handle.first_triangle` ordered by their sorted corners (a grid's keep the grid's order), so the triangles'
    /// order follows the particles' whatever order the mesh lists them in. The model steps fastest when
    /// neighbouring vertices have nearby indices. A mesh numbered without locality
    /// (vertices in random order) can be renumbered first with [`Mesh::renumbered_for_locality`].
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
        check_nonneg("gas_inflow", opts.gas_inflow)?;
        if opts.gas_inflow > 0.0 && !gas {
            return Err(ModelError::Parameter {
                name: "gas_inflow",
                value: opts.gas_inflow,
                expected: "0 for a body without gas (give it a pressure or gas amount)",
            });
        }
        let v0 = if topo.is_closed() { mesh.signed_volume() } else { 0.0 };
        let nrt = match opts.gas {
            Gas::None => 0.0,
            Gas::Amount(a) => {
                check_pos("gas_amount", a)?;
                a
            }
            Gas::Pressure(p) => {
                check_pos("pressure", p)?;
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
        b.gas_inflow = opts.gas_inflow;
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
        if let Some(g) = grid {
            let (nx, ny) = (g.nx as u32, g.ny as u32);
            self.tri_grids.push(super::TriGrid { first: first_triangle as u32, base, nx, ny });
        }
        let from = self.tris.len();
        self.tris.extend(mesh.triangles().iter().map(|t| t.map(|v| v + base)));
        if grid.is_none() {
            // A body's triangles in the order of its particles: by their corners sorted (least first; winding
            // kept, ties by the mesh's order). The fused springs-and-crosses pass hands each core a range of
            // triangles and a range of springs that start at the same fraction of the body; in the mesh's own
            // order (random, as some exporters leave it) each core's triangles touch every particle, and on two
            // threads the gather then reads what the other core wrote (`benches/ball.rs`, issue 15: the
            // 2,562-vertex ball with shuffled triangles 1.14–1.50x its own order on two threads before this,
            // see `benches/RESULTS.md`). A grid keeps its order: its wind walks the cells by row.
            self.tris[from..].sort_by_key(crate::mesh::sorted_corners);
        }
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
            out.push(([i as u32 + base, j as u32 + base], l, k, damp(k, i, j), kind, area_sum / l));
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
                // The area of one cell: the other diagonal stands for its quad, as the mesh diagonal does for its
                // two triangles, and a bending spring (two cells long) for one cell's area, as a bending spring
                // across two triangles does elsewhere. (An area of 0 here would give them no stiffness at all
                // under `Stiffness::Membrane`.)
                let cell = (p[g.v(1, 0)] - p[g.v(0, 0)]).length() * (p[g.v(0, 1)] - p[g.v(0, 0)]).length();
                if let Some(s) = shear {
                    // The other diagonal of each quad.
                    for j in 0..g.ny - 1 {
                        for i in 0..g.nx - 1 {
                            let (p00, p10, p01, p11) = (g.v(i, j), g.v(i + 1, j), g.v(i, j + 1), g.v(i + 1, j + 1));
                            let (a, b) = if (i + j) % 2 == 0 { (p10, p01) } else { (p00, p11) };
                            push(a, b, s, cell, SpringKind::Shear, &mut new_springs);
                        }
                    }
                }
                if let Some(s) = bending {
                    for j in 0..g.ny {
                        for i in 0..g.nx - 2 {
                            push(g.v(i, j), g.v(i + 2, j), s, cell, SpringKind::Bend, &mut new_springs);
                        }
                    }
                    for j in 0..g.ny - 2 {
                        for i in 0..g.nx {
                            push(g.v(i, j), g.v(i, j + 2), s, cell, SpringKind::Bend, &mut new_springs);
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
        if let Some(f) = &fracture {
            // The pushes left each spring's membrane width in its last field; now its strain limit (see
            // `Breakable::tear_strength`). Springs on no triangle (bending, the second diagonal) stand for no strip
            // of membrane of their own: they take the mean tear strain of the edge springs, so they break as a
            // crack opens across them instead of holding its sides together.
            let edge = |sp: &(_, f64, f64, f64, SpringKind, f64)| sp.4 == SpringKind::Edge;
            let tear: Vec<f64> = new_springs.iter().map(|sp| f.spring_strain_limit(sp.2, sp.1, sp.5)).collect();
            let (sum, count) = new_springs
                .iter()
                .zip(&tear)
                .filter(|(sp, t)| edge(sp) && t.is_finite())
                .fold((0.0, 0), |(s, c), (_, t)| (s + t, c + 1));
            let mean = if count > 0 { sum / count as f64 } else { f.strain_limit };
            for (sp, t) in new_springs.iter_mut().zip(tear) {
                sp.5 = if edge(sp) { t } else { mean.min(f.strain_limit) };
            }
        } else {
            new_springs.iter_mut().for_each(|sp| sp.5 = f64::INFINITY);
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
            gas_inflow: 0.0,
            external_pressure: 0.0,
            rest_volume: 0.0,
            aero,
            anchor: base,
            fracture,
            contact: None,
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
        let mut particle_handle = vec![NONE; n];
        let mut pinned = self.pinned.clone();
        for (h, (_, particles)) in self.handles.iter().enumerate() {
            for &i in particles {
                particle_handle[i] = h as u32;
                pinned[i] = true;
            }
        }
        let mut model = Model {
            particle_q0: self.q.iter().map(|&x| v(x)).collect(),
            particle_qd0: self.qd.iter().map(|&x| v(x)).collect(),
            particle_mass: self.mass.iter().map(|&m| r(m)).collect(),
            particle_inv_mass: self
                .mass
                .iter()
                .zip(&pinned)
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
                    if bi == bj { r(s.5) } else { R::infinity() }
                })
                .collect(),
            particle_load_limit: self.particle_body.iter().map(|&b| r(breakable(b).load_limit)).collect(),
            tri_indices: self.tris.clone(),
            tri_body: self.tri_body.clone(),
            body_kind: self.bodies.iter().map(|b| b.kind).collect(),
            body_gas_amount: self.bodies.iter().map(|b| r(b.gas)).collect(),
            body_gas_inflow: self.bodies.iter().map(|b| r(b.gas_inflow)).collect(),
            body_pressure_external: self.bodies.iter().map(|b| r(b.external_pressure)).collect(),
            body_rest_volume: self.bodies.iter().map(|b| r(b.rest_volume)).collect(),
            body_drag: self.bodies.iter().map(|b| r(b.aero.drag)).collect(),
            body_lift: self.bodies.iter().map(|b| r(b.aero.lift)).collect(),
            body_anchor: self.bodies.iter().map(|b| b.anchor).collect(),
            body_sealed: self.bodies.iter().map(|b| b.fracture.is_some_and(|f| f.sealed)).collect(),
            body_contact_thickness: (0..self.bodies.len()).map(|b| r(self.contact_thickness(b))).collect(),
            body_self_contact: self.bodies.iter().map(|b| b.contact.is_some_and(|c| c.self_collision)).collect(),
            body_contact_friction: self.bodies.iter().map(|b| r(b.contact.map_or(0.0, |c| c.friction))).collect(),
            particle_origin: (0..n as u32).collect(),
            particle_handle,
            handles: self.handles.iter().map(|(h, _)| h.clone()).collect(),
            openings: Vec::new(),
            breakable: false,
            tri_grids: self.tri_grids.clone(),
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
