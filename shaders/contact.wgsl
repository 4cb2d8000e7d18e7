// Contact between surfaces: the twin of `fissure_core::solver::contact` (the model is documented in
// `fissure_core::contact`). Encoded only when the model has contact. Per substep:
//  - at its start (`contact_count`, `contact_scan_sums`, `contact_scan_spread`, `contact_scatter`): the positions
//    are saved and two hashed uniform grids are built from them by a counting sort with u32 atomics, one of the
//    contact vertices, one of the midpoints of the contact edges;
//  - after the integrator and the colliders (`contact_moves` … `contact_apply`): the largest move sets the search
//    reach `r = h_max + d_max / GAMMA`; every vertex–triangle and edge–edge pair closer than its own reach
//    (`pair_reach`: the same with its four particles' largest move) at the start is listed
//    (`contact_vt`, `contact_ee`, 8 invocations per element); Jacobi iterations solve the normal impulses
//    (alternating between two sets of totals: all in one workgroup while the pairs are few, else one dispatch
//    each), then one pass of Coulomb friction;
//    each particle's move is capped by the displacement bound (`GAMMA` times its nearest pair's gap, at most
//    `GAMMA h_max` plus its own move), which rules
//    out crossings whatever the impulses did.
// As on the CPU, an element whose box meets no other body's box (and whose body does not collide with itself)
// skips the search: away from contacts an element costs one box test per body.
// Differences from the CPU pass: the grids are built at every substep (no Verlet list), and the impulses are
// solved by Jacobi (each pair's update scaled by 1 / the most pairs any of its particles is in) instead of
// Gauss–Seidel. Velocity changes are summed in fixed point with integer atomics (no float atomics): integer sums
// do not depend on the order, so a run is deterministic although the pairs are listed in a racy order.

// Twins of `fissure_core::contact::GAMMA`, `RELAX` and `PUSH_TIME`.
const GAMMA: f32 = 0.45;
const RELAX: f32 = 0.1;
const PUSH_TIME: f32 = 1e-4;
// `c_acc` words per particle (two sets of velocity-change totals xyz, the bound, the pairs it is in), and the
// bound's initial value (+inf as f32 bits).
const ACC: u32 = 8u;
const NO_BOUND: i32 = 0x7f800000;

fn buckets() -> u32 { return params.contact_n.y + 1u; }

// Each body's box at the start of the substep, in `c_ctl` from word 8: min xyz then max xyz, as order-preserving
// u32 keys (so that u32 atomics take float minima and maxima). Reset to empty by `contact_args` for the next substep.
fn body_box_at(b: u32) -> u32 { return 8u + 6u * b; }

fn ordered(f: f32) -> u32 {
    let b = bitcast<u32>(f);
    return select(b | 0x80000000u, ~b, (b & 0x80000000u) != 0u);
}

// The inverse of `ordered`; an empty box's keys come back as NaN, which meets nothing.
fn unordered(u: u32) -> f32 {
    return bitcast<f32>(select(~u, u & 0x7fffffffu, (u & 0x80000000u) != 0u));
}

// True if the box [lo, hi] of an element of `body` may hold a pair: its body collides with itself, or the box
// meets another body's box (the CPU pass's culling: away from contacts an element costs this test alone).
fn meets_another(body: u32, lo: vec3<f32>, hi: vec3<f32>) -> bool {
    if (c_body[body].z != 0.0) { return true; }
    for (var b = 0u; b < params.counts.w; b++) {
        if (b == body) { continue; }
        let o = body_box_at(b);
        let blo = vec3<f32>(unordered(atomicLoad(&c_ctl[o])), unordered(atomicLoad(&c_ctl[o + 1u])), unordered(atomicLoad(&c_ctl[o + 2u])));
        let bhi = vec3<f32>(unordered(atomicLoad(&c_ctl[o + 3u])), unordered(atomicLoad(&c_ctl[o + 4u])), unordered(atomicLoad(&c_ctl[o + 5u])));
        if (all(blo <= hi) && all(lo <= bhi)) { return true; }
    }
    return false;
}
// For the searches (`c_grid_r`, once the grids are built).
fn grid_start(g: u32) -> u32 { return c_grid_r[2u * buckets() + g]; }
fn grid_item(s: u32) -> u32 { return c_grid_r[grid_items_at() + s]; }

