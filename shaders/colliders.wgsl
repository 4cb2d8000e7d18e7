// The colliders, twin of `fissure_core::collision::PreparedCollider::resolve`: analytic half-spaces, balls,
// cuboids and capsules; triangle meshes through a signed-distance grid baked on the CPU with parry3d (trilinear,
// normal from its gradient). Shared by the collision kernel (`collide.wgsl`) and the contact pass (`contact.wgsl`,
// which resolves the particles it moved again); prepended to every kernel file after `common.wgsl` (see
// `fissure_gpu::shader_source`).

fn quat_rotate(q: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    let t = 2.0 * cross(q.xyz, v);
    return v + q.w * t + cross(q.xyz, t);
}

fn quat_mul(a: vec4<f32>, b: vec4<f32>) -> vec4<f32> {
    return vec4<f32>(
        a.w * b.xyz + b.w * a.xyz + cross(a.xyz, b.xyz),
        a.w * b.w - dot(a.xyz, b.xyz),
    );
}

struct Pose {
    t: vec3<f32>,
    r: vec4<f32>,
}

fn pose_at(c: Collider, time: f32) -> Pose {
    var p: Pose;
    p.t = c.translation.xyz + c.linear_velocity.xyz * time;
    p.r = c.rotation;
    let angle = c.angular_velocity.xyz * time;
    let len = length(angle);
    if (len > 0.0) {
        let rot = vec4<f32>(angle / len * sin(0.5 * len), cos(0.5 * len));
        p.r = normalize(quat_mul(rot, c.rotation));
    }
    return p;
}

struct Closest {
    point: vec3<f32>,
    inside: bool,
    normal: vec3<f32>,
    valid: bool,
}

fn sdf_at(c: Collider, ijk: vec3<u32>) -> f32 {
    let d = vec3<u32>(c.b.xyz);
    return sdf[c.head.y + ijk.x + d.x * (ijk.y + d.y * ijk.z)];
}

// Trilinear sample of the grid at local point `p` (inside the grid).
fn sdf_sample(c: Collider, p: vec3<f32>) -> f32 {
    let dims = c.b.xyz;
    let u = clamp((p - c.a.xyz) / c.a.w, vec3<f32>(0.0), dims - vec3<f32>(1.0));
    let i0 = min(vec3<u32>(floor(u)), vec3<u32>(dims) - vec3<u32>(2u));
    let f = u - vec3<f32>(i0);
    let c00 = mix(sdf_at(c, i0), sdf_at(c, i0 + vec3<u32>(1u, 0u, 0u)), f.x);
    let c10 = mix(sdf_at(c, i0 + vec3<u32>(0u, 1u, 0u)), sdf_at(c, i0 + vec3<u32>(1u, 1u, 0u)), f.x);
    let c01 = mix(sdf_at(c, i0 + vec3<u32>(0u, 0u, 1u)), sdf_at(c, i0 + vec3<u32>(1u, 0u, 1u)), f.x);
    let c11 = mix(sdf_at(c, i0 + vec3<u32>(0u, 1u, 1u)), sdf_at(c, i0 + vec3<u32>(1u, 1u, 1u)), f.x);
    return mix(mix(c00, c10, f.y), mix(c01, c11, f.y), f.z);
}

const SDF_ITERATIONS: u32 = 4u;

// Gradient of the grid at `p` by central differences over half a cell.
fn sdf_gradient(c: Collider, p: vec3<f32>) -> vec3<f32> {
    let e = 0.5 * c.a.w;
    return vec3<f32>(
        sdf_sample(c, p + vec3<f32>(e, 0.0, 0.0)) - sdf_sample(c, p - vec3<f32>(e, 0.0, 0.0)),
        sdf_sample(c, p + vec3<f32>(0.0, e, 0.0)) - sdf_sample(c, p - vec3<f32>(0.0, e, 0.0)),
        sdf_sample(c, p + vec3<f32>(0.0, 0.0, e)) - sdf_sample(c, p - vec3<f32>(0.0, 0.0, e)),
    );
}

