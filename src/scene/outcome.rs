//! Outcomes: what a headless run of a scene came to, one row of `fissure sweep`'s table and of Python's
//! `run_many`, and [`run_all`], which runs many scenes in parallel.
//!
//! Each run is one [`World`] on one thread (the runs share nothing), so a run's outcome is bit-identical whether
//! it ran alone, in a batch, or on any number of threads: the CPU solver's own parallel passes split work in
//! fixed chunks. A run that fails (a scene error, a state that blew up) is an outcome with its error and the
//! values it had reached, never a panic or a lost batch.

use super::{Override, Scene};
use crate::World;
use fissure_core::*;
use std::path::PathBuf;
use std::time::Instant;

/// What a run came to. Values are those at the end of the run, or at the step that failed.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Outcome {
    /// Simulated time \[s\].
    pub simulated: f64,
    /// Steps taken.
    pub steps: usize,
    /// Spring splits (cracks advancing).
    pub spring_events: usize,
    /// Core blocks broken out (punctures).
    pub core_events: usize,
    /// Pieces detached as new bodies.
    pub detach_events: usize,
    /// Bodies at the end.
    pub bodies: usize,
    /// Connected pieces at the end (particles joined by springs).
    pub pieces: usize,
    /// Particles at the end.
    pub particles: usize,
    /// Triangles at the end.
    pub triangles: usize,
    /// Gas volume at the start, summed over gas bodies \[m^3\] (0 without gas).
    pub initial_gas_volume: f64,
    /// Gas volume at the end \[m^3\].
    pub gas_volume: f64,
    /// Wall-clock time of the run \[s\] (building the world included).
    pub wall: f64,
    /// Why the run failed, if it did.
    pub error: Option<String>,
}

impl Outcome {
    /// The counts and volumes of `world` now (wall time and error left at their defaults).
    pub fn of<R: Real>(world: &World<R>) -> Outcome {
        let count = |k: FractureKind| world.events.iter().filter(|e| e.kind == k).count();
        let m = &world.model;
        Outcome {
            simulated: world.state.time,
            spring_events: count(FractureKind::Spring),
            core_events: count(FractureKind::Core),
            detach_events: count(FractureKind::Detach),
            bodies: m.body_count(),
            pieces: m.components().0,
            particles: m.particle_count(),
            triangles: m.tri_count(),
            gas_volume: gas_volume(world),
            ..Outcome::default()
        }
    }

    /// A run that failed before it started.
    pub fn failed(error: impl std::fmt::Display) -> Outcome {
        Outcome { error: Some(error.to_string()), ..Outcome::default() }
    }

    /// All fracture events.
    pub fn events(&self) -> usize {
        self.spring_events + self.core_events + self.detach_events
    }
}

fn gas_volume<R: Real>(world: &World<R>) -> f64 {
    let m = &world.model;
    let v = m.body_volumes(&world.state);
    v.iter().zip(&m.body_rest_volume).filter(|(_, rest)| rest.to_f64() > 0.0).map(|(v, _)| v).sum()
}

/// One run: a scene file, overrides, and how long to simulate.
#[derive(Clone, Debug, PartialEq)]
pub struct Job {
    /// The scene file.
    pub scene: PathBuf,
    /// Overrides of its keys.
    pub overrides: Vec<Override>,
    /// Simulated time \[s\]; `None`: the scene's `duration`.
    pub duration: Option<f64>,
}

impl Scene {
    /// Builds this scene's world and runs it headless on the CPU for `duration` \[s\] (default: the scene's
    /// `duration`) in steps of its `dt`. Never fails: an error is in the outcome.
    pub fn run_headless<R: Real>(&self, duration: Option<f64>) -> Outcome {
        let start = Instant::now();
        let mut out = match self.world::<R>() {
            Err(e) => Outcome::failed(e),
            Ok(mut world) => {
                let initial = gas_volume(&world);
                let run = world.advance(duration.unwrap_or(self.solver.duration), self.solver.dt);
                let mut o = Outcome::of(&world);
                o.initial_gas_volume = initial;
                o.steps = run.as_ref().map_or(0, |a| a.steps);
                o.error = run.err().map(|e| e.to_string());
                o
            }
        };
        out.wall = start.elapsed().as_secs_f64();
        out
    }
}