fn cell_of(p: vec3<f32>) -> vec3<i32> {
    return vec3<i32>(floor(p / params.contact_f.y));
}

fn bucket_of(c: vec3<i32>) -> u32 {
    let u = bitcast<vec3<u32>>(c);
    var h = (u.x * 0x8da6b343u) ^ (u.y * 0xd8163841u) ^ (u.z * 0xcb1ab31fu);
    h = h ^ (h >> 15u);
    return h & params.contact_n.y;
}

// The step's reach: a particle with nothing within it moves at most `GAMMA r`, so the bound never caps it.
fn reach() -> f32 {
    return params.contact_f.x + bitcast<f32>(atomicLoad(&c_ctl[1])) / GAMMA;
}

// A contact particle's move this substep (`contact_moves` keeps it beside its start, in `c_x0[i].w`), and a pair's
// own reach: the thickness plus its particles' largest move over GAMMA (the CPU's `near`). The grids are searched
// at the step's reach, the largest of them.
fn moved(i: u32) -> f32 {
    return c_x0[i].w;
}

fn pair_reach(p: vec4<u32>) -> f32 {
    return params.contact_f.x + max(max(moved(p.x), moved(p.y)), max(moved(p.z), moved(p.w))) / GAMMA;
}

fn fixed(v: f32) -> i32 {
    return i32(clamp(round(v * params.contact_f.z), -2.0e9, 2.0e9));
}

fn dv_total(i: u32, totals: u32) -> vec3<f32> {
    let a = ACC * i + 3u * totals;
    let v = vec3<i32>(atomicLoad(&c_acc[a]), atomicLoad(&c_acc[a + 1u]), atomicLoad(&c_acc[a + 2u]));
    return vec3<f32>(v) / params.contact_f.z;
}

fn dv_add(i: u32, totals: u32, v: vec3<f32>) {
    let a = ACC * i + 3u * totals;
    atomicAdd(&c_acc[a], fixed(v.x));
    atomicAdd(&c_acc[a + 1u], fixed(v.y));
    atomicAdd(&c_acc[a + 2u], fixed(v.z));
}

// Barycentric weights of the point of triangle abc closest to p (Ericson 5.1.5).
// Rust twin: `fissure_core::contact::geometry::closest_on_triangle`.
fn closest_on_triangle(p: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> vec3<f32> {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) { return vec3<f32>(1.0, 0.0, 0.0); }
    let bp = p - b;
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) { return vec3<f32>(0.0, 1.0, 0.0); }
    let vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        let v = d1 / (d1 - d3);
        return vec3<f32>(1.0 - v, v, 0.0);
    }
    let cp = p - c;
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) { return vec3<f32>(0.0, 0.0, 1.0); }
    let vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        let w = d2 / (d2 - d6);
        return vec3<f32>(1.0 - w, 0.0, w);
    }
    let va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return vec3<f32>(0.0, 1.0 - w, w);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    return vec3<f32>(1.0 - v - w, v, w);
}

