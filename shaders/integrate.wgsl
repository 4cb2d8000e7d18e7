// Per-particle force gather and the integrators. Twin of `fissure_core::forces::particle_force` and the CPU
// solver's update loops: gravity, then the particle's springs in CSR order (each spring computed by both its ends;
// WGSL has no float atomics and recomputing is cheaper than a second pass), then its triangles' corner forces
// (pressure + wind, when the model has either), then the pressure through the caps over openings. The spring
// force itself is `spring_force` in common.wgsl (twin of `fissure_core::forces::spring::force_components`).

// Gradient share of a cap edge `i -> j` about the cap's centre `c` (each end gets it).
fn cap_edge(xi: vec3<f32>, xj: vec3<f32>, c: vec3<f32>) -> vec3<f32> {
    return cross(xi - xj, c - xj) * (1.0 / 6.0);
}

fn cap_force(i: u32) -> vec3<f32> {
    var f = vec3<f32>(0.0);
    let start = caps[2u * i];
    let len = caps[2u * i + 1u];
    let base = 2u * particle_count();
    let n_gas = params.counts2.y;
    for (var k = 0u; k < len; k++) {
        let item = vec2<u32>(caps[base + 2u * (start + k)], caps[base + 2u * (start + k) + 1u]);
        let o = item.x;
        let h = n_gas + 4u * o;
        let body = openings[h];
        let first = openings[h + 1u];
        let n = openings[h + 2u];
        let at = item.y;
        let prev = openings[first + (at + n - 1u) % n];
        let next = openings[first + (at + 1u) % n];
        let c = cap_data[2u * o].xyz;
        let cg = cap_data[2u * o + 1u].xyz;
        let xi = q_src[i].xyz;
        let g = cap_edge(q_src[prev].xyz, xi, c) + cap_edge(xi, q_src[next].xyz, c) + cg * (1.0 / f32(n));
        f += g * body_state[body].y;
    }
    return f;
}

// Net force on particle `i` at the source state [N].
fn particle_force(i: u32) -> vec3<f32> {
    let p = particles[i];
    var f = params.gravity.xyz * p.mass;
    let row = rows[i];
    let xi = q_src[i].xyz;
    let vi = qd_src[i].xyz;
    for (var k = 0u; k < row.y; k++) {
        let e = adj[row.x + k];
        let s = springs[e >> 1u];
        let ends = spring_ends[e >> 1u];
        if ((e & 1u) == 0u) {
            f += spring_force(s, q_src[ends.y].xyz - xi, qd_src[ends.y].xyz - vi);
        } else {
            f -= spring_force(s, xi - q_src[ends.x].xyz, vi - qd_src[ends.x].xyz);
        }
    }
    // misc.y: triangle forces present (pressure or wind); misc.z: caps over openings present.
    if (params.misc.y != 0u) {
        for (var k = 0u; k < row.w; k++) {
            f += tri_f[adj[row.z + k]].xyz;
        }
        if (params.misc.z != 0u) {
            f += cap_force(i);
        }
    }
    return f;
}

fn not_finite(v: vec3<f32>) -> bool {
    let b = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return any(b == vec3<u32>(0x7f800000u));
}

fn flag_blown(x: vec3<f32>, v: vec3<f32>) {
    if (not_finite(x) || not_finite(v)) {
        atomicStore(&candidates[2], 1u);
    }
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
            q_dst[i] = vec4<f32>(q_src[i].xyz + d, 0.0);
            qd_dst[i] = vec4<f32>(d / clock.dt, 0.0);
            return;
        }
        q_dst[i] = q_src[i];
        qd_dst[i] = qd_src[i];
        return;
    }
    let a = particle_force(i) * w;
    let v = qd_src[i].xyz + a * clock.dt;
    let x = q_src[i].xyz + (qd_src[i].xyz + a * h) * clock.dt;
    qd_dst[i] = vec4<f32>(v, 0.0);
    q_dst[i] = vec4<f32>(x, 0.0);
    flag_blown(x, v);
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
    q_dst[i] = q_src[i];
    let w = particles[i].inv_mass;
    if (w == 0.0) {
        qd_dst[i] = qd_src[i];
        return;
    }
    let vh = 0.5 * (qd_src[i].xyz + qd_dst[i].xyz);
    let v = vh + particle_force(i) * (w * (clock.dt * 0.5));
    qd_dst[i] = vec4<f32>(v, 0.0);
    flag_blown(q_src[i].xyz, v);
}

// The net force on every particle into `q_dst` (for tests and tools; no state is changed).
@compute @workgroup_size(64)
fn net_forces(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = flat_index(gid, nwg);
    if (i >= particle_count()) { return; }
    q_dst[i] = vec4<f32>(particle_force(i), 0.0);
}
