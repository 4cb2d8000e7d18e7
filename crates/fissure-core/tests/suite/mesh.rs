//! Mesh construction, validation errors, generators, OBJ welding and export, topology.

use crate::common;

use fissure_core::glam::DVec3;
use fissure_core::topology::connected_components;
use fissure_core::*;

fn tetra() -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let p = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
    // Outward-facing.
    let t = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
    (p, t)
}

#[test]
fn valid_tetrahedron_is_closed_and_outward() {
    let (p, t) = tetra();
    let m = Mesh::new(p, t).unwrap();
    assert!(m.is_closed());
    assert!((m.signed_volume() - 1.0 / 6.0).abs() < 1e-15);
}

#[test]
fn each_bad_input_gets_its_own_error() {
    let (p, t) = tetra();
    let mut bad = p.clone();
    bad[2].y = f64::NAN;
    assert!(matches!(Mesh::new(bad, t.clone()), Err(MeshError::NonFinite { vertex: 2, .. })));
    let mut bad = p.clone();
    bad[1].x = f64::INFINITY;
    assert!(matches!(Mesh::new(bad, t.clone()), Err(MeshError::NonFinite { vertex: 1, .. })));
    let mut tt = t.clone();
    tt[3][1] = 9;
    assert!(matches!(
        Mesh::new(p.clone(), tt),
        Err(MeshError::IndexOutOfRange { triangle: 3, index: 9, vertex_count: 4 })
    ));
    let mut tt = t.clone();
    tt[1] = [0, 1, 1];
    assert!(matches!(Mesh::new(p.clone(), tt), Err(MeshError::Degenerate { triangle: 1, .. })));
    // Collinear vertices: zero area.
    let line = vec![DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
    assert!(matches!(Mesh::new(line, vec![[0, 1, 2]]), Err(MeshError::Degenerate { triangle: 0, .. })));
    // Three triangles on one edge.
    let fan = vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z, DVec3::new(0.0, -1.0, 0.3)];
    let e = Mesh::new(fan, vec![[0, 1, 2], [1, 0, 3], [0, 1, 4]]).unwrap_err();
    assert!(matches!(e, MeshError::NonManifoldEdge { a: 0, b: 1, faces: 3, .. }), "{e}");
    // One face flipped.
    let mut tt = t.clone();
    tt[2].swap(1, 2);
    assert!(matches!(Mesh::new(p.clone(), tt), Err(MeshError::InconsistentWinding { .. })));
    assert!(matches!(Mesh::new(vec![], vec![]), Err(MeshError::Empty { .. })));
    // Messages name the problem.
    let msg =
        Mesh::new(vec![DVec3::new(f64::NAN, 0.0, 0.0), DVec3::X, DVec3::Y], vec![[0, 1, 2]]).unwrap_err().to_string();
    assert!(msg.contains("non-finite") && msg.contains("vertex 0"), "{msg}");
}

#[test]
fn inward_facing_mesh_is_reoriented_or_rejected() {
    let (p, mut t) = tetra();
    for tri in &mut t {
        tri.swap(1, 2);
    }
    let inward = Mesh::new(p, t).unwrap();
    assert!(inward.signed_volume() < 0.0);
    let mut b = ModelBuilder::new();
    b.add_soft_body(&inward, &SoftBodyOptions::default()).unwrap();
    let model: Model<f64> = b.finalize().unwrap();
    assert!(model.body_volumes(&model.state())[0] > 0.0, "reoriented outward");
    let mut b = ModelBuilder::new();
    let e = b.add_soft_body(&inward, &SoftBodyOptions { reorient: false, ..Default::default() }).unwrap_err();
    assert!(matches!(e, ModelError::Mesh(MeshError::InwardFacing { .. })), "{e}");
}

#[test]
fn open_mesh_with_gas_is_rejected_with_a_message() {
    let grid = Mesh::grid(4, 4, 0.1);
    let mut b = ModelBuilder::new();
    let e = b.add_soft_body(&grid, &SoftBodyOptions::default()).unwrap_err();
    assert!(matches!(e, ModelError::Mesh(MeshError::Open { boundary_edges: 12, .. })), "{e}");
    assert!(e.to_string().contains("closed surface"));
    // Without gas it is accepted (a hollow membrane).
    b.add_soft_body(&grid, &SoftBodyOptions { gas: Gas::None, ..Default::default() }).unwrap();
}

