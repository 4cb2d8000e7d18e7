"""Moving pins, tear strength and the gas pump from Python: handles follow their path, a strip pulled apart by
two handles tears through at its tear strength, a pumped balloon's gas grows; bad settings are errors that name
the argument."""

import numpy as np
import pytest

import fissure


def strip(nx=17, ny=9, spacing=0.0125, speed=0.02, tear=20.0):
    """A strip in the xy plane, its left and right columns on handles that pull apart at `speed` [m/s] each."""
    b = fissure.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    h = b.add_cloth_grid(
        nx, ny, spacing, area_density=0.5, spring_stiffness=1000.0, shear=250.0, bending=10.0, damping_ratio=0.3,
        tear_strength=tear,
    )
    first = h["first_particle"]
    left = [first + j * nx for j in range(ny)]
    right = [i + nx - 1 for i in left]
    b.add_handle(left, velocity=(-speed, 0.0, 0.0), stop=10.0)
    b.add_handle(right, velocity=(speed, 0.0, 0.0), stop=10.0)
    return b.finalize(), left, right


def test_handles_follow_their_path_and_then_hold():
    b = fissure.ModelBuilder(gravity=(0.0, -9.81, 0.0))
    b.add_cloth_grid(5, 5, 0.1)
    top = list(range(5))
    b.add_handle(top, path=[(0.0, (0.0, 0.0, 0.0)), (0.2, (0.1, 0.05, 0.0))])
    model = b.finalize()
    w = fissure.World(model)
    x0 = w.state.positions[top].copy()
    w.advance(0.1, 2e-4)
    np.testing.assert_allclose(w.state.positions[top] - x0, [[0.05, 0.025, 0.0]] * 5, atol=1e-5)
    np.testing.assert_allclose(w.state.velocities[top], [[0.5, 0.25, 0.0]] * 5, atol=1e-4)
    w.advance(0.3, 2e-4)
    # float32 positions moved by 2000 increments: rounding adds up to a few 1e-5 m.
    np.testing.assert_allclose(w.state.positions[top] - x0, [[0.1, 0.05, 0.0]] * 5, atol=1e-4)
    np.testing.assert_allclose(w.state.velocities[top], 0.0, atol=1e-6)
    # The rest of the cloth hangs from the handle: it is free and falls below it.
    assert w.state.positions[20:, 1].max() < x0[0, 1]


def test_a_strip_pulled_by_handles_tears_through():
    model, left, right = strip()
    w = fissure.World(model)
    w.advance(0.25, 1e-4)
    events = w.events
    assert any(e["kind"] == "spring" for e in events), events[:3]
    assert w.model.body_count >= 2, "the strip did not tear through"
    # The handles stay apart: left to the left, right to the right of where they started.
    assert w.state.positions[left, 0].max() < 0.0
    assert w.state.positions[right, 0].min() > 0.2


def test_a_stronger_strip_holds():
    model, _, _ = strip(tear=200.0)
    w = fissure.World(model)
    w.advance(0.25, 1e-4)
    assert not w.events and w.model.body_count == 1


def test_the_pump_inflates_a_balloon():
    b = fissure.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    b.add_soft_body(fissure.Mesh.icosphere(0.1, 2), mass=0.05, stiffness=500.0, pressure=1000.0, gas_inflow=20.0)
    w = fissure.World(b.finalize())
    v0 = w.model.body_volumes(w.state)[0]
    w.advance(0.2, 5e-5)
    assert w.model.body_volumes(w.state)[0] > 1.2 * v0


@pytest.mark.parametrize(
    ("kwargs", "word"),
    [
        ({"velocity": (1.0, 0.0, 0.0)}, "stop"),
        ({"velocity": (1.0, 0.0, 0.0), "start": 1.0, "stop": 0.5}, "stop"),
        ({"path": [(0.5, (0.0, 0.0, 0.0)), (0.1, (1.0, 0.0, 0.0))]}, "path"),
        ({}, "velocity"),
    ],
)
def test_bad_handles_are_errors_that_name_the_argument(kwargs, word):
    b = fissure.ModelBuilder()
    b.add_cloth_grid(3, 3, 0.1)
    with pytest.raises(ValueError, match=word):
        b.add_handle([0, 1], **kwargs)


def test_bad_handle_particles_and_strengths_are_errors():
    b = fissure.ModelBuilder()
    b.add_cloth_grid(3, 3, 0.1)
    with pytest.raises(ValueError, match="particle"):
        b.add_handle([0, 99], velocity=(1.0, 0.0, 0.0), stop=1.0)
    b.add_handle([0], velocity=(1.0, 0.0, 0.0), stop=1.0)
    with pytest.raises(ValueError, match="particles"):
        b.add_handle([0], velocity=(1.0, 0.0, 0.0), stop=1.0)
    with pytest.raises(ValueError, match="tear_strength"):
        b.add_cloth_grid(3, 3, 0.1, tear_strength=-1.0)
    with pytest.raises(ValueError, match="gas_inflow"):
        b.add_soft_body(fissure.Mesh.icosphere(0.1, 1), gas_inflow=-1.0)
