//! Queries and edits of the live topology, as the fracture pass uses them: each edit changes the arrays of the
//! items it touches and their adjacency rows, and appends new items, so its cost follows the change.

use super::*;
use crate::real::{Real, Vector3};

pub(crate) fn tri_has<R: Real>(m: &Model<R>, t: u32, v: u32) -> bool {
    m.tri_indices[t as usize].contains(&v)
}

pub(crate) fn tri_area_now<R: Real>(m: &Model<R>, s: &State<R>, t: u32) -> f64 {
    let [a, b, c] = m.tri_indices[t as usize].map(|v| s.particle_q[v as usize].to_dvec3());
    0.5 * (b - a).cross(c - a).length()
}

/// The live spring between `i` and `j`, if any.
pub fn spring_between<R: Real>(m: &Model<R>, i: u32, j: u32) -> Option<u32> {
    m.particle_springs.row(i as usize).iter().map(|&e| e >> 1).find(|&sp| {
        let [a, b] = m.spring_indices[sp as usize];
        (a == i && b == j) || (a == j && b == i)
    })
}

pub(crate) fn rest_between<R: Real>(m: &Model<R>, s: &State<R>, i: u32, j: u32) -> f64 {
    match spring_between(m, i, j) {
        Some(sp) => m.spring_rest_length[sp as usize].to_f64(),
        None => (s.particle_q[j as usize] - s.particle_q[i as usize]).length().to_f64(),
    }
}

/// A fan of triangles around a vertex `v`: `(triangle, x, y)` for each triangle `(v, x, y)`.
pub type Fan = Vec<(u32, u32, u32)>;

/// The triangles around `v` grouped into fans, each as `(triangle, x, y)` with the triangle `(v, x, y)`,
/// ordered so that each one's `y` is the next one's `x`; with whether the fan closes on itself.
pub fn fans<R: Real>(m: &Model<R>, v: u32) -> Vec<(Fan, bool)> {
    let corners: Vec<(u32, u32, u32)> = m
        .particle_tris
        .row(v as usize)
        .iter()
        .map(|&t| {
            let tri = m.tri_indices[t as usize];
            let k = tri.iter().position(|&x| x == v).expect("row lists the triangle");
            (t, tri[(k + 1) % 3], tri[(k + 2) % 3])
        })
        .collect();
    let mut used = vec![false; corners.len()];
    let mut out = Vec::new();
    let next_of = |f: &(u32, u32, u32)| corners.iter().position(|g| g.1 == f.2);
    for start in 0..corners.len() {
        if used[start] {
            continue;
        }
        // Walk back to the start of an open fan (or once around a closed one).
        let mut first = start;
        let mut steps = 0;
        while let Some(p) = corners.iter().position(|g| g.2 == corners[first].1) {
            if p == start || used[p] || steps > corners.len() {
                break;
            }
            first = p;
            steps += 1;
        }
        let mut fan = Vec::new();
        let mut cur = first;
        let mut closed = false;
        loop {
            used[cur] = true;
            fan.push(corners[cur]);
            match next_of(&corners[cur]) {
                Some(nx) if nx == first => {
                    closed = true;
                    break;
                }
                Some(nx) if !used[nx] => cur = nx,
                _ => break,
            }
        }
        out.push((fan, closed));
    }
    out
}