// Parameters (s, t) of the closest points of segments p1q1 and p2q2 (Ericson 5.1.9).
// Rust twin: `fissure_core::contact::geometry::closest_on_segments`.
fn closest_on_segments(p1: vec3<f32>, q1: vec3<f32>, p2: vec3<f32>, q2: vec3<f32>) -> vec2<f32> {
    let d1 = q1 - p1;
    let d2 = q2 - p2;
    let r = p1 - p2;
    let a = dot(d1, d1);
    let e = dot(d2, d2);
    let f = dot(d2, r);
    let tiny = 1e-30;
    if (a <= tiny && e <= tiny) { return vec2<f32>(0.0); }
    if (a <= tiny) { return vec2<f32>(0.0, clamp(f / e, 0.0, 1.0)); }
    let c = dot(d1, r);
    if (e <= tiny) { return vec2<f32>(clamp(-c / a, 0.0, 1.0), 0.0); }
    let b = dot(d1, d2);
    let denom = a * e - b * b;
    var s = 0.0;
    if (denom > 0.0) { s = clamp((b * f - c * e) / denom, 0.0, 1.0); }
    var t = (b * s + f) / e;
    if (t < 0.0) {
        t = 0.0;
        s = clamp(-c / a, 0.0, 1.0);
    } else if (t > 1.0) {
        t = 1.0;
        s = clamp((b - c) / a, 0.0, 1.0);
    }
    return vec2<f32>(s, t);
}

// Lists a pair closer than the reach: thickness the larger of the bodies', friction their mean.
fn push_pair(p: vec4<u32>, w: vec4<f32>, n: vec3<f32>, d: f32, ba: u32, bb: u32) {
    let k = atomicAdd(&c_ctl[0], 1u);
    if (k >= params.contact_n.z) {
        atomicMax(&c_ctl[3], k + 1u);
        return;
    }
    let im = vec4<f32>(particles[p.x].inv_mass, particles[p.y].inv_mass, particles[p.z].inv_mass, particles[p.w].inv_mass);
    let h = max(c_body[ba].x, c_body[bb].x);
    let mu = 0.5 * (c_body[ba].y + c_body[bb].y);
    c_pairs[k] = Pair(p, w, vec4<f32>(n, d), vec4<f32>(h, mu, dot(w * w, im), 0.0), vec4<f32>(0.0));
}

fn same_origin(a: u32, b: u32) -> bool {
    return c_part[a].x == c_part[b].x;
}

// Bodies `a` and `b` may touch: different bodies, or one that collides with itself; and not a pair left out of
// contact (a piece born crossing its family, until they part: `fissure_core::contact::family`), listed in
// `c_body` after the bodies, as many as body 0's last component says.
fn allowed(a: u32, b: u32) -> bool {
    if (a == b) { return c_body[a].z != 0.0; }
    let n = params.counts.w;
    let lo = f32(min(a, b));
    let hi = f32(max(a, b));
    for (var k = n; k < n + u32(c_body[0].w); k++) {
        if (c_body[k].x == lo && c_body[k].y == hi) { return false; }
    }
    return true;
}

// Each contact particle's start position saved and counted into the vertex grid, with its body's box; each
// contact edge's midpoint counted into the edge grid, with the longest half edge. One dispatch over particles,
// then edges (two, first, cost a dependent dispatch's ~7 µs more on an H200 for nothing). The edges read the
// state, not `c_x0`, which this dispatch writes. `c_ctl`'s largest move and longest half edge are emptied by
// `contact_args` for the next substep (and by the submission's clear for its first).
@compute @workgroup_size(64)
fn contact_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = flat_index(gid, nwg);
    if (k == 0u) {
        atomicStore(&c_ctl[0], 0u);
        atomicAdd(&c_ctl[7], 1u);
    }
    let n = particle_count();
    if (k < n) {
        let x = q_src(k);
        c_x0[k] = vec4<f32>(x, 0.0);
        if (c_part[k].z == 0u) { return; }
        atomicAdd(&c_grid[bucket_of(cell_of(x))], 1u);
        let o = body_box_at(c_part[k].y);
        for (var c = 0u; c < 3u; c++) {
            atomicMin(&c_ctl[o + c], ordered(x[c]));
            atomicMax(&c_ctl[o + 3u + c], ordered(x[c]));
        }
        return;
    }
    let e = k - n;
    if (e >= params.contact_n.x) { return; }
    let ab = c_edges[e];
    let a = q_src(ab.x);
    let b = q_src(ab.y);
    atomicMax(&c_ctl[2], bitcast<u32>(0.5 * length(b - a)));
    atomicAdd(&c_grid[buckets() + bucket_of(cell_of(0.5 * (a + b)))], 1u);
}

