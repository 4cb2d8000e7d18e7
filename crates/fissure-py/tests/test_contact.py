"""Contact between surfaces from Python: two balloons thrown at each other bounce apart and keep their momentum;
bad settings are errors that name the argument."""

import numpy as np
import pytest

import fissure


def two_balloons(contact=True):
    b = fissure.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    ball = fissure.Mesh.icosphere(0.2, 2)
    a = b.add_soft_body(ball.translated((-0.3, 0.0, 0.0)), mass=0.3, pressure=2000.0, velocity=(2.0, 0.0, 0.0))
    z = b.add_soft_body(ball.translated((0.3, 0.02, 0.0)), mass=0.2, pressure=2000.0, velocity=(-1.0, 0.0, 0.0))
    if contact:
        b.set_contact(a["index"])
        b.set_contact(z["index"], friction=0.5)
    return b.finalize(), a, z


def centre_x(state, handle):
    r = slice(handle["first_particle"], handle["first_particle"] + handle["particle_count"])
    return state.positions[r, 0].mean()


def test_balloons_bounce_apart_with_contact_and_pass_through_without():
    for contact in (True, False):
        model, a, z = two_balloons(contact)
        state = model.state()
        solver = fissure.Solver()
        p0 = np.array(model.momentum(state))
        solver.step(model, state, 1e-4, steps=3000)
        gap = centre_x(state, z) - centre_x(state, a)
        stats = solver.contact_stats()
        if contact:
            assert gap > 0.4, gap
            assert stats["pushed_total"] > 100, stats
            # float32 state: momentum to a few 1e-6 of the bodies' momenta (0.6 + 0.2 kg m/s).
            assert np.abs(np.array(model.momentum(state)) - p0).max() < 1e-4 * 0.8
        else:
            assert gap < 0.0, "without contact the balloons pass through each other"
            assert stats["steps"] == 0 and solver.timers()["contact"] == 0.0


def test_bad_contact_settings_name_the_argument():
    b = fissure.ModelBuilder()
    h = b.add_soft_body(fissure.Mesh.icosphere(0.2, 1), pressure=1000.0)
    with pytest.raises(ValueError, match="thickness"):
        b.set_contact(h["index"], thickness=-1.0)
    with pytest.raises(ValueError, match="friction"):
        b.set_contact(h["index"], friction=float("nan"))
    with pytest.raises(ValueError, match="body"):
        b.set_contact(7)


def test_a_step_above_the_stability_bound_with_contact_is_refused():
    # With contact, an unstable explicit step would not blow up (the displacement bound caps its runaway moves)
    # but run on jittering: it is refused before it is taken, and the state is kept.
    model, _, _ = two_balloons()
    state = model.state()
    before = state.positions.copy()
    with pytest.raises(ValueError, match="stability bound.*has contact.*substep_safety"):
        fissure.Solver().step(model, state, 1e-2)
    assert np.array_equal(state.positions, before) and state.time == 0.0
    fissure.Solver(substep_safety=0.9).step(model, state, 1e-2)
    assert state.time == pytest.approx(1e-2) and np.isfinite(state.positions).all()
