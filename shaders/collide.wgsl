// Collisions: every particle against the colliders (`colliders.wgsl`), run on the destination state after the
// integrator (in place: each particle is independent). Encoded only when the model has colliders. The clock entry
// bound here is the time after the step.

@compute @workgroup_size(64)
fn collide(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = flat_index(gid, nwg);
    if (i >= particle_count() || particles[i].inv_mass == 0.0) { return; }
    let r = resolve_all(q_dst(i), qd_dst(i));
    if (r.hit) {
        store(i, r.x, r.v);
    }
}
