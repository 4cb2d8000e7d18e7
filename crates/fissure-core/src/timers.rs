//! Time spent per stage of the step, accumulated until reset. A stage that has nothing to do is never entered
//! and shows zero time and zero calls, which is how tests check that a scene pays only for what it uses.

use std::fmt;
use std::time::Duration;

/// The clock of the stage timers: `std::time::Instant`, except on wasm32-unknown-unknown, where std has no clock
/// (its `Instant::now` panics) and the browser's `performance.now()` stands in (the `web-time` crate).
#[cfg(not(all(target_arch = "wasm32", target_os = "unknown")))]
pub use std::time::Instant;
#[cfg(all(target_arch = "wasm32", target_os = "unknown"))]
pub use web_time::Instant;

/// The named, ordered stages of a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Per-spring forces (seed eqs. 1–2). On cloth grids under symplectic Euler the update of each particle is
    /// fused into this pass (see `CpuSolver`), and `Integrate` then shows no calls.
    Springs,
    /// Per-triangle pass: volumes, pressure (seed eqs. 6–9) and wind.
    Surface,
    /// Per-particle gather of forces and the integrator's update (seed eqs. 3–5).
    Integrate,
    /// Implicit Euler's linear solve (conjugate gradients).
    Solve,
    /// Collision detection and response against colliders.
    Collide,
    /// Contact between surfaces (bodies against each other and themselves; see the `contact` module).
    Contact,
    /// Fracture: strain and load checks, splits, openings and the gas leak (between steps).
    Fracture,
}

impl Stage {
    /// All stages in step order.
    pub const ALL: [Stage; 7] = [
        Stage::Springs,
        Stage::Surface,
        Stage::Integrate,
        Stage::Solve,
        Stage::Collide,
        Stage::Contact,
        Stage::Fracture,
    ];

    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Springs => "springs",
            Stage::Surface => "surface",
            Stage::Integrate => "integrate",
            Stage::Solve => "solve",
            Stage::Collide => "collide",
            Stage::Contact => "contact",
            Stage::Fracture => "fracture",
        }
    }
}

/// Accumulated wall time and call count per [`Stage`], and steps taken.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StageTimers {
    time: [Duration; 7],
    calls: [u64; 7],
    /// Steps accumulated.
    pub steps: u64,
    /// Total step time.
    pub total: Duration,
}

impl StageTimers {
    /// Adds the time since `since` to `stage`.
    #[inline]
    pub fn add(&mut self, stage: Stage, since: Instant) {
        self.time[stage as usize] += since.elapsed();
        self.calls[stage as usize] += 1;
    }
    /// Adds `d` to `stage` (a stage timed in pieces inside another's pass, or on a device).
    #[inline]
    pub fn add_time(&mut self, stage: Stage, d: Duration) {
        self.time[stage as usize] += d;
        self.calls[stage as usize] += 1;
    }
    /// Total time in `stage`.
    pub fn time(&self, stage: Stage) -> Duration {
        self.time[stage as usize]
    }
    /// Times `stage` was entered.
    pub fn calls(&self, stage: Stage) -> u64 {
        self.calls[stage as usize]
    }
    /// Adds `other`'s stage times and calls (not its steps or total) to these.
    pub fn merge_stages(&mut self, other: &StageTimers) {
        for k in 0..self.time.len() {
            self.time[k] += other.time[k];
            self.calls[k] += other.calls[k];
        }
    }
    /// Clears everything.
    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

impl fmt::Display for StageTimers {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let steps = self.steps.max(1) as f64;
        writeln!(f, "{:<10} {:>12} {:>10} {:>8}", "stage", "µs/step", "calls", "share")?;
        let total = self.total.as_secs_f64().max(1e-12);
        for s in Stage::ALL {
            let t = self.time(s).as_secs_f64();
            writeln!(
                f,
                "{:<10} {:>12.2} {:>10} {:>7.1}%",
                s.name(),
                t * 1e6 / steps,
                self.calls(s),
                100.0 * t / total
            )?;
        }
        write!(f, "{:<10} {:>12.2} {:>10}", "total", total * 1e6 / steps, self.steps)
    }
}
