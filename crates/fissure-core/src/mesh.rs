//! Triangle surface meshes: construction from arrays with validation, generators (icosphere, cloth grid, box),
//! OBJ import that welds seam-split vertices, OBJ and PLY export.
//!
//! Coordinates are `f64` metres. A [`Mesh`] that exists is valid: finite coordinates, indices in range, no
//! degenerate triangle, every edge shared by at most two consistently wound triangles.

use crate::error::MeshError;
use crate::topology::Topology;
use glam::DVec3;
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::Path;

/// Where [`Mesh::renumbered_for_locality`] moved each vertex and triangle: `vertex[old] = new`,
/// `triangle[old] = new` (for per-vertex or per-face data of the original mesh).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Renumbering {
    /// The new index of each old vertex.
    pub vertex: Vec<u32>,
    /// The new index of each old triangle.
    pub triangle: Vec<u32>,
}

/// A validated triangle mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    positions: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
}

/// Relative area below which a triangle is "zero-area": `|cross| <= AREA_EPS * longest_edge^2`.
const AREA_EPS: f64 = 1e-12;

impl Mesh {
    /// Builds and validates a mesh. Errors name the offending vertex, triangle or edge.
    pub fn new(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        Self::validate(&positions, &triangles)?;
        Ok(Mesh { positions, triangles })
    }

