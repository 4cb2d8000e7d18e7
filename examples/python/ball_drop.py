"""The seed's Fig. 5 from Python: a pressurised ball drops into a walled room with sphere obstacles.

    python examples/python/ball_drop.py [--frames 240] [--out out/ball_drop]

Writes positions per frame to OUT/frames.npz (`positions`: (frames, N, 3) float32, `triangles`, `time`) and, if
matplotlib is installed, a plot of volume and energy over time to OUT/ball_drop.png.
"""

import argparse
import os

import numpy as np

import fissure

FPS = 60.0


def build() -> fissure.Model:
    b = fissure.ModelBuilder()
    ball = fissure.Mesh.icosphere(0.25, 3).translated((-0.3, 1.6, -0.1))
    b.add_soft_body(ball, mass=0.4, stiffness=2500.0, damping_ratio=0.3, bending=50.0, pressure=2500.0,
                    velocity=(0.8, 0.0, 0.3))
    b.add_ground(restitution=0.3, friction=0.5)
    w = 1.2
    for point, normal in [((w, 0, 0), (-1, 0, 0)), ((-w, 0, 0), (1, 0, 0)), ((0, 0, w), (0, 0, -1)), ((0, 0, -w), (0, 0, 1))]:
        b.add_plane(point, normal, restitution=0.5, friction=0.2)
    for center, radius in [((0.15, 0.3, 0.0), 0.3), ((-0.7, 0.2, 0.5), 0.2), ((0.6, 0.15, -0.6), 0.15)]:
        b.add_ball(center, radius, restitution=0.4, friction=0.3)
    return b.finalize()


def main(frames: int = 240, out: str = "out/ball_drop", dt: float = 1e-4) -> dict:
    model = build()
    world = fissure.World(model)
    n = model.particle_count
    positions = np.empty((frames, n, 3), dtype=np.float32)
    times, volumes, energies = [], [], []
    for f in range(frames):
        world.advance(1.0 / FPS, dt)
        world.state.copy_positions_into(positions[f])
        times.append(world.time)
        volumes.append(model.body_volumes(world.state)[0])
        energies.append(model.energy(world.state)["total"])
        if (f + 1) % 30 == 0 or f + 1 == frames:
            com = model.center_of_mass(world.state)
            print(f"frame {f + 1:4d}  t = {world.time:6.3f} s  centre height {com[1]:.3f} m  volume {volumes[-1]:.5f} m^3")
    os.makedirs(out, exist_ok=True)
    np.savez_compressed(os.path.join(out, "frames.npz"), positions=positions, triangles=model.triangles,
                        time=np.array(times))
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(2, 1, sharex=True, figsize=(6, 5))
        ax[0].plot(times, volumes)
        ax[0].set_ylabel("volume [m³]")
        ax[1].plot(times, energies)
        ax[1].set_ylabel("energy [J]")
        ax[1].set_xlabel("time [s]")
        fig.savefig(os.path.join(out, "ball_drop.png"), dpi=100)
    except ImportError:
        print("matplotlib not installed: no plot")
    lowest = float(positions[:, :, 1].min())
    print(f"lowest particle over the run: {lowest:.5f} m; frames written to {out}/frames.npz")
    return {"lowest": lowest, "positions": positions, "volumes": np.array(volumes)}


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=240)
    ap.add_argument("--out", default="out/ball_drop")
    a = ap.parse_args()
    main(a.frames, a.out)