impl Job {
    /// Loads the scene with its overrides and runs it (see [`Scene::run_headless`]).
    pub fn run<R: Real>(&self) -> Outcome {
        let start = Instant::now();
        match Scene::load_with(&self.scene, &self.overrides) {
            Ok(scene) => scene.run_headless::<R>(self.duration),
            Err(e) => Outcome { wall: start.elapsed().as_secs_f64(), ..Outcome::failed(e) },
        }
    }
}

/// Runs every job in parallel, at most `threads` at a time (`None`: one per core), and returns the outcomes in
/// the jobs' order. Each job runs on one thread, so its outcome does not depend on `threads`.
pub fn run_all<R: Real>(jobs: &[Job], threads: Option<usize>) -> Vec<Outcome> {
    run_all_reporting::<R>(jobs, threads, &|_, _| {})
}

/// [`run_all`], calling `done(k, outcome)` from the worker thread as each job `k` finishes (for progress output).
pub fn run_all_reporting<R: Real>(
    jobs: &[Job],
    threads: Option<usize>,
    done: &(dyn Fn(usize, &Outcome) + Sync),
) -> Vec<Outcome> {
    let mut jobs: Vec<(usize, &Job)> = jobs.iter().enumerate().collect();
    parallel(&mut jobs, threads, |(k, job)| {
        let o = job.run::<R>();
        done(*k, &o);
        o
    })
}

/// Advances every world by `duration` \[s\] in steps of `dt` \[s\] in parallel, at most `threads` at a time, and
/// returns their outcomes (each world's state is left where its run ended). As [`run_all`], a world's result does
/// not depend on `threads`.
pub fn advance_all<R: Real>(
    worlds: &mut [&mut World<R>],
    duration: f64,
    dt: f64,
    threads: Option<usize>,
) -> Vec<Outcome> {
    parallel(worlds, threads, |w| {
        let start = Instant::now();
        let initial = gas_volume(w);
        let run = w.advance(duration, dt);
        Outcome {
            steps: run.as_ref().map_or(0, |a| a.steps),
            error: run.err().map(|e| e.to_string()),
            initial_gas_volume: initial,
            wall: start.elapsed().as_secs_f64(),
            ..Outcome::of(w)
        }
    })
}

/// `f` of every item on `threads` threads (one per core for `None`), results in the items' order. A panic in
/// `f` (a bug) becomes a failed outcome rather than taking the batch down.
fn parallel<T: Send>(items: &mut [T], threads: Option<usize>, f: impl Fn(&mut T) -> Outcome + Sync) -> Vec<Outcome> {
    let threads = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get())).max(1);
    let n = items.len();
    let queue = std::sync::Mutex::new(items.iter_mut().enumerate());
    let results = std::sync::Mutex::new(vec![None; n]);
    std::thread::scope(|s| {
        for _ in 0..threads.min(n) {
            s.spawn(|| {
                loop {
                    let next = queue.lock().unwrap_or_else(|e| e.into_inner()).next();
                    let Some((k, item)) = next else { break };
                    let o = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| f(item)))
                        .unwrap_or_else(|_| Outcome::failed("the run panicked (a bug: please report it)"));
                    results.lock().unwrap_or_else(|e| e.into_inner())[k] = Some(o);
                }
            });
        }
    });
    let results = results.into_inner().unwrap_or_else(|e| e.into_inner());
    results.into_iter().map(|o| o.unwrap_or_else(|| Outcome::failed("not run"))).collect()
}