/// The particle after `v` along the boundary (the edge `v -> w` of a triangle with no triangle on `w -> v`).
pub fn boundary_next<R: Real>(m: &Model<R>, v: u32) -> Option<u32> {
    let row = m.particle_tris.row(v as usize);
    let corner = |t: u32| {
        let tri = m.tri_indices[t as usize];
        let k = tri.iter().position(|&x| x == v).expect("row lists the triangle");
        (tri[(k + 1) % 3], tri[(k + 2) % 3])
    };
    row.iter().map(|&t| corner(t).0).find(|&x| !row.iter().any(|&t| corner(t).1 == x))
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn add_particle<R: Real>(
    m: &mut Model<R>,
    s: &mut State<R>,
    x: R::V,
    v: R::V,
    mass: R,
    inv_mass: R,
    body: u32,
    like: usize,
) -> u32 {
    let (load, origin, handle) = (m.particle_load_limit[like], m.particle_origin[like], m.particle_handle[like]);
    m.push_particle(ParticleRow { q0: x, qd0: v, mass, inv_mass, body, load_limit: load, origin, handle });
    m.particle_springs.push_row();
    m.particle_tris.push_row();
    s.particle_q.push(x);
    s.particle_qd.push(v);
    (m.particle_count() - 1) as u32
}

/// `m_i m_j / (m_i + m_j)` \[kg\].
pub(crate) fn reduced<R: Real>(a: R, b: R) -> R {
    a * b / (a + b)
}

/// Sets particle `i`'s mass, keeping the frequency and damping ratio of its springs: each one's `ks` and `kd`
/// scale with its reduced mass (see [`add_spring`]).
pub(crate) fn set_mass<R: Real>(m: &mut Model<R>, i: usize, mass: R) {
    let old = m.particle_mass[i];
    for k in 0..m.particle_springs.row(i).len() {
        let e = m.particle_springs.row(i)[k];
        let sp = (e >> 1) as usize;
        let w = m.spring_indices[sp][1 - (e & 1) as usize] as usize;
        let mw = m.particle_mass[w];
        let ratio = (reduced(mass, mw) / reduced(old, mw)).min(R::ONE);
        m.spring_stiffness[sp] *= ratio;
        m.spring_damping[sp] *= ratio;
    }
    m.particle_mass[i] = mass;
    if m.particle_inv_mass[i] != R::ZERO {
        m.particle_inv_mass[i] = R::ONE / mass;
    }
}

/// Adds a spring with the stiffness `ks` and damping `kd` of the spring it replaces, both scaled (down only) by
/// the ratio of its ends' reduced mass to `red`, the replaced spring's: every spring keeps its frequency
/// `sqrt(ks / m_red)` and damping ratio through a split. Splits share masses out, so without this a crack would
/// make ever lighter particles on equally stiff springs and raise the highest frequency of the model — and
/// with it the explicit integrators' stability limit `dt < 2 / ω` — at every split: a fracture storm would end
/// in a blow-up. The material around a crack is a little softer instead (a damaged zone), and a model stays
/// stable at the time step it started with.
pub(crate) fn add_spring<R: Real>(
    m: &mut Model<R>,
    i: u32,
    j: u32,
    rest: R,
    ks: R,
    (kd, red): (R, R),
    limit: R,
) -> u32 {
    let sp = m.spring_count() as u32;
    let red_new = reduced(m.particle_mass[i as usize], m.particle_mass[j as usize]);
    let ratio = (red_new / red).min(R::ONE);
    let (ks, kd) = (ks * ratio, kd * ratio);
    m.push_spring(SpringRow {
        indices: [i, j],
        rest_length: rest,
        stiffness: ks,
        damping: kd,
        kind: SpringKind::Edge,
        strain_limit: limit,
    });
    m.particle_springs.push(i as usize, sp << 1);
    m.particle_springs.push(j as usize, (sp << 1) | 1);
    // Spring runs are kept only while the model uses them (empty otherwise).
    if !m.spring_runs.is_empty() {
        match m.spring_runs.last_mut() {
            Some(r) if r.first + r.len == sp && r.i.wrapping_add(r.len) == i && r.j.wrapping_add(r.len) == j => {
                r.len += 1
            }
            _ => m.spring_runs.push(SpringRun { first: sp, i, j, len: 1 }),
        }
    }
    sp
}

/// Spring `sp` moved an end: its run (if runs are in use) splits around it. O(runs); the model falls back to
/// the gather kernel when runs get short.
pub(crate) fn split_run<R: Real>(m: &mut Model<R>, sp: u32) {
    if m.spring_runs.is_empty() {
        return;
    }
    let k = m.spring_runs.partition_point(|r| r.first + r.len <= sp);
    let r = m.spring_runs[k];
    let off = sp - r.first;
    let [i, j] = m.spring_indices[sp as usize];
    let mut parts = Vec::with_capacity(3);
    if off > 0 {
        parts.push(SpringRun { len: off, ..r });
    }
    parts.push(SpringRun { first: sp, i, j, len: 1 });
    if off + 1 < r.len {
        parts.push(SpringRun { first: sp + 1, i: r.i + off + 1, j: r.j + off + 1, len: r.len - off - 1 });
    }
    m.spring_runs.splice(k..k + 1, parts);
    if !m.springs_are_runs() {
        m.spring_runs.clear();
    }
}

pub(crate) fn break_spring<R: Real>(m: &mut Model<R>, sp: u32) {
    let s = sp as usize;
    if m.spring_kind[s] == SpringKind::Broken {
        return;
    }
    let [i, j] = m.spring_indices[s];
    m.particle_springs.remove(i as usize, sp << 1);
    m.particle_springs.remove(j as usize, (sp << 1) | 1);
    m.spring_kind[s] = SpringKind::Broken;
    m.spring_stiffness[s] = R::ZERO;
    m.spring_damping[s] = R::ZERO;
    m.spring_strain_limit[s] = R::infinity();
}

/// Moves end `end` (0 or 1) of spring `sp` to particle `to`: its index, both particles' rows, its run.
pub(crate) fn move_spring_end<R: Real>(m: &mut Model<R>, sp: u32, end: usize, to: u32) {
    let (s, e) = (sp as usize, (sp << 1) | end as u32);
    let from = std::mem::replace(&mut m.spring_indices[s][end], to);
    m.particle_springs.remove(from as usize, e);
    m.particle_springs.push(to as usize, e);
    split_run(m, sp);
}

pub(crate) fn set_tri<R: Real>(m: &mut Model<R>, t: u32, new: [u32; 3]) {
    let old = m.tri_indices[t as usize];
    for v in old {
        if !new.contains(&v) {
            m.particle_tris.remove(v as usize, t);
        }
    }
    for v in new {
        if !old.contains(&v) {
            m.particle_tris.push(v as usize, t);
        }
    }
    m.tri_indices[t as usize] = new;
}

pub(crate) fn add_tri<R: Real>(m: &mut Model<R>, tri: [u32; 3], body: u32) -> u32 {
    let t = m.tri_count() as u32;
    m.push_tri(TriRow { indices: tri, body });
    for v in tri {
        m.particle_tris.push(v as usize, t);
    }
    t
}

/// A new open body (no gas) with `parent`'s other parameters.
pub(crate) fn new_body<R: Real>(m: &mut Model<R>, parent: u32, anchor: u32) -> u32 {
    let p = parent as usize;
    m.push_body(BodyRow {
        kind: BodyKind::Cloth,
        gas_amount: R::ZERO,
        gas_inflow: R::ZERO,
        pressure_external: m.body_pressure_external[p],
        rest_volume: R::ZERO,
        drag: m.body_drag[p],
        lift: m.body_lift[p],
        anchor,
        sealed: m.body_sealed[p],
        contact_thickness: m.body_contact_thickness[p],
        self_contact: m.body_self_contact[p],
        contact_friction: m.body_contact_friction[p],
    });
    (m.body_count() - 1) as u32
}
