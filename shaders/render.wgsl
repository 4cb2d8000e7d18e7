// The renderer (crates/fissure-gpu/src/render.rs): lit double-sided soft bodies, the scene's static geometry
// (ground, walls, obstacles), a wireframe of springs, mass points as screen-space squares, and a text overlay.
// Standalone: it does not include common.wgsl.
//
// Soft-body positions come straight from the solver's position buffer (vec4<f32> per particle, read here as a
// vertex buffer of stride 16), so a GPU run is drawn without a read-back. Soft bodies are shaded flat, with the
// face normal taken from screen-space derivatives of the world position: it needs no normal buffer (which a
// tearing mesh would have to rebuild every split) and shows the facets the springs span.

struct Camera {
    view_proj: mat4x4<f32>,
    eye: vec4<f32>,
    // x, y: viewport in pixels; z: point size in pixels; w: unused
    viewport: vec4<f32>,
    // direction towards the key light (unit), w unused
    light: vec4<f32>,
};

@group(0) @binding(0) var<uniform> cam: Camera;

fn shade(n_in: vec3<f32>, world: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    let v = normalize(cam.eye.xyz - world);
    // Double-sided: light the side that faces the viewer.
    var n = n_in;
    if (dot(n, v) < 0.0) {
        n = -n;
    }
    let l = cam.light.xyz;
    let diffuse = max(dot(n, l), 0.0);
    let h = normalize(l + v);
    let spec = pow(max(dot(n, h), 0.0), 48.0) * 0.35;
    let sky = 0.5 + 0.5 * n.y; // hemispherical ambient: brighter from above
    let ambient = mix(vec3<f32>(0.16, 0.14, 0.13), vec3<f32>(0.30, 0.33, 0.38), sky);
    let rim = pow(1.0 - max(dot(n, v), 0.0), 3.0) * 0.15;
    return albedo * (ambient + 0.85 * diffuse) + vec3<f32>(spec + rim);
}

fn to_linear(c: vec3<f32>) -> vec3<f32> {
    // Colours are given in sRGB; the targets are *Srgb formats, which encode on write.
    return pow(c, vec3<f32>(2.2));
}

// ---- soft bodies ------------------------------------------------------------------------------------------

struct BodyOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) color: vec3<f32>,
};

@vertex
fn body_vs(@location(0) q: vec4<f32>, @location(1) color: vec4<f32>) -> BodyOut {
    var o: BodyOut;
    o.clip = cam.view_proj * vec4<f32>(q.xyz, 1.0);
    o.world = q.xyz;
    o.color = to_linear(color.rgb);
    return o;
}

@fragment
fn body_fs(i: BodyOut, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    let n = normalize(cross(dpdx(i.world), dpdy(i.world)));
    // The inside of a torn body shows a darker, warmer tint than its outside.
    var albedo = i.color;
    if (!front) {
        albedo = i.color * vec3<f32>(0.55, 0.38, 0.32);
    }
    return vec4<f32>(shade(n, i.world, albedo), 1.0);
}

// ---- static scene geometry: ground, walls, obstacles -----------------------------------------------------

struct StaticOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
};

@vertex
fn static_vs(@location(0) p: vec3<f32>, @location(1) n: vec3<f32>, @location(2) color: vec4<f32>) -> StaticOut {
    var o: StaticOut;
    o.clip = cam.view_proj * vec4<f32>(p, 1.0);
    o.world = p;
    o.normal = n;
    o.color = color;
    return o;
}

@fragment
fn static_fs(i: StaticOut) -> @location(0) vec4<f32> {
    var albedo = to_linear(i.color.rgb);
    // color.a = 1: a checkerboard of 0.25 m tiles (floor and walls), for a sense of scale and motion.
    if (i.color.a > 0.5) {
        let t = floor(i.world / 0.25 + vec3<f32>(1e-3));
        let odd = (i32(t.x) + i32(t.y) + i32(t.z)) & 1;
        if (odd == 1) {
            albedo = albedo * 0.82;
        }
    }
    return vec4<f32>(shade(normalize(i.normal), i.world, albedo), 1.0);
}

// ---- wireframe: springs ----------------------------------------------------------------------------------

struct LineOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
};

@vertex
fn line_vs(@location(0) q: vec4<f32>) -> LineOut {
    return line_out(q, vec3<f32>(0.10, 0.12, 0.16));
}

fn line_out(q: vec4<f32>, srgb: vec3<f32>) -> LineOut {
    var o: LineOut;
    let c = cam.view_proj * vec4<f32>(q.xyz, 1.0);
    // A small pull towards the camera keeps the lines in front of the faces they lie on.
    o.clip = vec4<f32>(c.xy, c.z - 2e-4 * c.w, c.w);
    o.color = vec4<f32>(to_linear(srgb), 1.0);
    return o;
}

// Crack edges: the same lines in a bright amber, so slits and the rims of holes stand out on any body colour.
@vertex
fn crack_vs(@location(0) q: vec4<f32>) -> LineOut {
    return line_out(q, vec3<f32>(1.0, 0.78, 0.12));
}

@fragment
fn line_fs(i: LineOut) -> @location(0) vec4<f32> {
    return i.color;
}

// ---- mass points: one screen-space square per particle (instanced) ---------------------------------------

@vertex
fn point_vs(@builtin(vertex_index) k: u32, @location(0) q: vec4<f32>, @location(1) color: vec4<f32>) -> LineOut {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    );
    var o: LineOut;
    let c = cam.view_proj * vec4<f32>(q.xyz, 1.0);
    let px = corners[k] * cam.viewport.z / cam.viewport.xy; // half size in NDC units
    o.clip = vec4<f32>(c.xy + px * c.w, c.z - 4e-4 * c.w, c.w);
    // Points are drawn darker than their body; pinned particles (alpha 0 in the colour buffer) red.
    if (color.a < 0.5) {
        o.color = vec4<f32>(to_linear(vec3<f32>(0.85, 0.1, 0.1)), 1.0);
    } else {
        o.color = vec4<f32>(to_linear(color.rgb * 0.35), 1.0);
    }
    return o;
}

// ---- text overlay: a texture drawn at a pixel rectangle ---------------------------------------------------

struct OverlayRect {
    // left, top, right, bottom in NDC
    rect: vec4<f32>,
};

@group(1) @binding(0) var overlay_tex: texture_2d<f32>;
@group(1) @binding(1) var<uniform> orect: OverlayRect;

struct OverlayOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) uv: vec2<f32>,
};

@vertex
fn overlay_vs(@builtin(vertex_index) k: u32) -> OverlayOut {
    var uv = array<vec2<f32>, 6>(
        vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 1.0), vec2<f32>(1.0, 0.0),
        vec2<f32>(0.0, 1.0), vec2<f32>(1.0, 0.0), vec2<f32>(0.0, 0.0),
    );
    var o: OverlayOut;
    let r = orect.rect;
    o.uv = uv[k];
    o.clip = vec4<f32>(mix(r.x, r.z, uv[k].x), mix(r.y, r.w, uv[k].y), 0.0, 1.0);
    return o;
}

@fragment
fn overlay_fs(i: OverlayOut) -> @location(0) vec4<f32> {
    let size = vec2<f32>(textureDimensions(overlay_tex));
    let texel = vec2<i32>(clamp(i.uv * size, vec2<f32>(0.0), size - vec2<f32>(1.0)));
    let c = textureLoad(overlay_tex, texel, 0);
    return vec4<f32>(to_linear(c.rgb), c.a);
}