// The bucket starts of both grids: an exclusive scan of their `2 buckets()` counts in blocks of `SCAN_BLOCK`, by
// two dispatches of one workgroup per block: `contact_scan_sums` sums each block, `contact_scan_spread` adds up the
// sums of the blocks before its own and scans its block. The block sums lie after the total, before the items.
// One workgroup scanning both grids, the first version, read its counts in 256 strided chains on one compute
// unit: the 128^2 fold (2^18 counts) took 1,100 µs per substep on an H200 with it, 571 µs with this.
const SCAN_BLOCK: u32 = 1024u;
var<workgroup> scan_part: array<u32, 256>;

fn scan_blocks() -> u32 { return (2u * buckets() + SCAN_BLOCK - 1u) / SCAN_BLOCK; }
fn scan_sums_at() -> u32 { return 4u * buckets() + 1u; }
fn grid_items_at() -> u32 { return scan_sums_at() + scan_blocks(); }

fn scan_count(k: u32) -> u32 {
    if (k < 2u * buckets()) { return c_grid_w[k]; }
    return 0u;
}

// `scan_part`'s 256 values summed into `scan_part[0]` (every invocation of the workgroup calls it).
fn scan_reduce(t: u32) {
    for (var w = 128u; w > 0u; w >>= 1u) {
        if (t < w) { scan_part[t] += scan_part[t + w]; }
        workgroupBarrier();
    }
}

@compute @workgroup_size(256)
fn contact_scan_sums(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) t: u32) {
    let base = wid.x * SCAN_BLOCK + 4u * t;
    scan_part[t] = scan_count(base) + scan_count(base + 1u) + scan_count(base + 2u) + scan_count(base + 3u);
    workgroupBarrier();
    scan_reduce(t);
    if (t == 0u) { c_grid_w[scan_sums_at() + wid.x] = scan_part[0]; }
}

@compute @workgroup_size(256)
fn contact_scan_spread(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) t: u32) {
    let b = wid.x;
    // The block's offset: the sums of the blocks before it.
    var before = 0u;
    for (var k = t; k < b; k += 256u) {
        before += c_grid_w[scan_sums_at() + k];
    }
    scan_part[t] = before;
    workgroupBarrier();
    scan_reduce(t);
    let offset = scan_part[0];
    workgroupBarrier();
    // This invocation's four counts, and an inclusive scan of the invocations' sums (Hillis-Steele).
    let n = 2u * buckets();
    let base = b * SCAN_BLOCK + 4u * t;
    let c = vec4<u32>(scan_count(base), scan_count(base + 1u), scan_count(base + 2u), scan_count(base + 3u));
    let own = c.x + c.y + c.z + c.w;
    scan_part[t] = own;
    workgroupBarrier();
    for (var w = 1u; w < 256u; w <<= 1u) {
        var v = scan_part[t];
        if (t >= w) { v += scan_part[t - w]; }
        workgroupBarrier();
        scan_part[t] = v;
        workgroupBarrier();
    }
    var run = offset + scan_part[t] - own;
    for (var k = 0u; k < 4u; k++) {
        if (base + k < n) { c_grid_w[n + base + k] = run; }
        run += c[k];
    }
    // The last block's last invocation holds the total (counts past the grid read as zero).
    if (b + 1u == scan_blocks() && t == 255u) { c_grid_w[n + n] = run; }
}

// Each vertex and edge into its bucket; the counts count back down to zero for the next substep.
@compute @workgroup_size(64)
fn contact_scatter(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = flat_index(gid, nwg);
    let n = particle_count();
    var g = 0u;
    var id = k;
    if (k < n) {
        if (c_part[k].z == 0u) { return; }
        g = bucket_of(cell_of(c_x0[k].xyz));
    } else if (k < n + params.contact_n.x) {
        id = k - n;
        let ab = c_edges[id];
        g = buckets() + bucket_of(cell_of(0.5 * (c_x0[ab.x].xyz + c_x0[ab.y].xyz)));
    } else {
        return;
    }
    let slot = atomicLoad(&c_grid[2u * buckets() + g]) + atomicSub(&c_grid[g], 1u) - 1u;
    atomicStore(&c_grid[grid_items_at() + slot], id);
}

