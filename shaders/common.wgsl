// fissure: shared declarations of every kernel. The Rust side prepends this file to each kernel file (group 0: the
// model and state, group 1: the clock of the current substep).
// Mirrors: `crates/fissure-gpu/src/layout.rs` (same field order, `bytemuck::Pod`).
//
// Vectors are `vec4<f32>` (a `vec3` is 16-byte aligned in storage, so the fourth lane is free and used where noted).
// WGSL has no float atomics: every force is gathered per particle over CSR lists, one summation order, no races.

const WG: u32 = 64u;
const NONE: u32 = 0xffffffffu;

struct Params {
    // xyz: gravity [m/s^2]; w: 1 for projected damping (default), 0 for the seed's unprojected form.
    gravity: vec4<f32>,
    // particles, springs, triangles, bodies
    counts: vec4<u32>,
    // colliders, gas bodies, openings, volume partial rows (workgroups of the triangle pass)
    counts2: vec4<u32>,
    // xyz: mean wind U [m/s]; w: air density [kg/m^3]
    wind_u: vec4<f32>,
    // gust amplitude, gust frequency [Hz], gust wavelength [m], crosswind fraction
    wind_p: vec4<f32>,
    // candidate capacity (per kind), 0, 0, 0
    misc: vec4<u32>,
    // contact (contact.wgsl): largest thickness h_max [m], grid cell [m], fixed-point units per m/s, 0
    contact_f: vec4<f32>,
    // contact: edges, buckets per grid - 1 (a power of two less one), pair capacity, 0
    contact_n: vec4<u32>,
}

// One per substep, selected by a dynamic offset: nothing is written between substeps of a submission.
struct Clock {
    time: f32,
    dt: f32,
    _pad0: f32,
    _pad1: f32,
    // Each moving pin's displacement over this step [m] (`Clock::handles` in layout.rs).
    handles: array<vec4<f32>, 15>,
}

struct Particle {
    mass: f32,
    inv_mass: f32,
    // The moving pin holding the particle, plus one (0: none).
    handle: u32,
    // Core-mode load limit [N]; negative: unbreakable.
    load_limit: f32,
    // Spring row start, spring row length, triangle row start, triangle row length (offsets into `adj`).
    row: vec4<u32>,
}

// A spring's parameters; its ends are in `spring_ends` (split so the largest array stays under the 128 MiB a
// storage binding may hold on many devices: a 1024² cloth has 6.3 million springs).
struct Spring {
    rest: f32,
    ks: f32,
    kd: f32,
    // Strain limit; negative: unbreakable (or broken).
    strain_limit: f32,
}

struct Body {
    // nRT [J]; 0: no gas
    gas: f32,
    p_ext: f32,
    rest_volume: f32,
    drag: f32,
    lift: f32,
    anchor: u32,
    // index among the gas bodies, or NONE
    gas_slot: u32,
    _pad0: u32,
}

struct Collider {
    // kind (0 half-space, 1 ball, 2 cuboid, 3 capsule, 4 signed-distance grid), grid offset into `sdf`, 0, 0
    head: vec4<u32>,
    // restitution, restitution threshold [m/s], friction, margin [m]
    material: vec4<f32>,
    translation: vec4<f32>,
    // unit quaternion (x, y, z, w)
    rotation: vec4<f32>,
    linear_velocity: vec4<f32>,
    angular_velocity: vec4<f32>,
    // half-space: normal; ball: radius in x; cuboid: half extents; capsule: a, radius in w; grid: origin, cell in w
    a: vec4<f32>,
    // capsule: b; grid: dims (as f32, exact integers)
    b: vec4<f32>,
    // world-space bounding box of the collider at time 0 grown by the sweep: min (xyz)
    _reserved: vec4<f32>,
}

