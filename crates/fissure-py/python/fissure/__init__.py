"""fissure: soft bodies that stretch, inflate, collide and tear.

A mass-spring system built from a triangle surface mesh, the closed pressure model (P = nRT / V), wind, colliders
and four integrators, in Rust. Units are SI: metres, kilograms, seconds, newtons, pascals.

    import fissure
    b = fissure.ModelBuilder()
    b.add_soft_body(fissure.Mesh.icosphere(0.25, 3).translated((0, 1.5, 0)), mass=0.4, pressure=2500.0)
    b.add_ground()
    world = fissure.World(b.finalize())
    world.advance(1.0, 1e-4)
    print(world.state.positions.mean(axis=0))
"""

from ._fissure import (
    DampingModel,
    Integrator,
    Mesh,
    Model,
    ModelBuilder,
    Solver,
    State,
    World,
    __version__,
    load_scene,
    run_many,
)

__all__ = [
    "DampingModel",
    "Integrator",
    "Mesh",
    "Model",
    "ModelBuilder",
    "Solver",
    "State",
    "World",
    "load_scene",
    "run_many",
    "__version__",
]