@compute @workgroup_size(64)
fn contact_moves(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = flat_index(gid, nwg);
    if (i >= particle_count() || c_part[i].z == 0u) { return; }
    let d = length(q_dst(i) - c_x0[i].xyz);
    c_x0[i].w = d;
    atomicMax(&c_ctl[1], bitcast<u32>(d));
}

// The cells of the box [lo, hi]: how many to visit (1, meaning every item of the grid, when the box spans more
// cells than the grid has buckets), and the span per axis.
fn box_cells(lo: vec3<f32>, hi: vec3<f32>) -> vec4<u32> {
    let span = vec3<u32>(cell_of(hi) - cell_of(lo) + vec3<i32>(1));
    if (f32(span.x) * f32(span.y) * f32(span.z) > f32(buckets())) {
        return vec4<u32>(1u, 0u, 0u, 0u);
    }
    return vec4<u32>(span.x * span.y * span.z, span);
}

// Bucket range `[from, to)` of cell number `c` of a box starting at cell `a` (grid `g0`: 0 vertices, `buckets()`
// edges); with `span.y == 0`, every item of the grid.
fn cell_range(g0: u32, a: vec3<i32>, span: vec4<u32>, c: u32) -> vec2<u32> {
    if (span.y == 0u) {
        return vec2<u32>(grid_start(g0), grid_start(g0 + buckets()));
    }
    let b = g0 + bucket_of(cell_at(a, span, c));
    return vec2<u32>(grid_start(b), grid_start(b + 1u));
}

fn cell_at(a: vec3<i32>, span: vec4<u32>, c: u32) -> vec3<i32> {
    return a + vec3<i32>(vec3<u32>(c % span.y, (c / span.y) % span.z, c / (span.y * span.z)));
}

// Invocations per element in the pair searches. Each element's search is a chain of dependent loads (bucket
// starts, items, their positions) over the cells of its box; with one invocation per element a few thousand
// elements fill a large GPU thinly and every invocation waits out its chain alone (on an H100 the two searches
// took ~270 µs of a balloons substep). `LANES` invocations share an element's cells (or, when one "cell" is the
// whole grid, its items), so the chains are `LANES` times shorter and more of them are in flight: 434 -> 258 µs
// per substep there (2 iterations); 16 and 32 lanes measured no better.
const LANES: u32 = 8u;

// The share of an element's search for `lane`: the first cell and the cell step, the first item offset within a
// cell and the item step.
fn lane_share(span: vec4<u32>, lane: u32) -> vec4<u32> {
    if (span.y == 0u) {
        return vec4<u32>(0u, 1u, lane, LANES);
    }
    return vec4<u32>(lane, LANES, 0u, 1u);
}