// Group 0 holds every binding below, but each kernel's layout lists only those it uses (at most 8 storage
// buffers, WebGPU's default per stage); `fissure_gpu::KERNEL_BINDINGS` is that table, checked against naga.
@group(0) @binding(0) var<uniform> params: Params;
// The state, interleaved per particle: position at 2i, velocity at 2i + 1 (w unused). Read through `q_src`,
// `qd_src`, `q_dst`, `qd_dst`; written through `store`.
@group(0) @binding(1) var<storage, read> state_src: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> state_dst: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> particles: array<Particle>;
// Spring rows hold `spring << 1 | end`; triangle rows hold triangle ids (the rows: `Particle::row`).
@group(0) @binding(4) var<storage, read> adj: array<u32>;
@group(0) @binding(5) var<storage, read> springs: array<Spring>;
@group(0) @binding(6) var<storage, read> spring_ends: array<vec2<u32>>;
// a, b, c, body
@group(0) @binding(7) var<storage, read> tris: array<vec4<u32>>;
// xyz: (x1 - x0) x (x2 - x0); w: its 6V contribution about the body's anchor (gas bodies only)
@group(0) @binding(8) var<storage, read_write> tri_cross: array<vec4<f32>>;
// force on each corner (pressure + wind share; pressure alone before the load check) [N]
@group(0) @binding(9) var<storage, read_write> tri_f: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> bodies: array<Body>;
// per body: volume [m^3], net pressure [Pa], 0, 0
@group(0) @binding(11) var<storage, read_write> body_state: array<vec4<f32>>;
// volume partial sums: row r (a workgroup of the triangle pass), column g (gas slot)
@group(0) @binding(12) var<storage, read_write> partials: array<f32>;
@group(0) @binding(13) var<storage, read> colliders: array<Collider>;
@group(0) @binding(14) var<storage, read> sdf: array<f32>;
// Openings: per opening (body, first slot, slot count, 0) as 4 words, then the loop vertices of every slot.
@group(0) @binding(15) var<storage, read> openings: array<u32>;
// Caps over openings, per particle: its row (start, length) at words 2i, 2i + 1; a row's items are pairs
// (opening, position in its loop) from word 2 * (particles + start). One word when there are no caps.
@group(0) @binding(16) var<storage, read> caps: array<u32>;
// Per opening: (centre xyz, 6 V of the cap), (Σ edge gradients xyz, slot count)
@group(0) @binding(17) var<storage, read_write> cap_data: array<vec4<f32>>;
// Per particle: the gas pressure's force through the caps over openings [N] (when the model has caps)
@group(0) @binding(18) var<storage, read_write> cap_f: array<vec4<f32>>;
// [spring count, vertex count, non-finite flag, 0, spring ids (capacity), vertex ids (capacity)]
@group(0) @binding(19) var<storage, read_write> candidates: array<atomic<u32>>;

// Contact between surfaces (contact.wgsl; bound only by its kernels, and empty when the model has no contact).
// Per particle: origin (the particle it was split from), body, 1 if it is a corner of a contact triangle, 0.
@group(0) @binding(20) var<storage, read> c_part: array<vec4<u32>>;
// Per body: contact thickness [m] (0: no contact), friction, 1 if it collides with itself, 0.
@group(0) @binding(21) var<storage, read> c_body: array<vec4<f32>>;
// The unique edges of the contact triangles (lower index first).
@group(0) @binding(22) var<storage, read> c_edges: array<vec2<u32>>;
// Positions at the start of the substep.
@group(0) @binding(23) var<storage, read_write> c_x0: array<vec4<f32>>;
// The two hash grids (vertices, edge midpoints): counts [0, 2B), bucket starts [2B, 4B + 1), the scan's block sums
// (contact.wgsl, `scan_blocks`), items after them.
@group(0) @binding(24) var<storage, read_write> c_grid: array<atomic<u32>>;
// The pairs within reach this substep.
@group(0) @binding(25) var<storage, read_write> c_pairs: array<Pair>;
// [pairs this substep, largest move (f32 bits), longest half edge (f32 bits), most pairs wanted past the capacity,
//  pairs pushed (summed), pairs within reach (summed), particles capped (summed), substeps], then each body's box
// (contact.wgsl, `body_box_at`).
@group(0) @binding(26) var<storage, read_write> c_ctl: array<atomic<u32>>;
// Per particle, 8 words: two sets of velocity-change totals (fixed point) xyz, bound (f32 bits), pairs it is in.
@group(0) @binding(27) var<storage, read_write> c_acc: array<atomic<i32>>;

