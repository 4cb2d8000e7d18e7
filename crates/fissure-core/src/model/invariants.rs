//! The invariants every split keeps, checked in O(model) for tests and debugging.

use super::edit::spring_between;
use super::*;
use crate::real::Real;

/// Checks the invariants every split keeps; the first one broken, in words. Every index valid; every edge with
/// at most two triangles and a consistent winding (each directed edge used once); every triangle edge carried by
/// exactly one live spring and every live `Edge` spring between particles with triangles on a triangle edge;
/// triangles with three distinct corners and positive rest edges; a triangle's corners and a spring's ends in
/// its body; adjacency rows equal to the arrays; positive masses with matching inverse masses; openings walking
/// boundary edges. Cost: O(model), for tests and debugging.
pub fn check_invariants<R: Real>(m: &Model<R>) -> Result<(), String> {
    use std::collections::HashMap;
    let n = m.particle_count();
    let lens = [
        m.particle_q0.len(),
        m.particle_qd0.len(),
        m.particle_mass.len(),
        m.particle_inv_mass.len(),
        m.particle_body.len(),
        m.particle_load_limit.len(),
        m.particle_springs.rows(),
        m.particle_tris.rows(),
    ];
    if lens.iter().any(|&l| l != n) {
        return Err(format!("particle arrays disagree in length: {lens:?}"));
    }
    let ns = m.spring_count();
    let slens = [m.spring_rest_length.len(), m.spring_stiffness.len(), m.spring_damping.len(), m.spring_kind.len()];
    if slens.iter().any(|&l| l != ns) || m.spring_strain_limit.len() != ns {
        return Err(format!("spring arrays disagree in length: {ns} vs {slens:?}"));
    }
    if m.tri_body.len() != m.tri_count() {
        return Err("tri_body length".into());
    }
    let nb = m.body_count();
    for i in 0..n {
        let (mass, w) = (m.particle_mass[i], m.particle_inv_mass[i]);
        if mass.partial_cmp(&R::ZERO) != Some(std::cmp::Ordering::Greater) || !(w == R::ZERO || w == R::ONE / mass) {
            return Err(format!("particle {i}: mass {:?}, inverse mass {:?}", mass.to_f64(), w.to_f64()));
        }
    }
    // Directed edges of triangles.
    let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
    for (t, tri) in m.tri_indices.iter().enumerate() {
        if tri.iter().any(|&v| v as usize >= n) {
            return Err(format!("triangle {t} {tri:?}: index out of range"));
        }
        if tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] {
            return Err(format!("triangle {t} {tri:?}: repeated corner"));
        }
        let b = m.tri_body[t];
        if b as usize >= nb || tri.iter().any(|&v| m.particle_body[v as usize] != b) {
            return Err(format!("triangle {t} {tri:?}: corners not all in its body {b}"));
        }
        for k in 0..3 {
            let e = (tri[k], tri[(k + 1) % 3]);
            if let Some(other) = directed.insert(e, t as u32) {
                return Err(format!("edge {e:?} used in the same direction by triangles {other} and {t}"));
            }
        }
    }
    // Springs against edges.
    let mut pair_springs: HashMap<(u32, u32), u32> = HashMap::new();
    for (sp, &[i, j]) in m.spring_indices.iter().enumerate() {
        if m.spring_kind[sp] == SpringKind::Broken {
            continue;
        }
        if i as usize >= n || j as usize >= n || i == j {
            return Err(format!("spring {sp} [{i}, {j}]: bad ends"));
        }
        if m.particle_body[i as usize] != m.particle_body[j as usize] {
            return Err(format!("spring {sp} [{i}, {j}] joins two bodies"));
        }
        if m.spring_rest_length[sp].partial_cmp(&R::ZERO) != Some(std::cmp::Ordering::Greater) {
            return Err(format!("spring {sp}: rest length {:?}", m.spring_rest_length[sp].to_f64()));
        }
        let key = (i.min(j), i.max(j));
        *pair_springs.entry(key).or_insert(0) += 1;
        let has_tris = |v: u32| !m.particle_tris.row(v as usize).is_empty();
        let is_edge = directed.contains_key(&(i, j)) || directed.contains_key(&(j, i));
        if m.spring_kind[sp] == SpringKind::Edge && has_tris(i) && has_tris(j) && !is_edge {
            return Err(format!("edge spring {sp} [{i}, {j}] is on no triangle edge"));
        }
    }
    for &(a, b) in directed.keys() {
        let c = pair_springs.get(&(a.min(b), a.max(b))).copied().unwrap_or(0);
        if c != 1 {
            return Err(format!("triangle edge ({a}, {b}) carried by {c} live springs"));
        }
    }
    // Adjacency rows.
    let mut want_s: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (sp, &[i, j]) in m.spring_indices.iter().enumerate() {
        if m.spring_kind[sp] != SpringKind::Broken {
            want_s[i as usize].push((sp as u32) << 1);
            want_s[j as usize].push(((sp as u32) << 1) | 1);
        }
    }
    let mut want_t: Vec<Vec<u32>> = vec![Vec::new(); n];
    for (t, tri) in m.tri_indices.iter().enumerate() {
        for &v in tri {
            want_t[v as usize].push(t as u32);
        }
    }
    for i in 0..n {
        let mut got = m.particle_springs.row(i).to_vec();
        got.sort_unstable();
        if got != want_s[i] {
            return Err(format!("particle {i}: spring row {got:?}, springs say {:?}", want_s[i]));
        }
        let mut got = m.particle_tris.row(i).to_vec();
        got.sort_unstable();
        if got != want_t[i] {
            return Err(format!("particle {i}: triangle row {got:?}, triangles say {:?}", want_t[i]));
        }
    }
    // Rest edges of triangles.
    for (t, tri) in m.tri_indices.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            if let Some(sp) = spring_between(m, a, b)
                && m.spring_rest_length[sp as usize].partial_cmp(&R::ZERO) != Some(std::cmp::Ordering::Greater)
            {
                return Err(format!("triangle {t}: edge ({a}, {b}) has rest length 0"));
            }
        }
    }
    // Runs, when used, cover the springs in order.
    if !m.spring_runs.is_empty() {
        let mut next = 0u32;
        for r in &m.spring_runs {
            if r.first != next {
                return Err(format!("spring runs skip from {next} to {}", r.first));
            }
            for k in 0..r.len {
                if m.spring_indices[(r.first + k) as usize] != [r.i + k, r.j + k] {
                    return Err(format!("spring {} does not match its run", r.first + k));
                }
            }
            next += r.len;
        }
        if next as usize != ns {
            return Err(format!("spring runs cover {next} of {ns} springs"));
        }
    }
    for o in &m.openings {
        let k = o.vertices.len();
        for x in 0..k {
            let (a, b) = (o.vertices[x], o.vertices[(x + 1) % k]);
            if !directed.contains_key(&(a, b)) || directed.contains_key(&(b, a)) {
                return Err(format!("opening of body {}: ({a}, {b}) is not a boundary edge", o.body));
            }
        }
    }
    Ok(())
}