// Vertex–triangle pairs: each contact triangle against the vertices in the cells of its box grown by the reach.
@compute @workgroup_size(64)
fn contact_vt(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let t = flat_index(gid, nwg) / LANES;
    let lane = flat_index(gid, nwg) % LANES;
    if (t >= tri_count()) { return; }
    let tv = tris[t];
    if (c_body[tv.w].x <= 0.0) { return; }
    let r = reach();
    let xa = c_x0[tv.x].xyz;
    let xb = c_x0[tv.y].xyz;
    let xc = c_x0[tv.z].xyz;
    let lo = min(min(xa, xb), xc) - vec3<f32>(r);
    let hi = max(max(xa, xb), xc) + vec3<f32>(r);
    if (!meets_another(tv.w, lo, hi)) { return; }
    let a = cell_of(lo);
    let span = box_cells(lo, hi);
    let origins = vec3<u32>(c_part[tv.x].x, c_part[tv.y].x, c_part[tv.z].x);
    let share = lane_share(span, lane);
    for (var c = share.x; c < span.x; c += share.y) {
        let range = cell_range(0u, a, span, c);
        for (var s = range.x + share.z; s < range.y; s += share.w) {
            let v = grid_item(s);
            let p = c_x0[v].xyz;
            if (span.y != 0u && any(cell_of(p) != cell_at(a, span, c))) { continue; }
            if (any(p < lo) || any(p > hi)) { continue; }
            let pv = c_part[v];
            if (any(origins == vec3<u32>(pv.x)) || !allowed(pv.y, tv.w)) { continue; }
            let w = closest_on_triangle(p, xa, xb, xc);
            let diff = p - (w.x * xa + w.y * xb + w.z * xc);
            let d = length(diff);
            if (d >= r || d >= pair_reach(vec4<u32>(v, tv.xyz))) { continue; }
            var n = cross(xb - xa, xc - xa);
            if (d > 1e-12) { n = diff / d; } else if (dot(n, n) > 0.0) { n = normalize(n); } else { n = vec3<f32>(0.0, 1.0, 0.0); }
            push_pair(vec4<u32>(v, tv.xyz), vec4<f32>(1.0, -w), n, d, pv.y, tv.w);
        }
    }
}

// Edge–edge pairs: each contact edge against the edges of higher index whose midpoints lie in the cells of its box
// grown by the reach and the longest half edge.
@compute @workgroup_size(64)
fn contact_ee(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let e = flat_index(gid, nwg) / LANES;
    let lane = flat_index(gid, nwg) % LANES;
    if (e >= params.contact_n.x) { return; }
    let ea = c_edges[e];
    let r = reach();
    let p = c_x0[ea.x].xyz;
    let q = c_x0[ea.y].xyz;
    let elo = min(p, q);
    let ehi = max(p, q);
    let grow = vec3<f32>(r + bitcast<f32>(atomicLoad(&c_ctl[2])));
    let lo = elo - grow;
    let hi = ehi + grow;
    let body = c_part[ea.x].y;
    if (!meets_another(body, elo - vec3<f32>(r), ehi + vec3<f32>(r))) { return; }
    let a = cell_of(lo);
    let span = box_cells(lo, hi);
    let oa = vec2<u32>(c_part[ea.x].x, c_part[ea.y].x);
    let share = lane_share(span, lane);
    for (var c = share.x; c < span.x; c += share.y) {
        let range = cell_range(buckets(), a, span, c);
        for (var s = range.x + share.z; s < range.y; s += share.w) {
            let f = grid_item(s);
            if (f <= e) { continue; }
            let eb = c_edges[f];
            let u = c_x0[eb.x].xyz;
            let w = c_x0[eb.y].xyz;
            if (span.y != 0u && any(cell_of(0.5 * (u + w)) != cell_at(a, span, c))) { continue; }
            if (any(min(u, w) - ehi >= vec3<f32>(r)) || any(elo - max(u, w) >= vec3<f32>(r))) { continue; }
            let ob = vec2<u32>(c_part[eb.x].x, c_part[eb.y].x);
            if (any(oa == vec2<u32>(ob.x)) || any(oa == vec2<u32>(ob.y))) { continue; }
            let fb = c_part[eb.x].y;
            if (!allowed(body, fb)) { continue; }
            let st = closest_on_segments(p, q, u, w);
            let diff = mix(p, q, st.x) - mix(u, w, st.y);
            let d = length(diff);
            if (d >= r || d >= pair_reach(vec4<u32>(ea, eb))) { continue; }
            var n = cross(q - p, w - u);
            if (d > 1e-12) { n = diff / d; } else if (dot(n, n) > 0.0) { n = normalize(n); } else { n = vec3<f32>(0.0, 1.0, 0.0); }
            push_pair(vec4<u32>(ea, eb), vec4<f32>(1.0 - st.x, st.x, st.y - 1.0, -st.y), n, d, body, fb);
        }
    }
}

fn pair_count() -> u32 {
    return min(atomicLoad(&c_ctl[0]), params.contact_n.z);
}

