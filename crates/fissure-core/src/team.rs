//! A spinning team of helper threads for the passes of mid-sized models.
//!
//! A model below [`crate::par::PAR_MIN`] elements (the pressurised balls of 642 to 10,242 vertices) has passes of
//! 2–30 µs. Handed to rayon's pool, each pass waits for a sleeping worker to wake: on the 2-core development VM
//! that wake-up took microseconds in some minutes and tens in others (the 2,562-vertex ball at 39–45 µs a step
//! or 68–78 µs, flipping on its own; `benches/RESULTS.md`, issue 15, 24e), so those passes ran on the calling
//! thread. Here the helpers are threads of their own that keep spinning between passes (about [`SPIN`] after
//! the last one, then they park): a pass is handed over by one atomic store and picked up within a round trip
//! between the cores. On the development VM that round trip took 45 ns in one hour and 383–402 ns in another
//! (2026-11-25, likely the host placing the two vCPUs apart); there two threads lose to one on these models, so the
//! solver measures which way is faster as it steps ([`Pick`]).
//!
//! Work is claimed piece by piece from one atomic word (the caller from the front, helpers from the end), and
//! every pass cuts its work into the same fixed pieces as without the team: each piece's results are its own, so
//! the bits do not depend on which thread ran it, or on the number of threads. A caller never waits for a helper
//! to arrive: if none does, it runs every piece itself.
//!
//! One team serves the process ([`lease`]): a solver stepping on another thread meanwhile runs its passes as it
//! would without one. The team is used only outside rayon's pool, with a pool of more than one thread (its
//! helpers number the pool's threads less one, at most [`MAX_HELPERS`]): by models below the pool's threshold,
//! and by larger ones where the team has as many threads as the pool ([`covers_pool`]; see
//! `CpuSolver::advance`). On it, the contact pass's searches run in its pieces or on the calling thread
//! (`par::rayon_free`): the helpers never compete with the pool's workers for long.

use std::cell::{Cell, UnsafeCell};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread::Thread;
use std::time::{Duration, Instant};

/// At most this many helpers. Every thread claims pieces from one atomic word: past a few threads the claims
/// contend for its cache line more than the pieces gain, and a larger pool serves large models better (the team
/// serves them only where it has as many threads as the pool: [`covers_pool`]). A judgment, not a measurement:
/// the development VM has two cores (one helper).
const MAX_HELPERS: usize = 3;

/// How long a helper keeps spinning after the last piece it saw before it parks.
const SPIN: Duration = Duration::from_millis(2);

type Job = *const (dyn Fn(usize) + Sync);

struct Shared {
    /// The current pass's unclaimed pieces `front .. end`: `end` in the high 32 bits, `front` in the low.
    state: AtomicU64,
    /// Pieces of the current pass finished.
    done: AtomicU32,
    /// The current pass's function; written only while no piece can be claimed (see [`Team::run`]).
    job: UnsafeCell<Option<Job>>,
    /// A piece panicked (its pass then panics on the caller's thread).
    panicked: AtomicBool,
    /// Helpers parked.
    parked: AtomicUsize,
    /// Park at once instead of spinning out [`SPIN`] (see [`rest`]); cleared by the next pass.
    rest: AtomicBool,
}

// SAFETY: `job` is written by the team's one caller between passes, when every piece of the last pass is done
// and no piece of the next can be claimed yet; helpers read it only after claiming a piece (see `Team::run`).
unsafe impl Sync for Shared {}
unsafe impl Send for Shared {}

/// The process's team: its shared state, its helpers, and whether a caller holds it.
pub(crate) struct Team {
    shared: Arc<Shared>,
    helpers: Vec<Thread>,
    held: AtomicBool,
}

static TEAM: OnceLock<Option<Team>> = OnceLock::new();

thread_local! {
    /// Whether this thread holds the team (its passes go to it).
    static HELD: Cell<bool> = const { Cell::new(false) };
}

