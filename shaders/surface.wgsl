// The surface pass: triangle crosses, gas-body volumes (a two-pass workgroup reduction), pressures, and the
// per-corner force of each triangle (the seed's eq. (9) pressure force plus wind drag and lift).
// Twin of `ForceScratch::surface` in `fissure_core::forces` (the formulas: `forces::pressure::{gas_pressure,
// corner_force}`, `forces::wind::aero_components`). Encoded only when the model has gas or wind.

const TAU: f32 = 6.283185307179586;

var<workgroup> red: array<f32, 64>;
var<workgroup> slot_lo: atomic<u32>;
var<workgroup> slot_hi: atomic<u32>;
var<workgroup> range: array<u32, 2>;

fn tree_sum(li: u32) {
    for (var s = WG / 2u; s > 0u; s = s >> 1u) {
        if (li < s) {
            red[li] = red[li] + red[li + s];
        }
        workgroupBarrier();
    }
}

// Pass 1 (one invocation per triangle): the cross vector and, for gas bodies, `(x0 - anchor)·cross`; then each
// workgroup sums those per gas body into its row of `partials` (only the gas slots its triangles touch; the
// rest of the row gets 0). Bodies' triangles are mostly contiguous, so that is one or two slots per workgroup.
@compute @workgroup_size(64)
fn surface_cross(
    @builtin(global_invocation_id) gid: vec3<u32>,
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let t = flat_index(gid, nwg);
    let row = wid.x + wid.y * nwg.x;
    let n_gas = params.counts2.y;
    if (li == 0u) {
        atomicStore(&slot_lo, NONE);
        atomicStore(&slot_hi, 0u);
    }
    workgroupBarrier();
    var slot = NONE;
    var w = 0.0;
    if (t < tri_count()) {
        let tri = tris[t];
        let x0 = q_src(tri.x);
        let c = cross(q_src(tri.y) - x0, q_src(tri.z) - x0);
        let body = bodies[tri.w];
        slot = body.gas_slot;
        if (slot != NONE) {
            w = dot(x0 - q_src(body.anchor), c);
            atomicMin(&slot_lo, slot);
            atomicMax(&slot_hi, slot);
        }
        tri_cross[t] = vec4<f32>(c, w);
    }
    if (n_gas == 0u) {
        return;
    }
    workgroupBarrier();
    if (li == 0u) {
        range[0] = atomicLoad(&slot_lo);
        range[1] = atomicLoad(&slot_hi);
    }
    let r = workgroupUniformLoad(&range);
    // Slots this workgroup has no triangle of: 0.
    for (var g = li; g < n_gas; g += WG) {
        if (r[0] == NONE || g < r[0] || g > r[1]) {
            partials[row * n_gas + g] = 0.0;
        }
    }
    if (r[0] == NONE) {
        return;
    }
    for (var g = r[0]; g <= r[1]; g++) {
        red[li] = select(0.0, w, slot == g);
        workgroupBarrier();
        tree_sum(li);
        if (li == 0u) {
            partials[row * n_gas + g] = red[0];
        }
        workgroupBarrier();
    }
}

// Caps over the openings of gas bodies: centre, `6 V` of the cap fan about the body's anchor, and the sum of its
// edges' gradients (the centre's share). One workgroup per opening, its loop shared among the invocations and
// summed in a fixed tree (so a run is deterministic): a torn ball's openings run to hundreds of vertices, and one
// invocation walking each loop alone took 177 µs a step of the fracture scene on an H200 (`fissure run
// scenes/fracture.toml --backend gpu --kernel-timers`).
var<workgroup> red4: array<vec4<f32>, 64>;

fn tree_sum4(li: u32) {
    for (var s = WG / 2u; s > 0u; s = s >> 1u) {
        if (li < s) {
            red4[li] = red4[li] + red4[li + s];
        }
        workgroupBarrier();
    }
}

@compute @workgroup_size(64)
fn surface_caps(
    @builtin(local_invocation_index) li: u32,
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
) {
    let o = wid.x + wid.y * nwg.x;
    if (o >= params.counts2.z) { return; }
    let h = params.counts2.y + 4u * o;
    let body = openings[h];
    let first = openings[h + 1u];
    let n = openings[h + 2u];
    let anchor = q_src(bodies[body].anchor);
    var sum = vec3<f32>(0.0);
    for (var k = li; k < n; k += WG) {
        sum += q_src(openings[first + k]);
    }
    red4[li] = vec4<f32>(sum, 0.0);
    workgroupBarrier();
    tree_sum4(li);
    let c = red4[0].xyz * (1.0 / f32(n));
    workgroupBarrier();
    var vol6 = 0.0;
    var cg = vec3<f32>(0.0);
    for (var k = li; k < n; k += WG) {
        let xi = q_src(openings[first + k]);
        let xj = q_src(openings[first + (k + 1u) % n]);
        vol6 += dot(xj - anchor, cross(xi - anchor, c - anchor));
        cg += cross(xi - xj, c - xj) * (1.0 / 6.0);
    }
    red4[li] = vec4<f32>(cg, vol6);
    workgroupBarrier();
    tree_sum4(li);
    if (li == 0u) {
        cap_data[2u * o] = vec4<f32>(c, red4[0].w);
        cap_data[2u * o + 1u] = vec4<f32>(red4[0].xyz, f32(n));
    }
}

