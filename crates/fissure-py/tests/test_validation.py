"""Every value the core rejects raises ValueError naming the keyword to change (the bindings translate the
core's errors; they do no range checks of their own), and the rejected call changes nothing."""

import math

import pytest

import fissure

NAN = math.nan


def ball_builder():
    b = fissure.ModelBuilder()
    b.add_soft_body(fissure.Mesh.icosphere(0.2, 1), mass=0.1, pressure=1000.0)
    return b


@pytest.mark.parametrize("radius", [NAN, -0.1, 0.0, math.inf])
def test_bad_radius_names_radius(radius):
    b = ball_builder()
    with pytest.raises(ValueError, match="radius"):
        b.add_ball((0, 0, 0), radius)
    with pytest.raises(ValueError, match="radius"):
        b.add_capsule((0, 0, 0), (1, 0, 0), radius)


def test_zero_normal_names_normal():
    with pytest.raises(ValueError, match="normal"):
        ball_builder().add_plane((0, 0, 0), (0, 0, 0))


def test_bad_collider_values_name_their_keyword():
    b = ball_builder()
    with pytest.raises(ValueError, match="restitution"):
        b.add_ground(restitution=1.5)
    with pytest.raises(ValueError, match="friction"):
        b.add_ground(friction=NAN)
    with pytest.raises(ValueError, match="center"):
        b.add_ball((NAN, 0, 0), 1.0)
    with pytest.raises(ValueError, match="height"):
        b.add_ground(NAN)
    with pytest.raises(ValueError, match="half_extents"):
        b.add_cuboid((0, 0, 0), (1, 0, 1))


@pytest.mark.parametrize("pressure", [NAN, -5.0, math.inf])
def test_bad_pressure_names_pressure(pressure):
    b = fissure.ModelBuilder()
    with pytest.raises(ValueError, match="pressure"):
        b.add_soft_body(fissure.Mesh.icosphere(0.2, 1), pressure=pressure)
    assert b.particle_count == 0


@pytest.mark.parametrize("mass", [-1.0, NAN, 0.0])
def test_bad_mass_names_mass(mass):
    b = fissure.ModelBuilder()
    with pytest.raises(ValueError, match="mass"):
        b.add_soft_body(fissure.Mesh.icosphere(0.2, 1), mass=mass)
    assert b.particle_count == 0


def test_nan_wind_names_its_keyword():
    b = ball_builder()
    with pytest.raises(ValueError, match="velocity"):
        b.set_wind((NAN, 0, 0))
    with pytest.raises(ValueError, match="air_density"):
        b.set_wind((1, 0, 0), air_density=0.0)
    with pytest.raises(ValueError, match="gravity"):
        fissure.ModelBuilder(gravity=(0, NAN, 0))


@pytest.mark.parametrize("dt", [0.0, -1e-4, NAN])
def test_non_positive_dt_names_dt(dt):
    world = fissure.World(ball_builder().finalize())
    before = world.state.positions.copy()
    with pytest.raises(ValueError, match="dt"):
        world.step(dt)
    with pytest.raises(ValueError, match="dt"):
        world.advance(0.01, dt)
    assert (world.state.positions == before).all() and world.time == 0.0


def test_bad_solver_and_fracture_settings_name_their_keyword():
    model = ball_builder().finalize()
    with pytest.raises(ValueError, match="cg_tolerance"):
        fissure.Solver(cg_tolerance=NAN)
    with pytest.raises(ValueError, match="substep_safety"):
        fissure.World(model, substep_safety=1.5)
    with pytest.raises(ValueError, match="gas_density"):
        fissure.World(model, gas_density=0.0)
    with pytest.raises(ValueError, match="averaged_window"):
        fissure.World(model, averaged_window=-1.0)


def test_the_python_world_steps_through_the_rust_world():
    """The live objects stay shared: stepping the world moves `world.state`, a fracture grows `world.model`."""
    b = fissure.ModelBuilder()
    b.add_soft_body(fissure.Mesh.icosphere(0.2, 2).translated((0, 1, 0)), mass=0.2, pressure=2000.0)
    b.add_ground()
    world = fissure.World(b.finalize())
    model, state = world.model, world.state
    n = model.particle_count
    world.advance(0.05, 1e-4)
    assert abs(state.time - 0.05) < 1e-9 and state.positions[:, 1].mean() < 1.0
    events = world.break_core(10)
    assert events and events[0]["kind"] == "core"
    assert model.particle_count > n and state.particle_count == model.particle_count