// The dispatches over the pairs run as many workgroups as there are pairs this substep (indirect), not the
// capacity's worth. Also empties the bodies' boxes for the next substep.
@compute @workgroup_size(1)
fn contact_args() {
    // The searches are done: the largest move and the longest half edge start empty for the next substep.
    atomicStore(&c_ctl[1], 0u);
    atomicStore(&c_ctl[2], 0u);
    for (var b = 0u; b < params.counts.w; b++) {
        for (var c = 0u; c < 3u; c++) {
            atomicStore(&c_ctl[body_box_at(b) + c], 0xffffffffu);
            atomicStore(&c_ctl[body_box_at(b) + 3u + c], 0u);
        }
    }
    let groups = (pair_count() + WG - 1u) / WG;
    let x = min(groups, 65535u);
    c_args[0] = x;
    c_args[1] = select(1u, (groups + x - 1u) / x, x > 0u);
    c_args[2] = 1u;
}

// Each pair's particles: the displacement bound (GAMMA times the nearest gap, and at most `GAMMA h + d_i`, which
// keeps particle `i` within GAMMA of the gap of every pair it is in but not within reach) and how many pairs each
// is in.
@compute @workgroup_size(64)
fn contact_prep(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = flat_index(gid, nwg);
    if (k >= pair_count()) { return; }
    if (k == 0u) { atomicAdd(&c_ctl[5], pair_count()); }
    let pr = c_pairs[k];
    let b = GAMMA * pr.nd.w;
    for (var m = 0u; m < 4u; m++) {
        let start = GAMMA * params.contact_f.x + moved(pr.p[m]);
        atomicMin(&c_acc[ACC * pr.p[m] + 6u], bitcast<i32>(min(b, start)));
        atomicAdd(&c_acc[ACC * pr.p[m] + 7u], 1);
    }
}

// Jacobi's relaxation of a pair: 1 / the most pairs any of its particles is in.
fn relaxation(p: vec4<u32>) -> f32 {
    var most = 1;
    for (var m = 0u; m < 4u; m++) {
        most = max(most, atomicLoad(&c_acc[ACC * p[m] + 7u]));
    }
    return 1.0 / f32(most);
}

// The relative velocity of a pair's two elements with the velocity changes so far (totals set `set`).
fn pair_velocity(pr: Pair, totals: u32) -> vec3<f32> {
    var u = vec3<f32>(0.0);
    for (var m = 0u; m < 4u; m++) {
        u += pr.w[m] * (qd_dst(pr.p[m]) + dv_total(pr.p[m], totals));
    }
    return u;
}

// Adds impulse `j` along `dir` to the pair's particles in totals set `set`.
fn pair_push(pr: Pair, totals: u32, j: f32, dir: vec3<f32>) {
    if (j == 0.0) { return; }
    for (var m = 0u; m < 4u; m++) {
        dv_add(pr.p[m], totals, (pr.w[m] * particles[pr.p[m]].inv_mass * j) * dir);
    }
}

// One Jacobi iteration of the normal impulses: the impulse that brings the predicted gap at the end of the step to
// the thickness (a pair already inside it recovers RELAX of its overlap per step, or per PUSH_TIME when the step is
// shorter), never pulling. It reads the totals of set `read` and adds to the other set, which lags by the previous
// iteration's changes: each pair adds its previous change again (the same rounded integers) with its new one, so
// after the iteration the other set holds every change so far, and no set is read while it is written (Jacobi, one
// dispatch per iteration).
fn jacobi(k: u32, read: u32) {
    if (k >= pair_count()) { return; }
    let pr = c_pairs[k];
    let wsum = pr.hmj.z;
    if (wsum <= 0.0) { return; }
    let n = pr.nd.xyz;
    let d = pr.nd.w;
    let h = pr.hmj.x;
    let un = dot(pair_velocity(pr, read), n);
    var goal = RELAX * (h - d) / max(clock.dt, PUSH_TIME);
    if (d >= h) { goal = (h - d) / clock.dt; }
    let j = max(pr.hmj.w + relaxation(pr.p) * (goal - un) / wsum, 0.0);
    let dj = j - pr.hmj.w;
    c_pairs[k].hmj.w = j;
    c_pairs[k].last.x = dj;
    pair_push(pr, 1u - read, pr.last.x, n);
    pair_push(pr, 1u - read, dj, n);
}