/// Holding the team: passes on this thread go to it until this is dropped.
pub(crate) struct Lease(&'static Team);

impl Drop for Lease {
    fn drop(&mut self) {
        HELD.with(|h| h.set(false));
        self.0.held.store(false, Ordering::Release);
    }
}

impl Lease {
    /// Runs `f` with this thread's passes off the team (inline or on rayon's pool, as without one), keeping the
    /// lease (see [`Pick`]).
    pub(crate) fn without<T>(&self, f: impl FnOnce() -> T) -> T {
        HELD.with(|h| h.set(false));
        let out = f();
        HELD.with(|h| h.set(true));
        out
    }
}

/// Whether the team pays, measured as the steps run. Two threads are faster only where the cores answer each
/// other quickly: on the development VM a round trip between its two vCPUs took 45 ns in some hours and 383 ns in
/// others (2026-11-25), and then the 642-vertex ball took 26.6 µs a step on the team against 17.8 on one
/// thread. So the solver times both ways and uses the faster: the other is timed again
/// for [`Pick::TRY`] steps in every [`Pick::PERIOD`]. The choice changes no bits (the team gives one thread's).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Pick {
    /// The last [`Pick::TRY`] step times \[s\] inline (`[0]`) and on the team (`[1]`), a ring each…
    ring: [[f32; Pick::TRY as usize]; 2],
    /// …how many each holds, and where the next goes.
    len: [usize; 2],
    pos: [usize; 2],
    /// Whether the team was the faster at the last comparison (the medians of the rings: one step in a few
    /// hundred meets a preemption or an interrupt on the VM, and a mean would follow it).
    team_best: bool,
    steps: u64,
    /// The way the last steps went (a switch's first step is left out: see [`Pick::record`]).
    last: Option<bool>,
    /// A way set from outside (benchmarks that compare models: see `CpuSolver::force_team`); `None`: measured.
    forced: Option<bool>,
}

impl Default for Pick {
    fn default() -> Self {
        Pick {
            ring: [[0.0; Pick::TRY as usize]; 2],
            len: [0; 2],
            pos: [0; 2],
            team_best: true,
            steps: 0,
            last: None,
            forced: None,
        }
    }
}

impl Pick {
    const PERIOD: u64 = 4096;
    const TRY: u64 = 48;

    /// Whether the next steps go to the team, and how many at most before asking again.
    pub(crate) fn choose(&self) -> (bool, usize) {
        if let Some(team) = self.forced {
            return (team, usize::MAX);
        }
        let full = Self::TRY as usize;
        if self.len[1] < full {
            // Measure the team first, then one thread.
            return (true, full - self.len[1]);
        }
        if self.len[0] < full {
            return (false, full - self.len[0]);
        }
        let phase = self.steps % Self::PERIOD;
        if phase < Self::TRY {
            return (!self.team_best, (Self::TRY - phase) as usize);
        }
        (self.team_best, (Self::PERIOD - phase) as usize)
    }

    /// The way the measurements favour, once both ways have been timed (`None` before, or when forced).
    pub(crate) fn chosen(&self) -> Option<bool> {
        (self.forced.is_none() && self.len == [Self::TRY as usize; 2]).then_some(self.team_best)
    }

    /// Steps on the team (`Some(true)`), on one thread or the pool (`Some(false)`), or as measured (`None`).
    pub(crate) fn force(&mut self, team: Option<bool>) {
        self.forced = team;
    }