#[test]
fn bad_parameters_are_named() {
    let mut b = ModelBuilder::new();
    let m = Mesh::icosphere(1.0, 0);
    let e = b.add_soft_body(&m, &SoftBodyOptions { mass: Mass::Total(-1.0), ..Default::default() }).unwrap_err();
    assert!(e.to_string().contains("mass"), "{e}");
    let e = b.add_cloth(&Mesh::grid(3, 3, 0.1), &ClothOptions { pins: vec![99], ..Default::default() }).unwrap_err();
    assert!(matches!(e, ModelError::ParticleOutOfRange { index: 99, count: 9, .. }), "{e}");
    assert!(matches!(ModelBuilder::new().finalize::<f32>(), Err(ModelError::Empty)));
}

#[test]
fn generators_are_valid_with_expected_counts() {
    for s in 0..5 {
        let m = Mesh::icosphere(2.0, s);
        assert_eq!(m.vertex_count(), 10 * 4usize.pow(s) + 2);
        assert_eq!(m.triangle_count(), 20 * 4usize.pow(s));
        assert!(m.is_closed());
        assert!(m.positions().iter().all(|p| (p.length() - 2.0).abs() < 1e-12));
        // Volume approaches 4/3 π r³ from below.
        let exact = 4.0 / 3.0 * std::f64::consts::PI * 8.0;
        assert!(m.signed_volume() > 0.0 && m.signed_volume() < exact);
    }
    let b = Mesh::cuboid(DVec3::new(1.0, 2.0, 3.0), 3);
    assert!(b.is_closed());
    assert!((b.signed_volume() - 48.0).abs() < 1e-12);
    assert!((b.area() - 88.0).abs() < 1e-9, "box 2 × 4 × 6 has area 88, got {}", b.area());
    let g = Mesh::grid(5, 4, 0.5);
    assert_eq!((g.vertex_count(), g.triangle_count()), (20, 24));
    assert!((g.area() - 2.0 * 1.5).abs() < 1e-12);
    let topo = g.topology();
    assert_eq!(topo.boundary_loops(g.triangles()).len(), 1);
    assert_eq!(topo.boundary_loops(g.triangles())[0].len(), 14);
}

/// A cube exported the way DCC tools do: every face has its own four vertices (split at UV and normal seams),
/// with `vt`/`vn` indices.
fn seamed_cube_obj() -> String {
    let mut s = String::from("# seamed cube\nmtllib missing.mtl\no Cube\n");
    let faces = [
        ([1.0, 0.0, 0.0], [[1, -1, -1], [1, 1, -1], [1, 1, 1], [1, -1, 1]]),
        ([-1.0, 0.0, 0.0], [[-1, -1, 1], [-1, 1, 1], [-1, 1, -1], [-1, -1, -1]]),
        ([0.0, 1.0, 0.0], [[-1, 1, -1], [-1, 1, 1], [1, 1, 1], [1, 1, -1]]),
        ([0.0, -1.0, 0.0], [[-1, -1, 1], [-1, -1, -1], [1, -1, -1], [1, -1, 1]]),
        ([0.0, 0.0, 1.0], [[-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]]),
        ([0.0, 0.0, -1.0], [[1, -1, -1], [-1, -1, -1], [-1, 1, -1], [1, 1, -1]]),
    ];
    for (_, quad) in &faces {
        for v in quad {
            s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
        }
    }
    for uv in ["0 0", "1 0", "1 1", "0 1"] {
        s += &format!("vt {uv}\n");
    }
    for (n, _) in &faces {
        s += &format!("vn {} {} {}\n", n[0], n[1], n[2]);
    }
    s += "usemtl skin\ns off\n";
    for (f, _) in faces.iter().enumerate() {
        let b = f * 4 + 1;
        s += &format!("f {}/1/{n} {}/2/{n} {}/3/{n} {}/4/{n}\n", b, b + 1, b + 2, b + 3, n = f + 1);
    }
    s
}

