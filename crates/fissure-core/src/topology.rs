//! Derived topology of a triangle mesh: unique edges with their faces, vertex -> faces in CSR form,
//! boundary loops and connected components.
//!
//! Everything here is derived from `(vertex_count, triangles)` and rebuilt (or, by the fracture code, patched)
//! when they change. Building sorts the directed half-edges once, `O(F log F)`, and in that one scan finds the
//! non-manifold edges (more than two faces) and the inconsistently wound ones (two faces traversing an edge the
//! same way).

use crate::csr::Csr;
use crate::error::MeshError;

/// Marks "no face" in [`Topology::edge_faces`].
pub const NONE: u32 = u32::MAX;

/// Edges, edge -> faces and vertex -> faces of a manifold, consistently wound triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct Topology {
    /// Unique edges, `[a, b]` with `a < b`, sorted.
    pub edges: Vec<[u32; 2]>,
    /// The one or two faces of each edge; the second is [`NONE`] on a boundary edge.
    pub edge_faces: Vec<[u32; 2]>,
    /// Faces around each vertex.
    pub vertex_faces: Csr,
}

impl Topology {
    /// Builds the topology, failing on non-manifold edges and inconsistent winding.
    pub fn build(vertex_count: usize, triangles: &[[u32; 3]]) -> Result<Self, MeshError> {
        // (min, max, face, forward) for every directed half-edge.
        let mut half: Vec<(u32, u32, u32, bool)> = Vec::with_capacity(triangles.len() * 3);
        for (f, t) in triangles.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                half.push((a.min(b), a.max(b), f as u32, a < b));
            }
        }
        half.sort_unstable();
        let mut edges = Vec::with_capacity(half.len() / 2 + 1);
        let mut edge_faces = Vec::with_capacity(half.len() / 2 + 1);
        let mut i = 0;
        while i < half.len() {
            let (a, b, f0, d0) = half[i];
            let mut j = i + 1;
            while j < half.len() && half[j].0 == a && half[j].1 == b {
                j += 1;
            }
            match j - i {
                1 => edge_faces.push([f0, NONE]),
                2 => {
                    let (_, _, f1, d1) = half[i + 1];
                    if d0 == d1 {
                        let (s, e) = if d0 { (a, b) } else { (b, a) };
                        return Err(MeshError::InconsistentWinding { a: s, b: e, t0: f0, t1: f1 });
                    }
                    edge_faces.push([f0, f1]);
                }
                n => {
                    return Err(MeshError::NonManifoldEdge {
                        a,
                        b,
                        faces: n,
                        examples: half[i..j].iter().take(3).map(|h| h.2).collect(),
                    });
                }
            }
            edges.push([a, b]);
            i = j;
        }
        let vertex_faces = Csr::from_pairs(
            vertex_count,
            triangles.iter().enumerate().flat_map(|(f, t)| t.iter().map(move |&v| (v, f as u32))),
        );
        Ok(Topology { edges, edge_faces, vertex_faces })
    }

    /// Indices (into [`Self::edges`]) of the edges with a single face.
    pub fn boundary_edges(&self) -> impl Iterator<Item = usize> + '_ {
        self.edge_faces.iter().enumerate().filter(|(_, f)| f[1] == NONE).map(|(e, _)| e)
    }

    /// True when every edge has two faces.
    pub fn is_closed(&self) -> bool {
        self.boundary_edges().next().is_none()
    }

    /// Boundary loops, each a cycle of vertices in the direction the faces traverse them (so a loop runs
    /// clockwise seen from outside: the opening's own normal points inwards).
    pub fn boundary_loops(&self, triangles: &[[u32; 3]]) -> Vec<Vec<u32>> {
        // Directed boundary half-edges u -> v as their face traverses them.
        let mut directed: Vec<(u32, u32)> = self
            .boundary_edges()
            .map(|e| {
                let [a, b] = self.edges[e];
                let t = triangles[self.edge_faces[e][0] as usize];
                let forward = (0..3).any(|k| t[k] == a && t[(k + 1) % 3] == b);
                if forward { (a, b) } else { (b, a) }
            })
            .collect();
        directed.sort_unstable();
        let mut used = vec![false; directed.len()];
        let mut loops = Vec::new();
        for start in 0..directed.len() {
            if used[start] {
                continue;
            }
            let mut cycle = Vec::new();
            let mut cur = start;
            loop {
                used[cur] = true;
                let (u, v) = directed[cur];
                cycle.push(u);
                // Next unused half-edge leaving v (a pinched vertex has several; take the first, deterministic).
                let lo = directed.partition_point(|&(x, _)| x < v);
                match (lo..directed.len()).take_while(|&k| directed[k].0 == v).find(|&k| !used[k]) {
                    Some(k) => cur = k,
                    None => break,
                }
            }
            loops.push(cycle);
        }
        loops
    }
}

