// Per-particle force gather and the integrators. Twin of `fissure_core::forces::particle_force` and the CPU
// solver's update loops: gravity, then the particle's springs in CSR order (each spring computed by both its ends;
// WGSL has no float atomics and recomputing is cheaper than a second pass), then its triangles' corner forces
// (pressure + wind, when the model has either), then the pressure through the caps over openings (`cap_f`, from
// the `cap_force` pass in surface.wgsl). The spring force itself is `spring_force` in common.wgsl (twin of
// `fissure_core::forces::spring::force_components`).

// Net force on particle `i` at the source state [N].
fn particle_force(i: u32) -> vec3<f32> {
    let p = particles[i];
    var f = params.gravity.xyz * p.mass;
    let row = p.row;
    let xi = q_src(i);
    let vi = qd_src(i);
    for (var k = 0u; k < row.y; k++) {
        let e = adj[row.x + k];
        let s = springs[e >> 1u];
        let ends = spring_ends[e >> 1u];
        if ((e & 1u) == 0u) {
            f += spring_force(s, q_src(ends.y) - xi, qd_src(ends.y) - vi);
        } else {
            f -= spring_force(s, xi - q_src(ends.x), vi - qd_src(ends.x));
        }
    }
    // misc.y: triangle forces present (pressure or wind); misc.z: caps over openings present.
    if (params.misc.y != 0u) {
        for (var k = 0u; k < row.w; k++) {
            f += tri_f[adj[row.z + k]].xyz;
        }
        if (params.misc.z != 0u) {
            f += cap_f[i].xyz;
        }
    }
    return f;
}

// The first (or only) half of a step, from the source state into the destination; pinned particles are copied,
// or moved by their handle.
// Drift with the velocity kicked by `h` (`x += dt (v + h a)`), store the velocity kicked by the whole step
// (`v + dt a`). Symplectic Euler is `h = dt` (the two agree: the seed's eqs. 3-5). Velocity Verlet is `h = dt/2`:
// the stored velocity is then not the half-step one but its extrapolation to the step's end, where the second kick
// evaluates the velocity-dependent forces (damping, drag), which keeps the scheme second order with damping (at
// v_{n+1/2} it would be first order); it recovers v_{n+1/2} as the mean of it and v_n, which the other state buffer
// still holds.
fn kick_drift(i: u32, h: f32) {
    let w = particles[i].inv_mass;
    if (w == 0.0) {
        let pin = particles[i].handle;
        if (pin != 0u) {
            // A moving pin: moved by its handle's displacement over the step, at that velocity.
            let d = clock.handles[pin - 1u].xyz;
            store(i, q_src(i) + d, d / clock.dt);
            return;
        }
        store(i, q_src(i), qd_src(i));
        return;
    }
    let a = particle_force(i) * w;
    let v = qd_src(i) + a * clock.dt;
    let x = q_src(i) + (qd_src(i) + a * h) * clock.dt;
    store(i, x, v);
}

// Symplectic Euler, the seed's eqs. (3)-(5): v += dt a(x, v); x += dt v.
@compute @workgroup_size(64)
fn integrate_symplectic_euler(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = flat_index(gid, nwg);
    if (i >= particle_count()) { return; }
    kick_drift(i, clock.dt);
}

// Velocity Verlet, first half: kick half a step, drift a whole step, store the extrapolated velocity (see
// `kick_drift`).
@compute @workgroup_size(64)
fn integrate_verlet_first(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = flat_index(gid, nwg);
    if (i >= particle_count()) { return; }
    kick_drift(i, 0.5 * clock.dt);
}

// Velocity Verlet, second half: kick v_{n+1/2} = (v_pred + v_n) / 2 with the forces at the new positions and the
// extrapolated velocities. Bound with the buffers swapped, so `qd_dst` still holds v_n (read before it is
// overwritten, by the same invocation).
@compute @workgroup_size(64)
fn integrate_verlet_second(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = flat_index(gid, nwg);
    if (i >= particle_count()) { return; }
    let w = particles[i].inv_mass;
    if (w == 0.0) {
        store(i, q_src(i), qd_src(i));
        return;
    }
    let vh = 0.5 * (qd_src(i) + qd_dst(i));
    let v = vh + particle_force(i) * (w * (clock.dt * 0.5));
    store(i, q_src(i), v);
}

// The net force on every particle into the destination's position slots (for tests and tools; the source state
// is not changed).
@compute @workgroup_size(64)
fn net_forces(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = flat_index(gid, nwg);
    if (i >= particle_count()) { return; }
    state_dst[2u * i] = vec4<f32>(particle_force(i), 0.0);
}

fn not_finite(v: vec3<f32>) -> bool {
    let b = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return any(b == vec3<u32>(0x7f800000u));
}

// Flags a non-finite position or velocity of the source state (once per submission, on its final state: a
// non-finite value stays non-finite through the integrators, which add to it, and the colliders, whose tests it
// fails, so the last state shows any blow-up of the substeps before it).
@compute @workgroup_size(64)
fn finite_check(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = flat_index(gid, nwg);
    if (i >= particle_count()) { return; }
    if (not_finite(q_src(i)) || not_finite(qd_src(i))) {
        atomicStore(&candidates[2], 1u);
    }
}