#[test]
fn seamed_obj_welds_into_one_closed_surface() {
    let text = seamed_cube_obj();
    let m = Mesh::parse_obj(&text, None).unwrap();
    assert_eq!(m.vertex_count(), 8, "24 seam-split vertices weld to 8");
    assert_eq!(m.triangle_count(), 12);
    assert!(m.is_closed());
    assert!((m.signed_volume().abs() - 8.0).abs() < 1e-12);
    let (n, _) = connected_components(m.vertex_count(), m.topology().edges.iter().copied());
    assert_eq!(n, 1);
    // The same through the file loader.
    let dir = std::env::temp_dir().join(format!("fissure-obj-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("cube.obj");
    std::fs::write(&path, &text).unwrap();
    let loaded = Mesh::load_obj(&path, None).unwrap();
    assert_eq!(loaded, m);
    // Round trip through our own OBJ and PLY writers.
    let out = dir.join("out.obj");
    m.save_obj(&out).unwrap();
    assert_eq!(Mesh::load_obj(&out, Some(0.0)).unwrap(), m);
    let ply = dir.join("out.ply");
    m.save_ply(&ply).unwrap();
    let ply_text = std::fs::read_to_string(&ply).unwrap();
    assert!(ply_text.starts_with("ply\nformat ascii 1.0") && ply_text.contains("element face 12"));
    let missing = Mesh::load_obj(dir.join("nope.obj"), None).unwrap_err();
    assert!(matches!(missing, MeshError::Io { .. }) && missing.to_string().contains("nope.obj"));
}

#[test]
fn unwelded_seams_leave_the_surface_open() {
    // The same cube built from the raw 24 vertices, seams not welded: six separate open squares. This is what
    // an importer without welding would hand the pressure model.
    let text = seamed_cube_obj();
    let mut p = Vec::new();
    let mut t = Vec::new();
    for line in text.lines() {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.first() {
            Some(&"v") => p.push(DVec3::new(w[1].parse().unwrap(), w[2].parse().unwrap(), w[3].parse().unwrap())),
            Some(&"f") => {
                let i: Vec<u32> =
                    w[1..].iter().map(|s| s.split('/').next().unwrap().parse::<u32>().unwrap() - 1).collect();
                t.push([i[0], i[1], i[2]]);
                t.push([i[0], i[2], i[3]]);
            }
            _ => {}
        }
    }
    let raw = Mesh::new(p, t).unwrap();
    assert!(!raw.is_closed());
    assert_eq!(raw.topology().boundary_loops(raw.triangles()).len(), 6);
}

#[test]
fn components_and_loops_of_two_separate_sheets() {
    let a = Mesh::grid(3, 3, 1.0);
    let mut p = a.positions().to_vec();
    let mut t = a.triangles().to_vec();
    p.extend(a.positions().iter().map(|q| *q + DVec3::Z * 5.0));
    t.extend(a.triangles().iter().map(|tri| tri.map(|v| v + 9)));
    let m = Mesh::new(p, t).unwrap();
    let topo = m.topology();
    assert_eq!(topo.boundary_loops(m.triangles()).len(), 2);
    let (n, label) = connected_components(m.vertex_count(), topo.edges.iter().copied());
    assert_eq!(n, 2);
    assert!(label[..9].iter().all(|&l| l == 0) && label[9..].iter().all(|&l| l == 1));
    // The alternating split routes all four quad diagonals of a 3 × 3 grid through its centre vertex.
    assert_eq!(topo.vertex_faces.row(4).len(), 8);
    assert_eq!(topo.vertex_faces.row(0).len(), 2);
}

#[test]
fn cloth_grid_has_provot_spring_counts() {
    let mut b = ModelBuilder::new();
    b.add_cloth_grid(128, 128, 0.01, |p| p, &ClothOptions::default()).unwrap();
    let m: Model<f32> = b.finalize().unwrap();
    assert_eq!(m.spring_count(), 97_026);
    let count = |k: SpringKind| m.spring_kind.iter().filter(|&&x| x == k).count();
    assert_eq!((count(SpringKind::Edge), count(SpringKind::Shear), count(SpringKind::Bend)), (32_512, 32_258, 32_256));
}

#[test]
fn membrane_stiffness_is_resolution_independent() {
    // Stretch two resolutions of the same square sheet by 1% along x; the total force needed matches.
    let force_for = |n: usize| {
        let mut b = ModelBuilder::new();
        b.gravity(DVec3::ZERO).unwrap();
        let opts =
            ClothOptions { stiffness: Stiffness::Membrane(100.0), shear: None, bending: None, ..Default::default() };
        b.add_cloth_grid(n, n, 1.0 / (n - 1) as f64, |p| p, &opts).unwrap();
        let model: Model<f64> = b.finalize().unwrap();
        let mut s = model.state();
        for q in &mut s.particle_q {
            q.x *= 1.01;
        }
        let mut f = vec![DVec3::ZERO; model.particle_count()];
        CpuSolver::<f64>::default().compute_forces(&model, &s, &mut f).unwrap();
        // Net x-force on the right edge column.
        (0..n).map(|j| f[j * n + n - 1].x).sum::<f64>()
    };
    let (coarse, fine) = (force_for(9), force_for(33));
    assert!(coarse < 0.0 && fine < 0.0);
    assert!((coarse / fine - 1.0).abs() < 0.05, "edge force {coarse} N (9²) vs {fine} N (33²)");
}

/// The largest index gap over the mesh's edges.
fn bandwidth(m: &Mesh) -> u32 {
    m.triangles().iter().flat_map(|t| [t[0].abs_diff(t[1]), t[1].abs_diff(t[2]), t[2].abs_diff(t[0])]).max().unwrap()
}

/// Reverse Cuthill–McKee on a ball whose vertices were shuffled, beside a cloth and a second ball (three
/// parts): the same surface (every vertex and triangle where the maps send them, winding kept), permutations,
/// triangles in the vertices' order, and a bandwidth of the order of a BFS level's width rather than of the
/// vertex count.
#[test]
fn renumbering_for_locality_keeps_the_surface_and_brings_neighbours_together() {
    let ball = common::shuffled_mesh(&Mesh::icosphere(0.25, 4), 42, false).0;
    let cloth = Mesh::grid(20, 30, 0.01);
    let small = Mesh::icosphere(0.1, 2).translated(DVec3::X);
    let (mut p, mut t) = (ball.positions().to_vec(), ball.triangles().to_vec());
    for m in [&cloth, &small] {
        let off = p.len() as u32;
        p.extend_from_slice(m.positions());
        t.extend(m.triangles().iter().map(|tri| tri.map(|v| v + off)));
    }
    let all = Mesh::new(p, t).unwrap();
    let (r, map) = all.renumbered_for_locality();
    let new_of_old = &map.vertex;
    let n = all.vertex_count();
    let mut hit = vec![false; n];
    for (old, &new) in new_of_old.iter().enumerate() {
        assert!(!std::mem::replace(&mut hit[new as usize], true), "vertex {new} used twice");
        assert_eq!(r.positions()[new as usize], all.positions()[old]);
    }
    let mut hit = vec![false; all.triangle_count()];
    for (old, t) in all.triangles().iter().enumerate() {
        let new = map.triangle[old] as usize;
        assert!(!std::mem::replace(&mut hit[new], true), "triangle {new} used twice");
        assert_eq!(t.map(|v| new_of_old[v as usize]), r.triangles()[new]);
    }
    // The triangles follow the vertices: sorted by their sorted corners.
    let key = |t: &[u32; 3]| {
        let mut k = *t;
        k.sort_unstable();
        k
    };
    assert!(r.triangles().windows(2).all(|w| key(&w[0]) <= key(&w[1])));
    assert!((r.signed_volume() - all.signed_volume()).abs() < 1e-12 * all.signed_volume());
    let (before, after) = (bandwidth(&all), bandwidth(&r));
    // The shuffled ball spans 2,562 indices; a BFS level of it is a ring of ~2π·(14 edges) vertices (83 here).
    assert!(before > 2000 && after < 150, "bandwidth {before} -> {after}");
    // The parts stay apart, in order: the shuffled ball's vertices first.
    assert!(new_of_old[..2562].iter().all(|&v| v < 2562));
    assert!(new_of_old[2562..3162].iter().all(|&v| (2562..3162).contains(&v)));
}