    /// Records `n` steps on the team (or not) that took `secs`; the first step after a switch is left out (it
    /// may include a helper's wake-up). Compares the two ways when a trial ends, or when both rings first fill.
    pub(crate) fn record(&mut self, team: bool, n: usize, secs: f64) {
        let first_after_switch = self.last.replace(team) != Some(team);
        let full = Self::TRY as usize;
        let was_full = self.len == [full; 2];
        let before = self.steps % Self::PERIOD;
        self.steps += n as u64;
        if !(first_after_switch && n == 1) {
            let k = team as usize;
            self.ring[k][self.pos[k]] = (secs / n as f64) as f32;
            self.pos[k] = (self.pos[k] + 1) % full;
            self.len[k] = (self.len[k] + 1).min(full);
        }
        let after = self.steps % Self::PERIOD;
        let trial_ended = before < Self::TRY && (after >= Self::TRY || after < before);
        if self.len == [full; 2] && (trial_ended || !was_full) {
            self.team_best = median(self.ring[1]) <= median(self.ring[0]);
        }
    }
}

fn median<const N: usize>(mut v: [f32; N]) -> f32 {
    v.sort_unstable_by(f32::total_cmp);
    v[N / 2]
}

/// The team, if it exists (rayon's global pool has more than one thread) and no other thread holds it.
pub(crate) fn lease() -> Option<Lease> {
    let team =
        TEAM.get_or_init(|| Team::start(rayon::current_num_threads().saturating_sub(1).min(MAX_HELPERS))).as_ref()?;
    if HELD.with(|h| h.get()) || team.held.swap(true, Ordering::Acquire) {
        return None;
    }
    HELD.with(|h| h.set(true));
    Some(Lease(team))
}

/// Lets the helpers park now rather than spin for [`SPIN`]: the caller is done stepping for a while
/// (`World::rest`, before a frame is drawn). The next pass wakes them. In the viewer on the fracture scene the
/// helper spun through the first 2 ms of each frame's drawing, and llvmpipe draws on the same two cores: drawing
/// took 11.6 ms a frame against 7.9 with one thread. Correct at any time (at worst a helper parks early), but
/// waking a parked helper costs more than its spinning between back-to-back passes or steps.
pub(crate) fn rest() {
    if let Some(Some(team)) = TEAM.get() {
        team.rest();
    }
}

/// Whether the team has as many threads (its helpers and the caller) as rayon's global pool: then it can serve
/// a model of any size without leaving cores idle that the pool would use.
pub(crate) fn covers_pool() -> bool {
    let pool = rayon::current_num_threads();
    pool.saturating_sub(1).min(MAX_HELPERS) + 1 >= pool
}

/// The team this thread holds, if any.
#[inline]
pub(crate) fn held() -> Option<&'static Team> {
    if HELD.with(|h| h.get()) { TEAM.get().and_then(|t| t.as_ref()) } else { None }
}

/// A pass's unclaimed pieces `front .. end`, in one word.
const fn pack(end: u32, front: u32) -> u64 {
    ((end as u64) << 32) | front as u64
}

impl Shared {
    /// Claims a piece of the current pass and runs it; false if none was left. The caller claims from the front,
    /// helpers (`back`) from the end: each thread works through a contiguous run of pieces until they meet, so a
    /// pass that reads what the pass before wrote (the gather reads the spring forces) can find more of it in its
    /// own core's cache when the model's order is local. (On the balls of `benches/ball.rs` no difference showed
    /// against claiming from one end, 2026-11-25.)
    fn help(&self, back: bool) -> bool {
        let s = self.state.load(Ordering::Acquire);
        let (end, front) = ((s >> 32) as u32, s as u32);
        if front >= end {
            return false;
        }
        let (claimed, piece) = if back { (s - (1 << 32), end - 1) } else { (s + 1, front) };
        if self.state.compare_exchange_weak(s, claimed, Ordering::AcqRel, Ordering::Relaxed).is_err() {
            return true;
        }
        // SAFETY: the piece is claimed, so its pass cannot end (nor `job` change) before `done` counts it; the
        // value read is the one its caller published before the state that the claim saw. (A claim of a state
        // equal to one seen in an earlier pass claims the current pass's piece: the job is read after it.)
        let job = unsafe { (*self.job.get()).expect("a claimed piece has a job") };
        // SAFETY: the caller keeps the function alive until every piece is done.
        let f = unsafe { &*job };
        if catch_unwind(AssertUnwindSafe(|| f(piece as usize))).is_err() {
            self.panicked.store(true, Ordering::Relaxed);
        }
        self.done.fetch_add(1, Ordering::Release);
        true
    }
}

