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


def long_enough(make_work, steps=1500, seconds=0.2, tries=5):
    """Runs `make_work(steps)` under `spins_during`, doubling `steps` until it takes `seconds`.

    A faster solver (or machine) must not turn this test into one that measures nothing: the
    GIL check needs the work to last long enough for the spinning thread to count."""
    for _ in range(tries):
        result, during, elapsed = spins_during(lambda: make_work(steps))
        if elapsed >= seconds:
            return result, during, elapsed, steps
        steps *= 2
    raise AssertionError(f"{steps // 2} steps took only {elapsed:.3f} s: the work is too short to measure")


def test_other_threads_run_while_stepping():
    b = fissure.ModelBuilder()
    b.add_cloth_grid(96, 96, 0.01, particle_mass=1e-3, pins=[0, 95])
    model = b.finalize()
    state = model.state()
    solver = fissure.Solver()
    _, during, elapsed, _ = long_enough(lambda n: solver.step(model, state, 2e-4, steps=n))
    # With the GIL held, the spinning thread would be starved for the whole step (at most a few switches).
    assert during > 10000, f"only {during} increments in {elapsed:.2f} s: the GIL was not released"


def test_other_threads_run_during_run_many():
    """run_many runs its worlds on Rust threads with the GIL released."""
    def worlds():
        out = []
        for _ in range(2):
            b = fissure.ModelBuilder()
            b.add_cloth_grid(64, 64, 0.01, particle_mass=1e-3, pins=[0, 63])
            out.append(fissure.World(b.finalize()))
        return out

    out, during, elapsed, steps = long_enough(lambda n: fissure.run_many(worlds(), duration=n * 2e-4, dt=2e-4))
    assert out["ok"].all() and out["steps"].tolist() == [steps, steps]
    assert during > 10000, f"only {during} increments in {elapsed:.2f} s: the GIL was not released"


def test_rest_between_advances_changes_nothing():
    """World.rest lets the helper threads sleep (before drawing a frame); the steps after it give the same bits."""

    def run(rest):
        b = fissure.ModelBuilder()
        b.add_soft_body(fissure.Mesh.icosphere(0.25, 3).translated((0.0, 0.35, 0.0)), mass=0.4, pressure=2000.0)
        b.add_ground(0.0)
        w = fissure.World(b.finalize())
        for _ in range(20):
            w.advance(1 / 120, 1e-4)
            if rest:
                w.rest()
        return w.state.positions.copy()

    a, b = run(False), run(True)
    assert a[:, 1].min() < 0.02, "the ball (its bottom 0.1 m up) should have fallen onto the ground"
    assert (a == b).all()