// Pass 2 (one workgroup per gas body): sum the rows, add the caps, then V and P = nRT / max(V, 1e-3 V0) - P_ext.
@compute @workgroup_size(64)
fn surface_volume(@builtin(local_invocation_index) li: u32, @builtin(workgroup_id) wid: vec3<u32>) {
    let g = wid.x;
    let n_gas = params.counts2.y;
    let rows_n = params.counts2.w;
    var acc = 0.0;
    for (var r = li; r < rows_n; r += WG) {
        acc += partials[r * n_gas + g];
    }
    red[li] = acc;
    workgroupBarrier();
    tree_sum(li);
    if (li == 0u) {
        let b = openings[g];
        var vol6 = red[0];
        for (var o = 0u; o < params.counts2.z; o++) {
            if (openings[n_gas + 4u * o] == b) {
                vol6 += cap_data[2u * o].w;
            }
        }
        let v = vol6 * (1.0 / 6.0);
        let body = bodies[b];
        let p = gas_pressure(body.gas, v, body.rest_volume, body.p_ext);
        body_state[b] = vec4<f32>(v, p, 0.0, 0.0);
    }
}

// Wind velocity at `x` and time `t`: twin of `WindField::sample`.
fn wind_sample(x: vec3<f32>, t: f32) -> vec3<f32> {
    let u = params.wind_u.xyz;
    let speed = length(u);
    if (speed == 0.0) {
        return vec3<f32>(0.0);
    }
    let dir = u / speed;
    let along = dot(x, dir) / max(params.wind_p.z, 1e-9);
    let f = params.wind_p.y;
    let phase = TAU * (f * t - along);
    let phase2 = TAU * (0.37 * f * t - 0.61 * along);
    var side = cross(dir, vec3<f32>(0.0, 1.0, 0.0));
    if (dot(side, side) < 1e-12) {
        side = vec3<f32>(1.0, 0.0, 0.0);
    }
    side = normalize(side);
    return u * (1.0 + params.wind_p.x * sin(phase)) + side * (params.wind_p.w * speed * sin(phase2));
}

// Drag and lift on a triangle with cross vector `c` in relative air velocity `v`: twin of `aero_components`.
fn aero_force(c: vec3<f32>, v: vec3<f32>, cd: f32, cl: f32, rho_half: f32) -> vec3<f32> {
    // The drag ½ρ C_D A |n·v| v and lift ½ρ C_L A (n·v)(n|v| - (n·v̂) v) through s = c·v = 2A (n̂·v) (see
    // `aero_components` in `forces/wind.rs`).
    let vv = dot(v, v);
    let s = dot(c, v);
    let root = sqrt(dot(c, c) * vv);
    if (root <= 0.0) {
        return vec3<f32>(0.0);
    }
    let quarter = rho_half * 0.5;
    return v * (quarter * cd * abs(s)) + (c * vv - v * s) * (quarter * cl * s / root);
}

// Pass 3 (one invocation per triangle): the force on each of its corners.
@compute @workgroup_size(64)
fn surface_force(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = flat_index(gid, nwg);
    if (t >= tri_count()) { return; }
    let tri = tris[t];
    let body = bodies[tri.w];
    let c = tri_cross[t].xyz;
    let p = select(0.0, body_state[tri.w].y, body.gas_slot != NONE);
    var f = pressure_corner_force(c, p);
    let rho = params.wind_u.w;
    if (rho > 0.0 && (body.drag != 0.0 || body.lift != 0.0)) {
        let third = 1.0 / 3.0;
        // The mean of the corners' relative air `w(x) - v` (the CPU samples each particle once: `relative_air`).
        let ra = wind_sample(q_src(tri.x), clock.time) - qd_src(tri.x);
        let rb = wind_sample(q_src(tri.y), clock.time) - qd_src(tri.y);
        let rc = wind_sample(q_src(tri.z), clock.time) - qd_src(tri.z);
        f += aero_force(c, (ra + rb + rc) * third, body.drag, body.lift, 0.5 * rho) * third;
    }
    tri_f[t] = vec4<f32>(f, 0.0);
}

// The pressure share alone (no wind), for the fracture load check after a step.
@compute @workgroup_size(64)
fn surface_pressure(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = flat_index(gid, nwg);
    if (t >= tri_count()) { return; }
    let b = tris[t].w;
    let p = select(0.0, body_state[b].y, bodies[b].gas_slot != NONE);
    tri_f[t] = vec4<f32>(pressure_corner_force(tri_cross[t].xyz, p), 0.0);
}

// Gradient share of a cap edge `i -> j` about the cap's centre `c` (each end gets it).
fn cap_edge(xi: vec3<f32>, xj: vec3<f32>, c: vec3<f32>) -> vec3<f32> {
    return cross(xi - xj, c - xj) * (1.0 / 6.0);
}

// Pass 4 (one invocation per particle; a gas body with openings only): the pressure's force through the caps
// over the openings the particle borders, into `cap_f` (the integrators add it after the triangles' forces).
@compute @workgroup_size(64)
fn cap_force(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = flat_index(gid, nwg);
    if (i >= particle_count()) { return; }
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
        let xi = q_src(i);
        let g = cap_edge(q_src(prev), xi, c) + cap_edge(xi, q_src(next), c) + cg * (1.0 / f32(n));
        f += g * body_state[body].y;
    }
    cap_f[i] = vec4<f32>(f, 0.0);
}
