//! "No allocation per step": after the first step sized the buffers, stepping allocates nothing. Checked with
//! a counting global allocator, for every integrator, on a model with every term (gas, wind, colliders of all
//! kinds, pins). The model is below the parallel threshold so rayon's own job queues are not measured, and only
//! the stepping thread's allocations count: the test harness's main thread allocates now and then while the test
//! runs (this made the test fail about one run in six before).

use fissure_core::glam::{DVec3, Vec3};
use fissure_core::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;
static ALLOCS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Set on the thread whose allocations count (a const-initialised cell: reading it never allocates).
    static COUNTED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn count() {
    if COUNTED.try_with(|c| c.get()).unwrap_or(false) {
        ALLOCS.fetch_add(1, Ordering::Relaxed);
    }
}

// SAFETY: forwards to the system allocator, only counting calls.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, n: usize) -> *mut u8 {
        count();
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(p, l, n) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn steps_do_not_allocate() {
    COUNTED.with(|c| c.set(true));
    let mut b = ModelBuilder::new();
    b.add_soft_body(
        &Mesh::icosphere(0.2, 2).translated(DVec3::new(0.0, 0.5, 0.0)),
        &SoftBodyOptions { aero: Aero::default(), ..Default::default() },
    )
    .unwrap();
    b.add_cloth_grid(
        20,
        20,
        0.02,
        |p| DVec3::new(p.x, 1.0, p.y),
        &ClothOptions { pins: vec![0, 19], ..Default::default() },
    )
    .unwrap();
    b.wind(WindField::default()).unwrap();
    b.add_collider(Collider::ground(0.0)).unwrap();
    b.add_collider(Collider::ball(Vec3::new(0.0, 0.2, 0.0), 0.1)).unwrap();
    b.add_collider(Collider::cuboid(Vec3::new(0.5, 0.1, 0.0), Vec3::splat(0.1))).unwrap();
    b.add_collider(Collider::capsule(Vec3::ZERO, Vec3::X, 0.05)).unwrap();
    b.add_collider(Collider::trimesh(&Mesh::icosphere(0.1, 1).translated(DVec3::new(-0.5, 0.1, 0.0))).unwrap())
        .unwrap();
    let model: Model<f32> = b.finalize().unwrap();
    for integrator in Integrator::ALL {
        let mut s = model.state();
        let mut solver = CpuSolver::<f32>::with_integrator(integrator);
        let dt = if integrator == Integrator::ImplicitEuler { 1e-3 } else { 5e-5 };
        solver.step(&model, &mut s, dt).unwrap();
        let before = ALLOCS.load(Ordering::Relaxed);
        for _ in 0..20 {
            solver.step(&model, &mut s, dt).unwrap();
        }
        let n = ALLOCS.load(Ordering::Relaxed) - before;
        assert_eq!(n, 0, "{}: {n} allocations in 20 steps", integrator.name());
    }
}
