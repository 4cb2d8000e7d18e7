"""The seed's Fig. 6 from Python: a pressurised ball breaks on obstacles and deflates (the same scene as
scenes/fracture.toml).

    python examples/python/fracture.py [--duration 1.5]

Prints a line per 0.1 s (fracture events, openings, volume, gas), then the first events.
"""

import argparse

import fissure

FPS = 60.0


def build() -> fissure.Model:
    b = fissure.ModelBuilder()
    ball = fissure.Mesh.icosphere(0.25, 3).translated((-0.1, 1.3, 0.0))
    b.add_soft_body(ball, mass=0.4, stiffness=2500.0, damping_ratio=0.3, bending=50.0, pressure=3000.0,
                    velocity=(0.6, -4.0, 0.2), strain_limit=0.3, load_limit=3.0)
    b.add_ground(restitution=0.3, friction=0.5)
    w = 1.2
    for point, normal in [((w, 0, 0), (-1, 0, 0)), ((-w, 0, 0), (1, 0, 0)), ((0, 0, w), (0, 0, -1)), ((0, 0, -w), (0, 0, 1))]:
        b.add_plane(point, normal, restitution=0.5, friction=0.2)
    for center, radius in [((0.15, 0.3, 0.0), 0.3), ((-0.7, 0.2, 0.5), 0.2), ((0.6, 0.15, -0.6), 0.15)]:
        b.add_ball(center, radius, restitution=0.4, friction=0.3)
    return b.finalize()


def main(duration: float = 1.5, dt: float = 2e-4) -> dict:
    model = build()
    world = fissure.World(model, max_events_per_step=8, start_time=0.05)
    gas0 = None
    volume_at_puncture = None
    frames = round(duration * FPS)
    for f in range(frames):
        world.advance(1.0 / FPS, dt)
        volume = model.body_volumes(world.state)[0]
        if volume_at_puncture is None and world.events:
            volume_at_puncture = volume
        if gas0 is None:
            gas0 = model.body_pressures(world.state)[0] * volume
        if (f + 1) % 6 == 0 or f + 1 == frames:
            print(f"t = {world.time:6.3f} s  events {len(world.events):4d}  bodies {model.body_count:4d}  "
                  f"volume {volume * 1e3:7.2f} l")
    events = world.events
    for e in events[:8]:
        x, y, z = e["position"]
        print(f"  t = {e['time']:.4f} s  {e['kind']:<6} at ({x:6.3f}, {y:6.3f}, {z:6.3f})  body {e['body']}")
    kinds = [e["kind"] for e in events]
    print(f"{len(events)} events: {kinds.count('spring')} spring, {kinds.count('core')} core, "
          f"{kinds.count('detach')} detach; fracture stage {world.timers()['fracture']:.3f} s")
    return {
        "events": events,
        "bodies": model.body_count,
        "volume_at_puncture": volume_at_puncture,
        "volume_end": model.body_volumes(world.state)[0],
    }


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--duration", type=float, default=1.5)
    a = ap.parse_args()
    main(duration=a.duration)