/// Connected components of a graph given by its edges: `(count, label per vertex)`, labels numbered in order
/// of each component's lowest vertex (deterministic).
pub fn connected_components(vertex_count: usize, edges: impl Iterator<Item = [u32; 2]>) -> (usize, Vec<u32>) {
    let mut parent: Vec<u32> = (0..vertex_count as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for [a, b] in edges {
        let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
        if ra != rb {
            // Union by smaller root so the root of a component is its lowest vertex.
            let (lo, hi) = (ra.min(rb), ra.max(rb));
            parent[hi as usize] = lo;
        }
    }
    let mut label = vec![NONE; vertex_count];
    let mut count = 0usize;
    for v in 0..vertex_count {
        let r = find(&mut parent, v as u32) as usize;
        if label[r] == NONE {
            label[r] = count as u32;
            count += 1;
        }
        label[v] = label[r];
    }
    (count, label)
}

/// The edges along cracks: boundary edges (one face) that touch a particle fracture made (`origin` not itself:
/// the virtual nodes a spring split puts on a cut spring, the copies of a core block's ring), or that have a twin,
/// another boundary edge between copies of the same two original particles (`origin` followed to its root: the
/// rim of a hole, whose vertices kept their identity, with the rim of the block that left it). A mesh's own border
/// (a cloth's edge) touches no such particle and has no twin: it is not a crack, except where a crack meets it.
/// What the renderer draws as crack lines.
pub fn crack_edges(triangles: &[[u32; 3]], origin: &[u32]) -> Vec<[u32; 2]> {
    let root = |mut v: u32| {
        // Copies of copies: follow the chain to the builder's particle (a few steps at most).
        while let Some(&o) = origin.get(v as usize) {
            if o == v {
                break;
            }
            v = o;
        }
        v
    };
    let mut edges: Vec<[u32; 2]> =
        triangles.iter().flat_map(|t| (0..3).map(move |k| sorted(t[k], t[(k + 1) % 3]))).collect();
    edges.sort_unstable();
    let mut boundary: Vec<([u32; 2], [u32; 2])> = Vec::new();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i == 1 {
            let [a, b] = edges[i];
            boundary.push((sorted(root(a), root(b)), [a, b]));
        }
        i = j;
    }
    boundary.sort_unstable();
    let made = |v: u32| origin.get(v as usize).is_some_and(|&o| o != v);
    let mut out = Vec::new();
    let mut i = 0;
    while i < boundary.len() {
        let mut j = i + 1;
        while j < boundary.len() && boundary[j].0 == boundary[i].0 {
            j += 1;
        }
        let twinned = j - i >= 2;
        out.extend(boundary[i..j].iter().map(|(_, e)| *e).filter(|&[a, b]| twinned || made(a) || made(b)));
        i = j;
    }
    out.sort_unstable();
    out
}

fn sorted(a: u32, b: u32) -> [u32; 2] {
    [a.min(b), a.max(b)]
}
