"""Beyond one run: scene overrides, run_many (threads in Rust) against sequential runs, the Dask recipe on a
two-worker LocalCluster, and VTK frames read back with meshio."""

import pathlib

import numpy as np
import pytest

import fissure

SCENES = pathlib.Path(__file__).resolve().parents[3] / "scenes"
FRACTURE = SCENES / "fracture.toml"
# Long enough for the ball to hit the obstacle and break (core blocks at ~0.13 s, cracks by 0.2 s).
DURATION = 0.2


def same_outcomes(a: dict, b: dict) -> None:
    """Every column but the wall time, bit for bit."""
    assert set(a) == set(b)
    for key in a:
        if key == "wall":
            continue
        if key == "error":
            assert a[key] == b[key]
        else:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_overrides_set_keys_as_the_file_would() -> None:
    base = fissure.load_scene(FRACTURE)
    s = fissure.load_scene(FRACTURE, {"body[0].pressure": 4500.0, "solver.dt": 1e-4, "solver.integrator": "rk4"})
    assert s["dt"] == 1e-4 and base["dt"] == pytest.approx(2e-4)
    p0 = base["world"].model.body_pressures(base["world"].state)[0]
    p1 = s["world"].model.body_pressures(s["world"].state)[0]
    assert p1 / p0 == pytest.approx(1.5, rel=1e-6)
    # numpy values and lists are scene values too.
    s = fissure.load_scene(FRACTURE, {"body[0].velocity": np.array([0.5, 0.0, 0.0]), "body[0].mass": np.float32(0.5)})
    assert s["world"].state.velocities[:, 0].mean() == pytest.approx(0.5, rel=1e-6)


