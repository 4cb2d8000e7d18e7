"""The GIL is released while stepping: another Python thread runs during a long step and during run_many."""

import threading
import time

import fissure


def spins_during(work):
    """Runs `work()` while another thread counts; returns (its result, increments during it, seconds)."""
    counter = [0]
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            counter[0] += 1

    worker = threading.Thread(target=spin)
    worker.start()
    time.sleep(0.05)
    start = counter[0]
    t0 = time.perf_counter()
    result = work()
    elapsed = time.perf_counter() - t0
    during = counter[0] - start
    stop.set()
    worker.join()
    return result, during, elapsed


def test_other_threads_run_while_stepping():
    b = fissure.ModelBuilder()
    b.add_cloth_grid(96, 96, 0.01, particle_mass=1e-3, pins=[0, 95])
    model = b.finalize()
    state = model.state()
    solver = fissure.Solver()
    _, during, elapsed = spins_during(lambda: solver.step(model, state, 2e-4, steps=1500))
    assert elapsed > 0.1, "the step should take long enough to measure"
    # With the GIL held, the spinning thread would be starved for the whole step (at most a few switches).
    assert during > 10000, f"only {during} increments in {elapsed:.2f} s: the GIL was not released"


def test_other_threads_run_during_run_many():
    """run_many runs its worlds on Rust threads with the GIL released."""
    worlds = []
    for _ in range(2):
        b = fissure.ModelBuilder()
        b.add_cloth_grid(64, 64, 0.01, particle_mass=1e-3, pins=[0, 63])
        worlds.append(fissure.World(b.finalize()))
    out, during, elapsed = spins_during(lambda: fissure.run_many(worlds, duration=0.3, dt=2e-4))
    assert out["ok"].all() and out["steps"].tolist() == [1500, 1500]
    assert elapsed > 0.1, "the batch should take long enough to measure"
    assert during > 10000, f"only {during} increments in {elapsed:.2f} s: the GIL was not released"
