//! Crack edges (`topology::crack_edges`, drawn by the renderer): none on an intact mesh or along a cloth's own
//! border; both lips of a slit (the virtual nodes' edges included); the rims of a hole and of the block that
//! left it.

use fissure_core::topology::crack_edges;
use fissure_core::*;

fn boundary_edges(tris: &[[u32; 3]]) -> std::collections::BTreeSet<[u32; 2]> {
    let mut count = std::collections::BTreeMap::new();
    for t in tris {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *count.entry([a.min(b), a.max(b)]).or_insert(0) += 1;
        }
    }
    count.into_iter().filter(|(_, n)| *n == 1).map(|(e, _)| e).collect()
}

#[test]
fn a_cut_cloth_shows_both_lips_and_not_its_border() {
    let mut b = ModelBuilder::new();
    let opts =
        ClothOptions { fracture: Some(Breakable { strain_limit: 0.3, ..Default::default() }), ..Default::default() };
    b.add_cloth_grid(9, 9, 0.1, |p| p, &opts).unwrap();
    let mut m: Model<f64> = b.finalize().unwrap();
    let mut s = m.state();
    assert!(crack_edges(&m.tri_indices, &m.particle_origin).is_empty(), "an intact cloth has no cracks");
    assert!(!boundary_edges(&m.tri_indices).is_empty());
    // Cut three vertical edge springs across the middle row: a slit.
    let mut f = Fracture::<f64>::default();
    for x in 3..6u32 {
        let sp = fracture::spring_between(&m, 4 * 9 + x, 5 * 9 + x).unwrap() as usize;
        assert!(!f.break_spring(&mut m, &mut s, sp).events.is_empty());
    }
    let cracks = crack_edges(&m.tri_indices, &m.particle_origin);
    let border = boundary_edges(&m.tri_indices);
    assert!(cracks.iter().all(|e| border.contains(e)), "crack edges are boundary edges");
    assert!(cracks.len() >= 4 && cracks.len().is_multiple_of(2), "two lips: {cracks:?}");
    // Every boundary edge is either on the cloth's outer border (32 edges) or on the slit, never both.
    assert_eq!(border.len(), cracks.len() + 32, "{cracks:?}");
}

#[test]
fn a_punched_ball_shows_the_rim_of_its_hole_and_of_the_block() {
    let mut b = ModelBuilder::new();
    let opts = SoftBodyOptions {
        gas: Gas::Pressure(1000.0),
        fracture: Some(Breakable { load_limit: 10.0, ..Default::default() }),
        ..Default::default()
    };
    b.add_soft_body(&Mesh::icosphere(0.3, 2), &opts).unwrap();
    let mut m: Model<f64> = b.finalize().unwrap();
    let mut s = m.state();
    assert!(crack_edges(&m.tri_indices, &m.particle_origin).is_empty());
    let v = 20; // valence 6
    assert!(!Fracture::<f64>::default().break_core(&mut m, &mut s, v).events.is_empty());
    let cracks = crack_edges(&m.tri_indices, &m.particle_origin);
    // The block is the vertex's one-ring (6 triangles): its rim of 6 edges, and the hole's rim of 6.
    assert_eq!(cracks.len(), 12, "{cracks:?}");
    assert_eq!(boundary_edges(&m.tri_indices).len(), 12);
}