    /// Builds from flat arrays: `positions` of length `3 V`, `triangles` of length `3 F` (any integer type).
    pub fn from_flat<I: Copy + TryInto<u64>>(positions: &[f64], triangles: &[I]) -> Result<Self, MeshError> {
        let p = positions.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])).collect::<Vec<_>>();
        let n = p.len();
        let mut t = Vec::with_capacity(triangles.len() / 3);
        for (f, c) in triangles.chunks_exact(3).enumerate() {
            let mut tri = [0u32; 3];
            for k in 0..3 {
                let idx: u64 = c[k].try_into().unwrap_or(u64::MAX);
                if idx >= n as u64 {
                    return Err(MeshError::IndexOutOfRange { triangle: f, index: idx, vertex_count: n });
                }
                tri[k] = idx as u32;
            }
            t.push(tri);
        }
        Self::new(p, t)
    }

    fn validate(positions: &[DVec3], triangles: &[[u32; 3]]) -> Result<(), MeshError> {
        if positions.is_empty() || triangles.is_empty() {
            return Err(MeshError::Empty { vertices: positions.len(), triangles: triangles.len() });
        }
        if let Some((i, p)) = positions.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(MeshError::NonFinite { vertex: i, value: p.to_array() });
        }
        let n = positions.len();
        for (f, t) in triangles.iter().enumerate() {
            if let Some(&bad) = t.iter().find(|&&i| i as usize >= n) {
                return Err(MeshError::IndexOutOfRange { triangle: f, index: bad as u64, vertex_count: n });
            }
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
                return Err(MeshError::Degenerate { triangle: f, vertices: *t, reason: "a vertex is repeated" });
            }
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let longest = (b - a).length_squared().max((c - b).length_squared()).max((a - c).length_squared());
            if (b - a).cross(c - a).length() <= AREA_EPS * longest {
                return Err(MeshError::Degenerate {
                    triangle: f,
                    vertices: *t,
                    reason: "zero area (collinear or coincident vertices)",
                });
            }
        }
        Topology::build(n, triangles)?;
        Ok(())
    }

    /// Vertex positions \[m\].
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Triangles, counter-clockwise seen from outside (right-hand normal points out).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Number of vertices.
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The derived topology (valid meshes always have one).
    pub fn topology(&self) -> Topology {
        Topology::build(self.positions.len(), &self.triangles).expect("a Mesh is validated on construction")
    }

    /// True when every edge has two faces.
    pub fn is_closed(&self) -> bool {
        self.topology().is_closed()
    }

    /// Signed enclosed volume \[m^3\], `1/6 Σ x0 · (x1 × x2)` taken about the centroid to limit round-off; positive
    /// for an outward-facing closed mesh.
    pub fn signed_volume(&self) -> f64 {
        let c = self.centroid();
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, d] = t.map(|i| self.positions[i as usize] - c);
                a.dot(b.cross(d))
            })
            .sum::<f64>()
            / 6.0
    }

    /// Total surface area \[m^2\].
    pub fn area(&self) -> f64 {
        self.triangles.iter().map(|t| tri_area(&self.positions, t)).sum()
    }

    /// Mean of the vertex positions \[m\].
    pub fn centroid(&self) -> DVec3 {
        self.positions.iter().copied().sum::<DVec3>() / self.positions.len() as f64
    }

    /// Lengths of the shortest and longest edges \[m\].
    pub fn edge_length_range(&self) -> (f64, f64) {
        let mut lo = f64::INFINITY;
        let mut hi = 0.0f64;
        for t in &self.triangles {
            for k in 0..3 {
                let l = (self.positions[t[k] as usize] - self.positions[t[(k + 1) % 3] as usize]).length();
                lo = lo.min(l);
                hi = hi.max(l);
            }
        }
        (lo, hi)
    }

    /// Reverses every triangle's winding (flips all normals).
    pub fn flip_winding(&mut self) {
        for t in &mut self.triangles {
            t.swap(1, 2);
        }
    }

    /// Makes a closed mesh face outwards (positive signed volume); returns whether it had to flip it.
    pub fn orient_outward(&mut self) -> bool {
        if self.is_closed() && self.signed_volume() < 0.0 {
            self.flip_winding();
            true
        } else {
            false
        }
    }

    /// A copy with every position mapped by `f` (no validation beyond finiteness of the result).
    pub fn map_positions(&self, f: impl Fn(DVec3) -> DVec3) -> Result<Mesh, MeshError> {
        Mesh::new(self.positions.iter().map(|&p| f(p)).collect(), self.triangles.clone())
    }

    /// A copy moved by `offset` \[m\].
    pub fn translated(&self, offset: DVec3) -> Mesh {
        Mesh { positions: self.positions.iter().map(|&p| p + offset).collect(), triangles: self.triangles.clone() }
    }

    /// The same surface with its vertices renumbered for locality and its triangles in their order, and where
    /// each old vertex and triangle went ([`Renumbering`]). A model keeps the particle numbering of the meshes it is built from (it is the
    /// user's: pins, handles and the positions read back use it), orders a body's triangles by their sorted
    /// corners (as here) and its springs by its mesh's sorted edges; a mesh whose numbering has no locality (vertices in random order, as some
    /// exporters and tetrahedral meshers leave them) makes each particle's springs and triangles lie far apart
    /// in memory, and on two threads half of the gather's reads fall on what the other core wrote. Renumbering
    /// such a mesh first restores the fast path: on the 2,562-vertex pressurised ball with its vertices shuffled,
    /// `benches/ball.rs` measures the step before and after (see `benches/RESULTS.md`, issue 15).
    ///
    /// The order is reverse Cuthill–McKee, part by part: each connected part (in order of its least vertex)
    /// breadth-first from its vertex of least degree, neighbours in order of degree then index, then reversed.
    /// Deterministic. The triangles are then sorted by their corners (least first; winding kept), the order a
    /// model builder gives them anyway.
    pub fn renumbered_for_locality(&self) -> (Mesh, Renumbering) {
        let n = self.positions.len();
        let topo = self.topology();
        let mut adj: Vec<Vec<u32>> = vec![Vec::new(); n];
        for &[a, b] in &topo.edges {
            adj[a as usize].push(b);
            adj[b as usize].push(a);
        }
        let degree = |v: u32| adj[v as usize].len();
        // Each part (numbered in order of its least vertex) starts from its vertex of least degree, ties to the
        // least index.
        let (parts, label) = crate::topology::connected_components(n, topo.edges.iter().copied());
        let mut start = vec![u32::MAX; parts];
        for v in 0..n as u32 {
            let s = &mut start[label[v as usize] as usize];
            if *s == u32::MAX || degree(v) < degree(*s) {
                *s = v;
            }
        }
        let mut seen = vec![false; n];
        let mut order: Vec<u32> = Vec::with_capacity(n);
        for s in start {
            let from = order.len();
            seen[s as usize] = true;
            order.push(s);
            let mut head = from;
            while head < order.len() {
                let v = order[head];
                head += 1;
                let mut next: Vec<u32> = adj[v as usize].iter().copied().filter(|&w| !seen[w as usize]).collect();
                next.sort_by_key(|&w| (degree(w), w));
                for w in next {
                    seen[w as usize] = true;
                    order.push(w);
                }
            }
            order[from..].reverse();
        }
        let mut new_of_old = vec![0u32; n];
        for (new, &old) in order.iter().enumerate() {
            new_of_old[old as usize] = new as u32;
        }
        let positions = order.iter().map(|&old| self.positions[old as usize]).collect();
        let mapped: Vec<[u32; 3]> = self.triangles.iter().map(|t| t.map(|v| new_of_old[v as usize])).collect();
        // The triangles in the vertices' order too: by their corners sorted (least first), winding kept.
        let mut tri_order: Vec<u32> = (0..mapped.len() as u32).collect();
        tri_order.sort_by_key(|&t| (sorted_corners(&mapped[t as usize]), t));
        let mut triangle = vec![0u32; mapped.len()];
        for (new, &old) in tri_order.iter().enumerate() {
            triangle[old as usize] = new as u32;
        }
        let triangles = tri_order.iter().map(|&t| mapped[t as usize]).collect();
        (Mesh { positions, triangles }, Renumbering { vertex: new_of_old, triangle })
    }

    /// Icosphere of `radius` \[m\]: an icosahedron subdivided `subdivisions` times, vertices projected onto the
    /// sphere. `10·4^s + 2` vertices, `20·4^s` triangles (s = 4: 2,562 vertices; s = 6: 40,962).
    ///
    /// Numbered for locality ([`Mesh::renumbered_for_locality`]: reverse Cuthill–McKee, the triangles in their
    /// corners' order), not in the order subdivision makes them (the icosahedron's twelve vertices first, then
    /// each level's edge midpoints), where a vertex's neighbours lie across the whole numbering: on two threads
    /// each core then gathers forces the other core wrote. The icosahedron's twelve vertices are the ones with
    /// five neighbours. Measured with `cargo bench --bench ball` and `fissure bench --only terms` (two threads,
    /// the Zen 4 development VM, 2026-11-29): the 2,562-vertex pressurised ball 53 → 45 µs a step, the
    /// 10,242-vertex ball 145 → 111 µs without gas and 200 → 160 µs with it (`benches/RESULTS.md`, issue 15).
    pub fn icosphere(radius: f64, subdivisions: u32) -> Mesh {
        let t = (1.0 + 5f64.sqrt()) / 2.0;
        let mut pos: Vec<DVec3> = [
            (-1.0, t, 0.0),
            (1.0, t, 0.0),
            (-1.0, -t, 0.0),
            (1.0, -t, 0.0),
            (0.0, -1.0, t),
            (0.0, 1.0, t),
            (0.0, -1.0, -t),
            (0.0, 1.0, -t),
            (t, 0.0, -1.0),
            (t, 0.0, 1.0),
            (-t, 0.0, -1.0),
            (-t, 0.0, 1.0),
        ]
        .iter()
        .map(|&(x, y, z)| DVec3::new(x, y, z).normalize())
        .collect();
        let mut tris: Vec<[u32; 3]> = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        for _ in 0..subdivisions {
            let mut mid: HashMap<(u32, u32), u32> = HashMap::with_capacity(tris.len() * 3 / 2);
            let mut next = Vec::with_capacity(tris.len() * 4);
            for &[a, b, c] in &tris {
                let mut m = |i: u32, j: u32| -> u32 {
                    *mid.entry((i.min(j), i.max(j))).or_insert_with(|| {
                        pos.push(((pos[i as usize] + pos[j as usize]) * 0.5).normalize());
                        pos.len() as u32 - 1
                    })
                };
                let (ab, bc, ca) = (m(a, b), m(b, c), m(c, a));
                next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
            }
            tris = next;
        }
        let subdivided = Mesh { positions: pos.into_iter().map(|p| p * radius).collect(), triangles: tris };
        subdivided.renumbered_for_locality().0
    }

    /// A rectangular cloth grid of `nx × ny` vertices with `spacing` \[m\], in the XY plane (z = 0), x to the right,
    /// y downwards from 0 (row 0 is the top edge, y = 0; row j at y = -j·spacing). Vertex `(i, j)` is
    /// `j·nx + i`. Each quad is split along alternating diagonals so the grid has no preferred shear direction;
    /// normals point towards +z.
    pub fn grid(nx: usize, ny: usize, spacing: f64) -> Mesh {
        assert!(nx >= 2 && ny >= 2, "a grid needs at least 2 × 2 vertices");
        let mut pos = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                pos.push(DVec3::new(i as f64 * spacing, -(j as f64) * spacing, 0.0));
            }
        }
        let mut tris = Vec::with_capacity(2 * (nx - 1) * (ny - 1));
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let v = |a: usize, b: usize| (b * nx + a) as u32;
                let (p00, p10, p01, p11) = (v(i, j), v(i + 1, j), v(i, j + 1), v(i + 1, j + 1));
                // Seen from +z with y pointing up, (p01, p11, p10) is counter-clockwise.
                if (i + j) % 2 == 0 {
                    tris.push([p00, p01, p11]);
                    tris.push([p00, p11, p10]);
                } else {
                    tris.push([p00, p01, p10]);
                    tris.push([p10, p01, p11]);
                }
            }
        }
        Mesh { positions: pos, triangles: tris }
    }

    /// A closed box centred at the origin with `half_extents` \[m\], each face split into `n × n` quads.
    pub fn cuboid(half_extents: DVec3, n: usize) -> Mesh {
        let n = n.max(1);
        let mut pos: Vec<DVec3> = Vec::new();
        let mut tris = Vec::new();
        let mut index: HashMap<[i64; 3], u32> = HashMap::new();
        // Integer lattice coordinates in [-n, n] make shared corners and edges weld exactly.
        let mut vid = |l: [i64; 3], pos: &mut Vec<DVec3>| -> u32 {
            *index.entry(l).or_insert_with(|| {
                pos.push(DVec3::new(l[0] as f64, l[1] as f64, l[2] as f64) / n as f64 * half_extents);
                pos.len() as u32 - 1
            })
        };
        let n = n as i64;
        // For each face: the fixed axis and sign, and two in-plane axes (u, v) with u × v = outward normal.
        for (axis, sign, u, v) in
            [(0, 1, 1, 2), (0, -1, 2, 1), (1, 1, 2, 0), (1, -1, 0, 2), (2, 1, 0, 1), (2, -1, 1, 0)]
        {
            for a in 0..2 * n {
                for b in 0..2 * n {
                    let mut q = [[0i64; 3]; 4];
                    for (k, (da, db)) in [(0, 0), (1, 0), (1, 1), (0, 1)].into_iter().enumerate() {
                        q[k][axis] = sign * n;
                        q[k][u] = a - n + da;
                        q[k][v] = b - n + db;
                    }
                    let id = q.map(|l| vid(l, &mut pos));
                    tris.push([id[0], id[1], id[2]]);
                    tris.push([id[0], id[2], id[3]]);
                }
            }
        }
        Mesh { positions: pos, triangles: tris }
    }

    /// Merges vertices closer than `tolerance` \[m\] (a hash grid; each vertex maps to the first, lowest-index
    /// vertex within reach) and drops vertices no triangle uses. OBJ exports split vertices at UV and normal
    /// seams, which leaves a "closed" sphere full of cracks; welding restores it.
    pub fn weld(positions: &[DVec3], triangles: &[[u32; 3]], tolerance: f64) -> Result<Mesh, MeshError> {
        let cell = tolerance.max(f64::MIN_POSITIVE) * 2.0;
        let key = |p: DVec3| [(p.x / cell).floor() as i64, (p.y / cell).floor() as i64, (p.z / cell).floor() as i64];
        let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        let mut remap = vec![0u32; positions.len()];
        let mut out: Vec<DVec3> = Vec::new();
        for (i, &p) in positions.iter().enumerate() {
            if !p.is_finite() {
                return Err(MeshError::NonFinite { vertex: i, value: p.to_array() });
            }
            let k = key(p);
            let mut found = None;
            'search: for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        if let Some(list) = grid.get(&[k[0] + dx, k[1] + dy, k[2] + dz])
                            && let Some(&j) = list.iter().find(|&&j| (out[j as usize] - p).length() <= tolerance)
                        {
                            found = Some(j);
                            break 'search;
                        }
                    }
                }
            }
            remap[i] = match found {
                Some(j) => j,
                None => {
                    out.push(p);
                    let j = out.len() as u32 - 1;
                    grid.entry(k).or_default().push(j);
                    j
                }
            };
        }
        let mut tris = Vec::with_capacity(triangles.len());
        for (f, t) in triangles.iter().enumerate() {
            if let Some(&bad) = t.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(MeshError::IndexOutOfRange {
                    triangle: f,
                    index: bad as u64,
                    vertex_count: positions.len(),
                });
            }
            tris.push(t.map(|i| remap[i as usize]));
        }
        // Drop unreferenced vertices, keeping the order of first use by index.
        let mut used = vec![u32::MAX; out.len()];
        let mut compact = Vec::new();
        for t in &tris {
            for &v in t {
                used[v as usize] = 0;
            }
        }
        for (i, u) in used.iter_mut().enumerate() {
            if *u == 0 {
                *u = compact.len() as u32;
                compact.push(out[i]);
            }
        }
        let tris = tris.into_iter().map(|t| t.map(|v| used[v as usize])).collect();
        Mesh::new(compact, tris)
    }

    /// Loads a Wavefront OBJ (all objects merged, polygons triangulated), then welds vertices within
    /// `weld_tolerance` \[m\] (pass `None` for 1e-6 of the bounding-box diagonal).
    pub fn load_obj(path: impl AsRef<Path>, weld_tolerance: Option<f64>) -> Result<Mesh, MeshError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path)
            .map_err(|e| MeshError::Io { path: path.display().to_string(), message: e.to_string() })?;
        Self::parse_obj(&text, weld_tolerance).map_err(|e| match e {
            MeshError::Io { message, .. } => MeshError::Io { path: path.display().to_string(), message },
            other => other,
        })
    }

    /// Parses OBJ text; see [`Mesh::load_obj`].
    pub fn parse_obj(text: &str, weld_tolerance: Option<f64>) -> Result<Mesh, MeshError> {
        let opts =
            tobj::LoadOptions { single_index: false, triangulate: true, ignore_points: true, ignore_lines: true };
        let (models, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| Err(tobj::LoadError::OpenFileFailed))
            .map_err(|e| MeshError::Io { path: "<obj>".into(), message: format!("OBJ parse error: {e}") })?;
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        for m in &models {
            let base = positions.len() as u32;
            positions.extend(m.mesh.positions.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])));
            triangles.extend(m.mesh.indices.chunks_exact(3).map(|c| [c[0] + base, c[1] + base, c[2] + base]));
        }
        if positions.is_empty() || triangles.is_empty() {
            return Err(MeshError::Empty { vertices: positions.len(), triangles: triangles.len() });
        }
        let tol = weld_tolerance.unwrap_or_else(|| {
            let (lo, hi) = positions
                .iter()
                .fold((DVec3::splat(f64::MAX), DVec3::splat(f64::MIN)), |(l, h), &p| (l.min(p), h.max(p)));
            1e-6 * (hi - lo).length()
        });
        Self::weld(&positions, &triangles, tol)
    }

    /// Writes OBJ text (`v` and `f` lines, 1-based).
    pub fn to_obj_string(&self) -> String {
        write_obj(&self.positions, &self.triangles)
    }

    /// Writes an OBJ file.
    pub fn save_obj(&self, path: impl AsRef<Path>) -> Result<(), MeshError> {
        write_file(path.as_ref(), &self.to_obj_string())
    }

    /// Writes an ASCII PLY file.
    pub fn save_ply(&self, path: impl AsRef<Path>) -> Result<(), MeshError> {
        write_file(path.as_ref(), &write_ply(&self.positions, &self.triangles))
    }
}

