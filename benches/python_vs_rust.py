"""Cost of stepping from Python against the same steps from Rust (issue: Python bindings).

    cargo build --release --example cloth_steps && python benches/python_vs_rust.py

The 128 x 128 benchmark cloth, 1000 steps, minimum of 7 repetitions after 200 warm-up steps, on both sides:
`Solver.step(model, state, dt, steps=1000)` (one call, GIL released) and 1000 calls of `steps=1` (per-call
overhead included), against `target/release/examples/cloth_steps`.
"""

import pathlib
import re
import subprocess
import time

import fissure

ROOT = pathlib.Path(__file__).resolve().parents[1]


def cloth():
    n = 128
    b = fissure.ModelBuilder()
    # Rows along -z, like the Rust bench's |p| (p.x, 1.0, p.y).
    b.add_cloth_grid(n, n, 0.01, origin=(0.0, 1.0, 0.0), down=(0.0, 0.0, -1.0), particle_mass=1e-3,
                     spring_stiffness=1000.0, shear=1000.0, bending=1000.0, spring_damping=0.01, pins=[0, n - 1],
                     drag=0.0, lift=0.0)
    return b.finalize()


def best_of(f, reps=7):
    best = float("inf")
    for _ in range(reps):
        t = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t)
    return best


def main():
    model = cloth()
    assert model.spring_count == 97026, model.spring_count
    state = model.state()
    solver = fissure.Solver()
    solver.step(model, state, 2e-4, steps=200)
    one_call = best_of(lambda: solver.step(model, state, 2e-4, steps=1000))

    def per_step():
        for _ in range(1000):
            solver.step(model, state, 2e-4)

    many_calls = best_of(per_step)
    exe = ROOT / "target" / "release" / "examples" / "cloth_steps"
    rust = None
    if exe.exists():
        out = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout
        rust = float(re.search(r"rust: ([0-9.]+) ms", out).group(1)) / 1e3
    print(f"python, one call of 1000 steps : {one_call * 1e3:8.1f} ms")
    print(f"python, 1000 calls of 1 step   : {many_calls * 1e3:8.1f} ms")
    if rust is not None:
        print(f"rust,   1000 steps             : {rust * 1e3:8.1f} ms")
        print(f"overhead: one call {100 * (one_call / rust - 1):+.1f}%, per-step calls {100 * (many_calls / rust - 1):+.1f}%")
    else:
        print("build the Rust reference first: cargo build --release --example cloth_steps")


if __name__ == "__main__":
    main()