impl Team {
    fn start(helpers: usize) -> Option<Team> {
        if helpers == 0 {
            return None;
        }
        let shared = Arc::new(Shared {
            state: AtomicU64::new(0),
            done: AtomicU32::new(0),
            job: UnsafeCell::new(None),
            panicked: AtomicBool::new(false),
            parked: AtomicUsize::new(0),
            rest: AtomicBool::new(false),
        });
        let mut threads = Vec::with_capacity(helpers);
        for k in 0..helpers {
            let sh = Arc::clone(&shared);
            let spawned = std::thread::Builder::new().name(format!("fissure-team-{k}")).spawn(move || helper(&sh));
            match spawned {
                Ok(h) => threads.push(h.thread().clone()),
                Err(_) => break,
            }
        }
        (!threads.is_empty()).then(|| Team { shared, helpers: threads, held: AtomicBool::new(false) })
    }

    /// See [`rest`].
    fn rest(&self) {
        self.shared.rest.store(true, Ordering::Relaxed);
    }

    /// Runs `f(0) … f(n - 1)`, each once, on this thread and the helpers; returns when all are done. Only the
    /// lease holder calls this (one pass at a time).
    pub(crate) fn run(&self, n: usize, f: &(dyn Fn(usize) + Sync)) {
        let sh = &*self.shared;
        let Ok(n32) = u32::try_from(n) else {
            (0..n).for_each(f);
            return;
        };
        // SAFETY: no piece can be claimed now (the last pass's state is exhausted and every piece of it is done),
        // so no helper reads `job`. The lifetime is erased: this call returns only when every piece is done.
        unsafe { *sh.job.get() = Some(std::mem::transmute::<&(dyn Fn(usize) + Sync), Job>(f)) };
        sh.done.store(0, Ordering::Relaxed);
        sh.rest.store(false, Ordering::Relaxed);
        sh.state.store(pack(n32, 0), Ordering::SeqCst);
        if sh.parked.load(Ordering::SeqCst) > 0 {
            self.helpers.iter().for_each(|t| t.unpark());
        }
        // A pass that a piece starts runs off the team (this one is in progress): not as a nested publish.
        let held = HELD.with(|h| h.replace(false));
        while sh.help(false) {}
        while sh.done.load(Ordering::Acquire) < n32 {
            std::hint::spin_loop();
        }
        HELD.with(|h| h.set(held));
        // SAFETY: as above; clearing it keeps a dangling pointer out of the shared state.
        unsafe { *sh.job.get() = None };
        if sh.panicked.swap(false, Ordering::Relaxed) {
            panic!("a piece of a parallel pass panicked");
        }
    }
}