fn closest(c: Collider, p: vec3<f32>) -> Closest {
    var r: Closest;
    r.valid = true;
    let kind = c.head.x;
    if (kind == 0u) {
        let n = c.a.xyz;
        let s = dot(n, p);
        r.point = p - n * s;
        r.inside = s < 0.0;
        r.normal = n;
    } else if (kind == 1u) {
        let l = length(p);
        let n = select(vec3<f32>(0.0, 1.0, 0.0), p / l, l > 0.0);
        r.point = n * c.a.x;
        r.inside = l < c.a.x;
        r.normal = n;
    } else if (kind == 2u) {
        let h = c.a.xyz;
        let a = abs(p);
        if (all(a <= h)) {
            // Inside: leave through the nearest face.
            let gap = h - a;
            var axis = 2u;
            if (gap.x <= gap.y && gap.x <= gap.z) {
                axis = 0u;
            } else if (gap.y <= gap.z) {
                axis = 1u;
            }
            var n = vec3<f32>(0.0);
            n[axis] = select(-1.0, 1.0, p[axis] >= 0.0);
            var q = p;
            q[axis] = n[axis] * h[axis];
            r.point = q;
            r.inside = true;
            r.normal = n;
        } else {
            let q = clamp(p, -h, h);
            let d = p - q;
            r.point = q;
            r.inside = false;
            r.normal = d / length(d);
        }
    } else if (kind == 3u) {
        let a = c.a.xyz;
        let ab = c.b.xyz - a;
        let len2 = dot(ab, ab);
        let t = select(0.0, clamp(dot(p - a, ab) / len2, 0.0, 1.0), len2 > 0.0);
        let q = a + ab * t;
        let d = p - q;
        let l = length(d);
        var n = vec3<f32>(0.0, 1.0, 0.0);
        if (l > 0.0) {
            n = d / l;
        }
        r.point = q + n * c.a.w;
        r.inside = l < c.a.w;
        r.normal = n;
    } else {
        // Signed-distance grid: no contact outside it.
        let lo = c.a.xyz;
        let hi = lo + (c.b.xyz - vec3<f32>(1.0)) * c.a.w;
        if (any(p < lo) || any(p > hi)) {
            r.valid = false;
            return r;
        }
        r.inside = sdf_sample(c, p) < 0.0;
        // Newton steps onto the zero level (twin of `SdfGrid::closest`).
        var q = p;
        var n = vec3<f32>(0.0);
        for (var it = 0u; it < SDF_ITERATIONS; it++) {
            let d = sdf_sample(c, q);
            let g = sdf_gradient(c, q);
            let gl = length(g);
            if (gl <= 0.0) {
                r.valid = false;
                return r;
            }
            n = g / gl;
            q = q - n * d;
            if (abs(d) <= 1e-4 * c.a.w) {
                break;
            }
        }
        r.point = q;
        r.normal = n;
    }
    return r;
}

struct Contact {
    x: vec3<f32>,
    v: vec3<f32>,
    hit: bool,
}

fn resolve(c: Collider, pose: Pose, x: vec3<f32>, v: vec3<f32>) -> Contact {
    var out: Contact;
    out.hit = false;
    let inv = vec4<f32>(-pose.r.xyz, pose.r.w);
    let local = quat_rotate(inv, x - pose.t);
    let cl = closest(c, local);
    let margin = c.material.w;
    let dl = local - cl.point;
    if (!cl.valid || (!cl.inside && dot(dl, dl) >= margin * margin)) {
        return out;
    }
    out.hit = true;
    let n = quat_rotate(pose.r, cl.normal);
    let x_new = quat_rotate(pose.r, cl.point + cl.normal * margin) + pose.t;
    let v_col = c.linear_velocity.xyz + cross(c.angular_velocity.xyz, x_new - pose.t);
    let v_rel = v - v_col;
    let vn = dot(v_rel, n);
    out.x = x_new;
    if (vn >= 0.0) {
        out.v = v;
        return out;
    }
    let vn_new = select(0.0, -c.material.x * vn, -vn > c.material.y);
    let vt = v_rel - n * vn;
    let vt_len = length(vt);
    let scale = select(0.0, max(1.0 - c.material.z * (vn_new - vn) / vt_len, 0.0), vt_len > 0.0);
    out.v = v_col + vt * scale + n * vn_new;
    return out;
}

// A particle at (x, v) against every collider, sweeping until clear (a push out of one collider can land in
// another: a corner), at most 3 times; `hit` if any touched it. Twin of the CPU's `collide::sweeps`; the contact
// pass (`contact_apply`) calls it again for the particles it moved.
fn resolve_all(x0: vec3<f32>, v0: vec3<f32>) -> Contact {
    var out: Contact;
    out.x = x0;
    out.v = v0;
    out.hit = false;
    let nc = params.counts2.x;
    for (var sweep = 0u; sweep < 3u; sweep++) {
        var any_hit = false;
        for (var k = 0u; k < nc; k++) {
            let c = colliders[k];
            let r = resolve(c, pose_at(c, clock.time), out.x, out.v);
            if (r.hit) {
                out.x = r.x;
                out.v = r.v;
                any_hit = true;
            }
        }
        out.hit = out.hit || any_hit;
        if (!any_hit || nc == 1u) {
            break;
        }
    }
    return out;
}