@compute @workgroup_size(64)
fn contact_jacobi_even(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    jacobi(flat_index(gid, nwg), 0u);
}

@compute @workgroup_size(64)
fn contact_jacobi_odd(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    jacobi(flat_index(gid, nwg), 1u);
}

// Every Jacobi iteration in one workgroup, a storage barrier between two (the same updates as one dispatch per
// iteration, so the same bits: each pair is owned by one invocation throughout, and an iteration's sums are whole
// before the next reads them). A dispatch costs ~10 µs on an H100 whatever its size, so for the few hundred pairs
// a substep usually has one workgroup looping is much cheaper than 16 dispatches; the solver picks it by the last
// submission's pair count (`GpuConfig::contact_fused_pairs`).
@compute @workgroup_size(256)
fn contact_jacobi_fused(@builtin(local_invocation_index) t: u32) {
    let iterations = params.contact_n.w;
    for (var it = 0u; it < iterations; it++) {
        let n = pair_count();
        for (var k = t; k < n; k += 256u) {
            jacobi(k, it % 2u);
        }
        storageBarrier();
    }
}

// Coulomb friction: tangential relative velocity removed up to mu times the pair's normal impulse. After an even
// number of Jacobi iterations set 0 holds every normal change; set 1 gets the last iteration's changes again and
// the friction impulses, and is the one applied.
@compute @workgroup_size(64)
fn contact_friction(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let k = flat_index(gid, nwg);
    if (k >= pair_count()) { return; }
    let pr = c_pairs[k];
    let n = pr.nd.xyz;
    pair_push(pr, 1u, pr.last.x, n);
    let wsum = pr.hmj.z;
    if (pr.hmj.w <= 0.0) { return; }
    atomicAdd(&c_ctl[4], 1u);
    let u = pair_velocity(pr, 0u);
    let ut = u - dot(u, n) * n;
    let speed = length(ut);
    if (speed <= 0.0 || wsum <= 0.0) { return; }
    let jt = min(relaxation(pr.p) * speed / wsum, pr.hmj.y * pr.hmj.w);
    pair_push(pr, 1u, -jt, ut / speed);
}

// Applies each touched particle's velocity change (set 1), caps its move at its bound, and resets its words.
@compute @workgroup_size(64)
fn contact_apply(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = flat_index(gid, nwg);
    if (i >= particle_count() || atomicLoad(&c_acc[ACC * i + 7u]) == 0) { return; }
    let dv = dv_total(i, 1u);
    let b = bitcast<f32>(atomicExchange(&c_acc[ACC * i + 6u], NO_BOUND));
    for (var c = 0u; c < 6u; c++) {
        atomicStore(&c_acc[ACC * i + c], 0);
    }
    atomicStore(&c_acc[ACC * i + 7u], 0);
    if (particles[i].inv_mass == 0.0) { return; }
    let x0 = c_x0[i].xyz;
    var x = q_dst(i) + clock.dt * dv;
    var v = qd_dst(i) + dv;
    let mv = x - x0;
    let len = length(mv);
    if (len > b) {
        let k = b / len;
        x = x0 + k * mv;
        v *= k;
        atomicAdd(&c_ctl[6], 1u);
    }
    // The colliders again (their pass ran before this one), within the same bound: a push out of the ground that
    // would carry the particle farther than `b` could cross another surface (the CPU's contact pass does the same).
    if (params.counts2.x > 0u) {
        let r = resolve_all(x, v);
        if (r.hit && length(r.x - x0) <= b) {
            x = r.x;
            v = r.v;
        }
    }
    store(i, x, v);
}