/// A helper's loop: claim pieces while there are any; spin for [`SPIN`] after the last (or until [`rest`]), then
/// park until a pass is published.
fn helper(sh: &Shared) {
    let mut idle_since = Instant::now();
    let mut spins = 0u32;
    loop {
        if sh.help(true) {
            spins = 0;
            continue;
        }
        spins += 1;
        if !spins.is_multiple_of(1024) {
            std::hint::spin_loop();
            continue;
        }
        if spins == 1024 {
            idle_since = Instant::now();
        }
        if sh.rest.load(Ordering::Relaxed) || (spins > 1024 && idle_since.elapsed() > SPIN) {
            sh.parked.fetch_add(1, Ordering::SeqCst);
            let s = sh.state.load(Ordering::SeqCst);
            if (s as u32) >= (s >> 32) as u32 {
                std::thread::park_timeout(Duration::from_millis(100));
            }
            sh.parked.fetch_sub(1, Ordering::SeqCst);
            spins = 0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{Pick, Team};
    use std::sync::atomic::{AtomicU32, Ordering};

    #[test]
    fn every_piece_runs_once_and_a_panic_reaches_the_caller() {
        let team = Team::start(1).expect("one helper");
        let counts: Vec<AtomicU32> = (0..1000).map(|_| AtomicU32::new(0)).collect();
        for n in [0, 1, 2, 7, 1000] {
            counts.iter().for_each(|c| c.store(0, Ordering::Relaxed));
            team.run(n, &|i| {
                counts[i].fetch_add(1, Ordering::Relaxed);
            });
            assert!(counts.iter().enumerate().all(|(i, c)| c.load(Ordering::Relaxed) == (i < n) as u32), "{n}");
        }
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| team.run(64, &|i| assert!(i != 40))));
        assert!(r.is_err(), "a piece's panic is lost");
        // The team still works after it.
        let sum = AtomicU32::new(0);
        team.run(100, &|i| {
            sum.fetch_add(i as u32, Ordering::Relaxed);
        });
        assert_eq!(sum.load(Ordering::Relaxed), 4950);
    }

    /// After `rest` the helper parks (without it, a helper parks only after `SPIN` idle; the wait here is far
    /// longer, so this checks that it parks, not how soon), and the next pass clears the rest and runs every piece.
    #[test]
    fn a_resting_helper_parks_and_wakes_for_the_next_pass() {
        let team = Team::start(1).expect("one helper");
        for _ in 0..3 {
            team.rest();
            let t0 = std::time::Instant::now();
            while team.shared.parked.load(Ordering::SeqCst) == 0 {
                assert!(t0.elapsed().as_secs() < 10, "the helper never parked");
                std::thread::yield_now();
            }
            assert!(team.shared.rest.load(Ordering::Relaxed));
            let sum = AtomicU32::new(0);
            team.run(10_000, &|i| {
                sum.fetch_add(i as u32, Ordering::Relaxed);
            });
            assert_eq!(sum.load(Ordering::Relaxed), 49_995_000);
            assert!(!team.shared.rest.load(Ordering::Relaxed), "a pass clears the rest");
        }
    }

    /// Steps one at a time for `steps`, the team taking `team` s a step and one thread `one` s, every 100th step
    /// of either way `spike` s (a preemption); returns the share of steps that went to the team.
    fn share(team: f64, one: f64, spike: f64, steps: usize) -> f64 {
        let (mut p, mut on_team) = (Pick::default(), 0);
        for k in 0..steps {
            let (t, _) = p.choose();
            let secs = if k % 100 == 99 {
                spike
            } else if t {
                team
            } else {
                one
            };
            p.record(t, 1, secs);
            on_team += t as usize;
        }
        on_team as f64 / steps as f64
    }

    #[test]
    fn picks_the_faster_way_and_ignores_spikes() {
        let n = 40_000;
        // The faster way gets all but the trials (48 steps in every 4,096, and the first measurements).
        assert!(share(12e-6, 15e-6, 1e-3, n) > 0.98);
        assert!(share(27e-6, 18e-6, 1e-3, n) < 0.02);
        // Equal speeds: either is fine, but the pick must not flap on the spikes into a mean-driven choice.
        let s = share(15e-6, 15e-6, 1e-3, n);
        assert!(!(0.02..=0.98).contains(&s), "flapped: {s}");
    }

    #[test]
    fn follows_a_change_of_machine() {
        // The team faster for 20,000 steps, then slower: the pick turns within a period or two.
        let mut p = Pick::default();
        let mut late_team = 0;
        for k in 0..40_000 {
            let (t, _) = p.choose();
            let secs = match (t, k < 20_000) {
                (true, true) => 12e-6,
                (true, false) => 27e-6,
                (false, _) => 16e-6,
            };
            p.record(t, 1, secs);
            late_team += (t && k >= 30_000) as usize;
        }
        assert!(late_team < 200, "{late_team} of the last 10,000 steps still on the slower team");
    }
}
