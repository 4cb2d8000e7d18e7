//! A spinning team of helper threads for the passes of mid-sized models.
//!
//! A model below [`crate::par::PAR_MIN`] elements (the pressurised balls of 642 to 10,242 vertices) has passes of
//! 2–30 µs. Handed to rayon's pool, each pass waits for a sleeping worker to wake: on the 2-core development VM
//! that wake-up took microseconds in some minutes and tens in others (the 2,562-vertex ball at 39–45 µs a step
//! or 68–78 µs, flipping on its own; `benches/RESULTS.md`, issue 15, 24e), so those passes ran on the calling
//! thread. Here the helpers are threads of their own that keep spinning between passes (about
//! [`SPIN`] after the last one, then they park): a pass is handed over by one atomic store and picked up in
//! about 50 ns (a measured round trip between the VM's two cores: 45 ns, stable across runs).
//!
//! Work is claimed piece by piece from one atomic counter, by whichever thread is free, and every pass cuts its
//! work into the same fixed pieces as without the team: each piece's results are its own, so the bits do not
//! depend on which thread ran it, or on the number of threads. A caller never waits for a helper to arrive: if
//! none does, it runs every piece itself.
//!
//! One team serves the process ([`lease`]): a solver stepping on another thread meanwhile runs its passes as it
//! would without one. The team is used only outside rayon's pool, with a pool of more than one thread (its
//! helpers number the pool's threads less one), and only by models that step without rayon (see
//! `CpuSolver::advance`): its helpers never compete with the pool's workers for long.

use std::cell::{Cell, UnsafeCell};
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};
use std::thread::Thread;
use std::time::{Duration, Instant};

/// How long a helper keeps spinning after the last piece it saw before it parks.
const SPIN: Duration = Duration::from_millis(2);

type Job = *const (dyn Fn(usize) + Sync);

struct Shared {
    /// The current pass: its piece count (high 32 bits) and the next piece to claim (low 32 bits).
    state: AtomicU64,
    /// Pieces of the current pass finished.
    done: AtomicU32,
    /// The current pass's function; written only while no piece can be claimed (see [`Team::run`]).
    job: UnsafeCell<Option<Job>>,
    /// A piece panicked (its pass then panics on the caller's thread).
    panicked: AtomicBool,
    /// Helpers parked.
    parked: AtomicUsize,
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
/// others (2026-11-25; the host placed them apart), and there the 642-vertex ball took 26.6 µs a step on the
/// team against 15 on one thread. So the solver times both ways and uses the faster: the other is timed again
/// for [`Pick::TRY`] steps in every [`Pick::PERIOD`]. The choice changes no bits (the team gives one thread's).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Pick {
    /// Mean step time \[s\] inline and on the team (0: not measured yet).
    mean: [f64; 2],
    steps: u64,
}

impl Pick {
    const PERIOD: u64 = 4096;
    const TRY: u64 = 48;

    /// Whether the next steps go to the team, and how many at most before asking again.
    pub(crate) fn choose(&self) -> (bool, usize) {
        let phase = self.steps % Self::PERIOD;
        let best = self.mean[1] <= self.mean[0];
        if self.mean[1] == 0.0 || self.mean[0] == 0.0 {
            // Measure the one not measured yet (the team first).
            return (self.mean[1] == 0.0, (Self::TRY - phase % Self::TRY) as usize);
        }
        if phase < Self::TRY {
            return (!best, (Self::TRY - phase) as usize);
        }
        (best, (Self::PERIOD - phase) as usize)
    }

    /// Records `n` steps on the team (or not) that took `secs`; the first of a trial is left out (it may include
    /// a helper's wake-up).
    pub(crate) fn record(&mut self, team: bool, n: usize, secs: f64, first_of_trial: bool) {
        self.steps += n as u64;
        if first_of_trial && n == 1 {
            return;
        }
        let per = secs / n as f64;
        let m = &mut self.mean[team as usize];
        *m = if *m == 0.0 { per } else { 0.9 * *m + 0.1 * per };
    }
}

/// The team, if it exists (rayon's global pool has more than one thread) and no other thread holds it.
pub(crate) fn lease() -> Option<Lease> {
    let team = TEAM.get_or_init(|| Team::start(rayon::current_num_threads().saturating_sub(1))).as_ref()?;
    if HELD.with(|h| h.get()) || team.held.swap(true, Ordering::Acquire) {
        return None;
    }
    HELD.with(|h| h.set(true));
    Some(Lease(team))
}

/// The team this thread holds, if any.
#[inline]
pub(crate) fn held() -> Option<&'static Team> {
    if HELD.with(|h| h.get()) { TEAM.get().and_then(|t| t.as_ref()) } else { None }
}

const fn pack(n: u32, next: u32) -> u64 {
    ((n as u64) << 32) | next as u64
}

impl Shared {
    /// Claims a piece of the current pass and runs it; false if none was left.
    fn help(&self) -> bool {
        let s = self.state.load(Ordering::Acquire);
        let (n, next) = ((s >> 32) as u32, s as u32);
        if next >= n {
            return false;
        }
        if self.state.compare_exchange_weak(s, s + 1, Ordering::AcqRel, Ordering::Relaxed).is_err() {
            return true;
        }
        // SAFETY: the piece is claimed, so its pass cannot end (nor `job` change) before `done` counts it; the
        // value read is the one its caller published before the state that the claim saw. (A claim of a state
        // equal to one seen in an earlier pass claims the current pass's piece: the job is read after it.)
        let job = unsafe { (*self.job.get()).expect("a claimed piece has a job") };
        // SAFETY: the caller keeps the function alive until every piece is done.
        let f = unsafe { &*job };
        if catch_unwind(AssertUnwindSafe(|| f(next as usize))).is_err() {
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
        sh.state.store(pack(n32, 0), Ordering::SeqCst);
        if sh.parked.load(Ordering::SeqCst) > 0 {
            self.helpers.iter().for_each(|t| t.unpark());
        }
        while sh.help() {}
        while sh.done.load(Ordering::Acquire) < n32 {
            std::hint::spin_loop();
        }
        // SAFETY: as above; clearing it keeps a dangling pointer out of the shared state.
        unsafe { *sh.job.get() = None };
        if sh.panicked.swap(false, Ordering::Relaxed) {
            panic!("a piece of a parallel pass panicked on a helper thread");
        }
    }
}

/// A helper's loop: claim pieces while there are any; spin for [`SPIN`] after the last, then park until a pass
/// is published.
fn helper(sh: &Shared) {
    let mut idle_since = Instant::now();
    let mut spins = 0u32;
    loop {
        if sh.help() {
            spins = 0;
            continue;
        }
        spins += 1;
        if spins % 1024 != 0 {
            std::hint::spin_loop();
            continue;
        }
        if spins == 1024 {
            idle_since = Instant::now();
        } else if idle_since.elapsed() > SPIN {
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