/// Area of triangle `t` \[m^2\].
pub(crate) fn tri_area(p: &[DVec3], t: &[u32; 3]) -> f64 {
    let [a, b, c] = t.map(|i| p[i as usize]);
    0.5 * (b - a).cross(c - a).length()
}

/// OBJ text for any positions and triangles (used for simulation frames too).
pub fn write_obj(positions: &[DVec3], triangles: &[[u32; 3]]) -> String {
    let mut s = String::with_capacity(positions.len() * 40 + triangles.len() * 24);
    s.push_str("# written by fissure\n");
    for p in positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for t in triangles {
        let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
    }
    s
}

/// ASCII PLY text for any positions and triangles.
pub fn write_ply(positions: &[DVec3], triangles: &[[u32; 3]]) -> String {
    let mut s = String::new();
    let _ = write!(
        s,
        "ply\nformat ascii 1.0\ncomment written by fissure\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\nelement face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        positions.len(),
        triangles.len()
    );
    for p in positions {
        let _ = writeln!(s, "{} {} {}", p.x, p.y, p.z);
    }
    for t in triangles {
        let _ = writeln!(s, "3 {} {} {}", t[0], t[1], t[2]);
    }
    s
}

fn write_file(path: &Path, text: &str) -> Result<(), MeshError> {
    std::fs::write(path, text).map_err(|e| MeshError::Io { path: path.display().to_string(), message: e.to_string() })
}

/// A triangle's corners in increasing order: the key that orders a body's triangles after its particles (the
/// model builder and [`Mesh::renumbered_for_locality`]).
pub(crate) fn sorted_corners(t: &[u32; 3]) -> [u32; 3] {
    let mut k = *t;
    k.sort_unstable();
    k
}