@pytest.mark.parametrize(
    "overrides, match",
    [
        ({"body[0].presure": 1.0}, r"body\[0\]\.presure.*unknown field"),
        ({"body[0].pressure": "high"}, r"body\[0\]\.pressure.*invalid type"),
        ({"body[3].pressure": 1.0}, r"body\[3\]\.pressure.*1 `body` entries"),
        ({"solver.dt": -1.0}, r"solver\.dt.*must be > 0"),
        ({"solver.integrator": "rk5"}, r"solver\.integrator.*unknown variant"),
        ({"body[0].load_limit": -2.0}, r"body\[0\]\.load_limit"),
    ],
)
def test_bad_overrides_name_their_key(overrides: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        fissure.load_scene(FRACTURE, overrides)


def test_override_types_are_checked() -> None:
    with pytest.raises(TypeError, match="overrides"):
        fissure.load_scene(FRACTURE, [("solver.dt", 1e-4)])  # type: ignore[arg-type]
    with pytest.raises(TypeError, match=r"solver\.dt"):
        fissure.load_scene(FRACTURE, {"solver.dt": object()})


SWEEP = [{"body[0].pressure": p, "body[0].load_limit": l} for p in (2500.0, 3500.0) for l in (2.5, 3.0)]


def test_run_many_matches_sequential_runs_bit_for_bit() -> None:
    runs = [(FRACTURE, o) for o in SWEEP]
    together = fissure.run_many(runs, duration=DURATION)
    alone = [fissure.run_many([r], duration=DURATION, threads=1) for r in runs]
    merged = {k: (sum((a[k] for a in alone), []) if k == "error" else np.concatenate([a[k] for a in alone])) for k in alone[0]}
    same_outcomes(together, merged)
    assert together["ok"].all() and (together["events"] > 0).any()
    assert together["simulated"] == pytest.approx(DURATION)
    # The outcomes differ with the pressure: the sweep measures something.
    assert len(set(together["events"].tolist())) > 1


def test_run_many_on_worlds_matches_advance() -> None:
    worlds = [fissure.load_scene(FRACTURE, o)["world"] for o in SWEEP[:2]]
    twins = [fissure.load_scene(FRACTURE, o)["world"] for o in SWEEP[:2]]
    out = fissure.run_many(worlds, duration=0.05, dt=2e-4)
    for w, t in zip(worlds, twins):
        t.advance(0.05, 2e-4)
        np.testing.assert_array_equal(w.state.positions, t.state.positions)
        np.testing.assert_array_equal(w.state.velocities, t.state.velocities)
    assert out["steps"].tolist() == [250, 250]
    with pytest.raises(ValueError, match="duration"):
        fissure.run_many(worlds)
    with pytest.raises(ValueError, match="twice"):
        fissure.run_many([worlds[0], worlds[0]], duration=0.01, dt=2e-4)


def test_a_failing_run_is_a_row_with_its_error() -> None:
    out = fissure.run_many([(FRACTURE, {"body[0].pressure": -5.0}), (FRACTURE, {})], duration=0.01)
    assert out["ok"].tolist() == [False, True]
    assert "pressure" in out["error"][0] and out["error"][1] is None
    assert out["steps"][1] == 50


def test_dask_recipe_matches_run_many() -> None:
    distributed = pytest.importorskip("distributed")
    import fissure.dask

    values = {"body[0].pressure": [2500.0, 3500.0], "body[0].load_limit": [2.5, 3.0]}
    assert fissure.dask.sweep_overrides(values) == SWEEP
    expected = fissure.run_many([(FRACTURE, o) for o in SWEEP], duration=DURATION)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            assert len(client.scheduler_info()["workers"]) == 2
            table = fissure.dask.run_sweep(client, FRACTURE, values, duration=DURATION)
    np.testing.assert_array_equal(table["body[0].pressure"], [2500.0, 2500.0, 3500.0, 3500.0])
    del table["body[0].pressure"], table["body[0].load_limit"]
    same_outcomes(table, expected)


def test_vtk_frames_read_back_with_meshio(tmp_path: pathlib.Path) -> None:
    meshio = pytest.importorskip("meshio")
    import fissure.vtk

    fissure.vtk.register_meshio()
    s = fissure.load_scene(FRACTURE)
    world = s["world"]
    counts = []
    for frame in range(5):
        vtp, vtu = tmp_path / f"frame_{frame}.vtp", tmp_path / f"frame_{frame}.vtu"
        world.save_vtk(vtp)
        world.save_vtk(vtu)
        m = world.model
        mesh = meshio.read(vtp)
        n, f = m.particle_count, m.tri_count
        assert mesh.points.shape == (n, 3)
        np.testing.assert_array_equal(mesh.points, world.state.positions)
        np.testing.assert_array_equal(mesh.cells_dict["triangle"], m.triangles)
        assert mesh.point_data["velocity"].shape == (n, 3)
        np.testing.assert_array_equal(mesh.point_data["velocity"], world.state.velocities)
        assert mesh.point_data["strain"].shape == (n,) and mesh.point_data["body"].shape == (n,)
        damage = mesh.cell_data["damage"][0]
        assert damage.shape == (f,) and mesh.cell_data["body"][0].shape == (f,)
        assert ((0.0 <= damage) & (damage <= 1.0)).all()
        # The .vtu (meshio's own reader, no conversion) holds the same surface and fields.
        grid = meshio.read(vtu)
        np.testing.assert_array_equal(grid.points, mesh.points)
        np.testing.assert_array_equal(grid.cells_dict["triangle"], mesh.cells_dict["triangle"])
        for name in ("velocity", "strain", "body"):
            np.testing.assert_array_equal(grid.point_data[name], mesh.point_data[name], err_msg=name)
        np.testing.assert_array_equal(grid.cell_data["damage"][0], damage)
        counts.append((n, f))
        world.advance(0.05, s["dt"])
    # The ball broke between frames: the vertex count grew where it did, and some triangles lie on a crack.
    assert counts[0] == (642, 1280) and counts[-1][0] > counts[0][0]
    assert (damage == 1.0).any()
    with pytest.raises(ValueError, match="vtp or .vtu"):
        world.save_vtk(tmp_path / "frame.vtk")
    with pytest.raises(meshio.ReadError):
        fissure.vtk.read_vtp(vtu)


def test_save_vtk_reports_io_errors(tmp_path: pathlib.Path) -> None:
    world = fissure.load_scene(FRACTURE)["world"]
    with pytest.raises(OSError):
        world.save_vtk(tmp_path / "missing-dir" / "x.vtp")


def step_in_worker(model_and_state: tuple) -> np.ndarray:
    """Runs in another process: the pickled model and state arrive, are stepped, and the positions go back."""
    model, state = model_and_state
    fissure.Solver().step(model, state, 1e-4, steps=200)
    return state.positions


def test_pickled_models_round_trip_exactly() -> None:
    import pickle

    world = fissure.load_scene(FRACTURE)["world"]
    world.advance(0.2, 2e-4)  # broken: split particles, openings, new bodies
    model, state = world.model, world.state
    m2, s2 = pickle.loads(pickle.dumps(model)), pickle.loads(pickle.dumps(state))
    assert (m2.particle_count, m2.spring_count, m2.tri_count, m2.body_count) == (
        model.particle_count, model.spring_count, model.tri_count, model.body_count)
    np.testing.assert_array_equal(m2.triangles, model.triangles)
    np.testing.assert_array_equal(m2.springs, model.springs)
    np.testing.assert_array_equal(s2.positions, state.positions)
    assert m2.energy(s2) == model.energy(state) and m2.body_volumes(s2) == model.body_volumes(state)
    # Every parameter came back: the same steps give the same bits.
    a, b = state.copy(), s2.copy()
    fissure.Solver().step(model, a, 1e-4, steps=100)
    fissure.Solver().step(m2, b, 1e-4, steps=100)
    np.testing.assert_array_equal(a.positions, b.positions)
    # ... in another process too (what Dask and multiprocessing do with them).
    import concurrent.futures
    import multiprocessing

    ctx = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=ctx) as pool:
        remote = pool.submit(step_in_worker, (model, state.copy())).result(timeout=120)
    local = state.copy()
    fissure.Solver().step(model, local, 1e-4, steps=200)
    np.testing.assert_array_equal(remote, local.positions)


def test_pickled_worlds_keep_their_state_settings_and_events() -> None:
    import pickle

    s = fissure.load_scene(FRACTURE)
    world = s["world"]
    world.advance(0.2, s["dt"])
    w2 = pickle.loads(pickle.dumps(world))
    assert w2.time == world.time and len(w2.events) == len(world.events) > 0
    assert w2.events[-1] == world.events[-1]
    np.testing.assert_array_equal(w2.state.positions, world.state.positions)
    w2.advance(0.05, s["dt"])
    assert np.isfinite(w2.state.positions).all() and w2.time == pytest.approx(0.25)


def test_damaged_pickles_are_errors() -> None:
    with pytest.raises(ValueError, match="not a pickled fissure model"):
        fissure._fissure._model_from_pickle(b"garbage")
    import pickle

    data = pickle.dumps(fissure.load_scene(FRACTURE)["world"].model)
    raw = pickle.loads(data).__reduce__()[1][0]
    with pytest.raises(ValueError, match="damaged pickle"):
        fissure._fissure._model_from_pickle(raw[: len(raw) // 2])
