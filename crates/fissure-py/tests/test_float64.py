"""The float64 reference path from Python: `finalize(precision="float64")` and `load_scene(..., precision=...)`
give float64 models, states, solvers and worlds whose arrays are float64, and their RK4 run of the 32² cloth in
wind matches the same run in Rust's `Model<f64>` (`tests/suite/python_reference.rs`, which checks the committed
reference file against itself) to 1e-12 m."""

import pathlib

import numpy as np
import pytest

import fissure

ROOT = pathlib.Path(__file__).resolve().parents[3]
REFERENCE = pathlib.Path(__file__).resolve().parent / "data" / "cloth_wind_rk4_f64.bin"


def test_float64_rk4_cloth_matches_rust_to_1e_12_m() -> None:
    s = fissure.load_scene(ROOT / "scenes" / "cloth_wind.toml", {"solver.integrator": "rk4"}, precision="float64")
    world = s["world"]
    assert world.model.precision == "float64" and world.state.precision == "float64"
    world.step(s["dt"], steps=500)
    q = world.state.positions
    assert q.dtype == np.float64 and q.shape == (1024, 3)
    reference = np.fromfile(REFERENCE, dtype="<f8").reshape(-1, 3)
    assert np.abs(q - reference).max() <= 1e-12
    # The float32 run of the same scene is close but not that close: the check can tell the precisions apart.
    single = fissure.load_scene(ROOT / "scenes" / "cloth_wind.toml", {"solver.integrator": "rk4"})["world"]
    single.step(s["dt"], steps=500)
    assert single.state.positions.dtype == np.float32
    assert 1e-9 < np.abs(single.state.positions - reference).max() < 1e-2


def test_builder_float64_models_step_and_keep_their_precision() -> None:
    b = fissure.ModelBuilder()
    b.add_soft_body(fissure.Mesh.icosphere(0.2, 2).translated((0, 1, 0)), mass=0.3, pressure=2000.0)
    b.add_ground()
    m64, m32 = b.finalize(precision="float64"), b.finalize()
    assert (m64.precision, m32.precision) == ("float64", "float32")
    s64 = m64.state()
    assert s64.positions.dtype == np.float64 and s64.velocities.dtype == np.float64
    solver = fissure.Solver(integrator=fissure.Integrator.RK4)
    solver.step(m64, s64, 1e-4, steps=100)
    # Free fall for 10 ms before the ball reaches the ground: y drops by g t² / 2.
    assert m64.center_of_mass(s64)[1] == pytest.approx(1.0 - 0.5 * 9.81 * 0.01**2, abs=1e-9)
    out = np.empty((m64.particle_count, 3), dtype=np.float64)
    s64.copy_positions_into(out)
    np.testing.assert_array_equal(out, s64.positions)
    with pytest.raises(TypeError, match="float64"):
        s64.copy_positions_into(np.empty((m64.particle_count, 3), dtype=np.float32))
    # Mixing precisions is an error, not a silent conversion.
    with pytest.raises(TypeError, match="precision"):
        m32.body_volumes(s64)
    with pytest.raises(TypeError, match="precision"):
        solver.step(m32, s64, 1e-4)
    with pytest.raises(ValueError, match="precision"):
        b.finalize(precision="float16")
    # A float64 world, pickled and back, stays float64.
    import pickle

    w = fissure.World(m64)
    w.advance(0.01, 1e-4)
    w2 = pickle.loads(pickle.dumps(w))
    assert w2.state.positions.dtype == np.float64
    np.testing.assert_array_equal(w2.state.positions, w.state.positions)
    assert fissure.run_many([w, w2], duration=0.005, dt=1e-4)["ok"].all()
    np.testing.assert_array_equal(w2.state.positions, w.state.positions)
