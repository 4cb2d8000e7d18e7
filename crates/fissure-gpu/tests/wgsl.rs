//! Every WGSL file parses and validates with naga (the compiler wgpu uses), with no GPU needed; and the Rust
//! mirrors of the WGSL structs have the sizes the WGSL layout rules give them.

use fissure_gpu::{COMMON_WGSL, SHADERS, shader_source};

fn validate(name: &str, src: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(src).unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(src)));
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::default())
        .validate(&module)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(src)));
    module
}

#[test]
fn every_shader_file_validates() {
    validate("common.wgsl", COMMON_WGSL);
    validate("common.wgsl + colliders.wgsl", &shader_source(""));
    for (name, src) in SHADERS {
        let m = validate(name, &shader_source(src));
        assert!(m.entry_points.iter().all(|e| e.stage == naga::ShaderStage::Compute), "{name}");
        assert!(!m.entry_points.is_empty(), "{name} has no kernel");
    }
}

/// The renderer's shader stands alone (no common.wgsl): vertex and fragment stages for bodies, scene geometry,
/// springs, crack edges, mass points and the overlay.
#[test]
fn the_render_shader_validates() {
    let m = validate("render.wgsl", fissure_gpu::render::RENDER_WGSL);
    for stage in [naga::ShaderStage::Vertex, naga::ShaderStage::Fragment] {
        // Points and crack edges share the lines' fragment stage.
        let want = if stage == naga::ShaderStage::Vertex { 6 } else { 4 };
        assert_eq!(m.entry_points.iter().filter(|e| e.stage == stage).count(), want, "{stage:?}");
    }
}

#[test]
fn every_file_in_the_shader_folder_is_compiled_in() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shaders");
    for e in std::fs::read_dir(&dir).unwrap() {
        let name = e.unwrap().file_name().into_string().unwrap();
        let shared = ["common.wgsl", "colliders.wgsl", "render.wgsl"];
        if name.ends_with(".wgsl") && !shared.contains(&name.as_str()) {
            assert!(SHADERS.iter().any(|(n, _)| *n == name), "{name} is not in fissure_gpu::SHADERS");
        }
    }
}

#[test]
fn rust_mirrors_match_the_wgsl_struct_sizes() {
    let m = validate("common.wgsl", COMMON_WGSL);
    let size = |name: &str| {
        let (_, ty) = m.types.iter().find(|(_, t)| t.name.as_deref() == Some(name)).unwrap_or_else(|| panic!("{name}"));
        ty.inner.size(m.to_ctx()) as usize
    };
    assert_eq!(size("Params"), size_of::<fissure_gpu::Params>());
    assert_eq!(size("Particle"), size_of::<fissure_gpu::GpuParticle>());
    assert_eq!(size("Spring"), size_of::<fissure_gpu::GpuSpring>());
    assert_eq!(size("Body"), size_of::<fissure_gpu::GpuBody>());
    assert_eq!(size("Collider"), size_of::<fissure_gpu::GpuCollider>());
}

/// `KERNEL_BINDINGS` lists exactly the storage buffers each entry point uses (a kernel given a binding it does not
/// declare would fail at pipeline creation; one given more than it uses would waste a slot of the 8), every entry
/// point is listed, and none uses more than WebGPU's default 8 storage buffers per stage.
#[test]
fn each_kernel_binds_what_it_uses_and_at_most_eight_storage_buffers() {
    let webgpu = fissure_gpu::wgpu::Limits::default().max_storage_buffers_per_shader_stage as usize;
    assert_eq!(webgpu, 8);
    let mut seen = Vec::new();
    for (name, src) in SHADERS {
        let source = shader_source(src);
        let m = naga::front::wgsl::parse_str(&source).unwrap();
        let info =
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), Default::default()).validate(&m).unwrap();
        for (i, ep) in m.entry_points.iter().enumerate() {
            let used = info.get_entry_point(i);
            let mut storage: Vec<u32> = m
                .global_variables
                .iter()
                .filter(|(h, g)| !used[*h].is_empty() && matches!(g.space, naga::AddressSpace::Storage { .. }))
                .map(|(_, g)| g.binding.as_ref().expect("storage is bound").binding)
                .collect();
            storage.sort_unstable();
            let listed = fissure_gpu::KERNEL_BINDINGS
                .iter()
                .find(|(n, _)| *n == ep.name)
                .unwrap_or_else(|| panic!("{name}: {} is not in KERNEL_BINDINGS", ep.name))
                .1;
            assert_eq!(listed, &storage[..], "{name}: {}", ep.name);
            assert!(storage.len() <= webgpu, "{name}: {} binds {} storage buffers", ep.name, storage.len());
            for b in &storage {
                let written = m.global_variables.iter().any(|(_, g)| {
                    g.binding.as_ref().is_some_and(|r| r.binding == *b)
                        && matches!(g.space, naga::AddressSpace::Storage { access } if access.contains(naga::StorageAccess::STORE))
                });
                assert_eq!(written, fissure_gpu::READ_WRITE_BINDINGS.contains(b), "binding {b}");
            }
            seen.push(ep.name.clone());
        }
    }
    assert_eq!(seen.len(), fissure_gpu::KERNEL_BINDINGS.len(), "KERNEL_BINDINGS lists a kernel no file has");
}

/// The value of `const NAME: f32 = VALUE;` in a WGSL source.
fn wgsl_const(src: &str, name: &str) -> f64 {
    let at = src.find(&format!("const {name}: f32 = ")).unwrap_or_else(|| panic!("no const {name}"));
    let rest = &src[at..];
    let value = &rest[rest.find('=').unwrap() + 1..rest.find(';').unwrap()];
    value.trim().parse().unwrap_or_else(|e| panic!("{name}: {value:?}: {e}"))
}

/// The kernels' constants are their Rust twins' (`fissure_core::contact`, `fissure_core::forces::pressure`).
#[test]
fn constants_match_their_rust_twins() {
    let (_, src) = SHADERS.iter().find(|(n, _)| *n == "contact.wgsl").unwrap();
    assert_eq!(wgsl_const(src, "GAMMA"), fissure_core::contact::GAMMA);
    assert_eq!(wgsl_const(src, "RELAX"), fissure_core::contact::RELAX);
    assert_eq!(wgsl_const(src, "PUSH_TIME"), fissure_core::contact::PUSH_TIME);
    let min_volume = wgsl_const(COMMON_WGSL, "MIN_VOLUME_FRACTION");
    assert_eq!(min_volume, fissure_core::forces::pressure::MIN_VOLUME_FRACTION);
}
