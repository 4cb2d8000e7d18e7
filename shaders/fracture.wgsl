// Fracture candidates: twin of the trigger scan in `fissure_core::fracture::trigger` (instant trigger). Each kernel appends
// the springs stretched past their strain limit, or the vertices loaded past their load limit, to `candidates`
// (a counter per kind, then the ids; the counter keeps counting past the capacity). The CPU reads the counters
// after a submission and, when either is non-zero, reads the state back and runs the fracture pass, which makes
// the decisions; nothing else is read back. Encoded only when the model has something breakable.

fn append(kind: u32, id: u32) {
    let cap = params.misc.x;
    let k = atomicAdd(&candidates[kind], 1u);
    if (k < cap) {
        atomicStore(&candidates[4u + kind * cap + k], id);
    }
}

@compute @workgroup_size(64)
fn strain_check(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let s = flat_index(gid, nwg);
    if (s >= spring_count()) { return; }
    let sp = springs[s];
    if (sp.strain_limit < 0.0) { return; }
    let ends = spring_ends[s];
    let strain = (length(q_src(ends.y) - q_src(ends.x)) - sp.rest) / sp.rest;
    if (strain > sp.strain_limit) {
        append(0u, s);
    }
}

// The load: |net elastic force| on the particle (its springs' `ks (l - L0) d̂` and its share of the gas pressure).
// With gas, the `surface_pressure` pass has just run on the same state: `tri_f` holds each triangle's pressure
// share per corner (0 on bodies without gas).
@compute @workgroup_size(64)
fn load_check(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = flat_index(gid, nwg);
    if (i >= particle_count()) { return; }
    let p = particles[i];
    if (p.load_limit < 0.0 || p.inv_mass == 0.0) { return; }
    let row = p.row;
    var f = vec3<f32>(0.0);
    for (var k = 0u; k < row.y; k++) {
        let e = adj[row.x + k];
        let s = springs[e >> 1u];
        let ends = spring_ends[e >> 1u];
        let sf = spring_elastic_force(s, q_src(ends.y) - q_src(ends.x));
        f += select(-sf, sf, (e & 1u) == 0u);
    }
    if (params.counts2.y != 0u) {
        for (var k = 0u; k < row.w; k++) {
            f += tri_f[adj[row.z + k]].xyz;
        }
    }
    if (length(f) > p.load_limit) {
        append(1u, i);
    }
}