// The workgroup counts of the dispatches over the pairs (x, y, z), written once the pairs are known.
@group(0) @binding(28) var<storage, read_write> c_args: array<u32>;
// `c_grid` again, as plain words: read-only for the pair searches, read-write for the scan, which need no atomics
// once the counts are in. Plain loads may be cached and overlapped; atomic ones are not (on an H100, balloons scene,
// 2 contact iterations: 471 -> 434 µs per substep). No kernel binds two of the three.
@group(0) @binding(29) var<storage, read> c_grid_r: array<u32>;
@group(0) @binding(30) var<storage, read_write> c_grid_w: array<u32>;

// A contact pair: four particles and weights (`Σ w x` runs from the second element to the first), the normal and
// gap, then thickness, friction, `Σ w² / m` and the accumulated normal impulse; the last iteration's change of it.
struct Pair {
    p: vec4<u32>,
    w: vec4<f32>,
    nd: vec4<f32>,
    hmj: vec4<f32>,
    last: vec4<f32>,
}

@group(1) @binding(0) var<uniform> clock: Clock;

// Flat index of a 2-D dispatch (more than 65535 workgroups of 64 need a second dimension).
fn flat_index(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * WG;
}

fn particle_count() -> u32 { return params.counts.x; }

fn q_src(i: u32) -> vec3<f32> { return state_src[2u * i].xyz; }
fn qd_src(i: u32) -> vec3<f32> { return state_src[2u * i + 1u].xyz; }
fn q_dst(i: u32) -> vec3<f32> { return state_dst[2u * i].xyz; }
fn qd_dst(i: u32) -> vec3<f32> { return state_dst[2u * i + 1u].xyz; }
fn store(i: u32, x: vec3<f32>, v: vec3<f32>) {
    state_dst[2u * i] = vec4<f32>(x, 0.0);
    state_dst[2u * i + 1u] = vec4<f32>(v, 0.0);
}
fn spring_count() -> u32 { return params.counts.y; }
fn tri_count() -> u32 { return params.counts.z; }

// ---- One home per equation: the scalar formulas every kernel uses, each the twin of one Rust function. ----

// Seed eqs. (1)-(2): the force of spring `s` on its end 0 with `d = xj - xi`, `dv = vj - vi`; projected damping
// when `projected`, else the paper's unprojected form. Coincident ends have no direction and no elastic force.
// Rust twin: `fissure_core::forces::spring::force_components`.
fn spring_force_of(d: vec3<f32>, dv: vec3<f32>, rest: f32, ks: f32, kd: f32, projected: bool) -> vec3<f32> {
    let l2 = dot(d, d);
    let l = sqrt(l2);
    let inv = select(0.0, 1.0 / l, l2 > 0.0);
    let u = d * inv;
    if (projected) {
        return u * (ks * (l - rest) + kd * dot(dv, u));
    }
    return u * (ks * (l - rest)) + dv * kd;
}

// The model's spring `s` with the model's damping form (params.gravity.w: 1 projected, 0 unprojected).
fn spring_force(s: Spring, d: vec3<f32>, dv: vec3<f32>) -> vec3<f32> {
    return spring_force_of(d, dv, s.rest, s.ks, s.kd, params.gravity.w != 0.0);
}

// The elastic part alone, `ks (l - L0) d̂` (the fracture load). Rust twin: `forces::spring::elastic_force`.
fn spring_elastic_force(s: Spring, d: vec3<f32>) -> vec3<f32> {
    return spring_force_of(d, vec3<f32>(0.0), s.rest, s.ks, 0.0, true);
}

// A body's volume is clamped below at this fraction of its rest volume before `P = nRT / V`.
// Rust twin: `fissure_core::forces::pressure::MIN_VOLUME_FRACTION`.
const MIN_VOLUME_FRACTION: f32 = 1e-3;

// Net gas pressure `nRT / max(V, MIN_VOLUME_FRACTION V0) - P_ext` [Pa]; 0 without gas.
// Rust twin: `fissure_core::forces::pressure::gas_pressure`.
fn gas_pressure(gas: f32, volume: f32, rest_volume: f32, p_ext: f32) -> f32 {
    if (gas <= 0.0) { return 0.0; }
    return gas / max(volume, rest_volume * MIN_VOLUME_FRACTION) - p_ext;
}

// Seed eq. (9): the pressure force on each corner of a triangle with cross vector `cross` under pressure `p`.
// Rust twin: `fissure_core::forces::pressure::corner_force`.
fn pressure_corner_force(cross: vec3<f32>, p: f32) -> vec3<f32> {
    return cross * (p * (1.0 / 6.0));
}
