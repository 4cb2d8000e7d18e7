"""Array round trips and every bad input getting its own clear error."""

import numpy as np
import pytest

import fissure

TETRA_P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float64)
TETRA_T = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def test_mesh_round_trip_any_dtype_and_layout():
    for p in (TETRA_P, TETRA_P.astype(np.float32), np.asfortranarray(TETRA_P), TETRA_P.tolist()):
        for t in (TETRA_T, TETRA_T.astype(np.uint32), TETRA_T.astype(np.int16), TETRA_T.tolist()):
            m = fissure.Mesh(p, t)
            assert m.positions.dtype == np.float64 and m.positions.shape == (4, 3)
            assert np.array_equal(m.positions, TETRA_P)
            assert np.array_equal(m.triangles, TETRA_T)
    assert m.is_closed() and abs(m.signed_volume() - 1 / 6) < 1e-15


def test_state_round_trip_and_copy_into_without_allocation():
    b = fissure.ModelBuilder()
    b.add_soft_body(fissure.Mesh.icosphere(0.1, 1), mass=0.1)
    model = b.finalize()
    state = model.state()
    assert state.positions.dtype == np.float32 and state.positions.shape == (42, 3)
    new = np.random.default_rng(0).normal(size=(42, 3))
    state.positions = new  # float64 in, rounded once
    assert np.array_equal(state.positions, new.astype(np.float32))
    state.velocities = np.ones((42, 3), dtype=np.float32)
    assert np.all(state.velocities == 1.0)
    out = np.empty((42, 3), dtype=np.float32)
    before = out.__array_interface__["data"][0]
    state.copy_positions_into(out)
    assert out.__array_interface__["data"][0] == before
    assert np.array_equal(out, state.positions)
    # Returned arrays are copies: writing to them does not change the state.
    p = state.positions
    p[:] = 0.0
    assert not np.all(state.positions == 0.0)


@pytest.mark.parametrize(
    "positions, triangles, exc, words",
    [
        (TETRA_P[:, :2], TETRA_T, ValueError, "shape (N, 3)"),
        (TETRA_P, TETRA_T[:, :2], ValueError, "shape (N, 3)"),
        (TETRA_P.astype(np.complex128), TETRA_T, TypeError, "float32 or float64"),
        (TETRA_P.astype(bool), TETRA_T, TypeError, "float32 or float64"),
        (TETRA_P, TETRA_T.astype(np.float64), TypeError, "integer"),
        (np.where(np.arange(12).reshape(4, 3) == 4, np.nan, TETRA_P), TETRA_T, ValueError, "not finite"),
        (np.where(np.arange(12).reshape(4, 3) == 4, np.inf, TETRA_P), TETRA_T, ValueError, "not finite"),
        (TETRA_P, np.array([[0, 2, 1], [0, 1, 9], [0, 3, 2], [1, 2, 3]]), ValueError, "refers to vertex 9"),
        (TETRA_P, np.array([[0, 2, 1], [0, 1, -1], [0, 3, 2], [1, 2, 3]]), ValueError, "refers to vertex -1"),
        (TETRA_P, np.array([[0, 2, 1], [0, 1, 1], [0, 3, 2], [1, 2, 3]]), ValueError, "degenerate"),
        (TETRA_P, np.array([[0, 1, 2], [0, 1, 3], [0, 3, 2], [1, 2, 3]]), ValueError, "inconsistent winding"),
        (np.vstack([TETRA_P, [[0, -1, 0.3]]]), np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]]), ValueError, "non-manifold"),
        ("not an array", TETRA_T, TypeError, "numeric"),
    ],
)
def test_bad_mesh_inputs(positions, triangles, exc, words):
    with pytest.raises(exc) as e:
        fissure.Mesh(positions, triangles)
    assert words in str(e.value)


def test_bad_model_inputs():
    grid = fissure.Mesh.grid(4, 4, 0.1)
    b = fissure.ModelBuilder()
    with pytest.raises(ValueError, match="closed surface"):
        b.add_soft_body(grid, pressure=1000.0)
    with pytest.raises(ValueError, match="mass"):
        b.add_soft_body(fissure.Mesh.icosphere(1.0, 0), mass=-1.0)
    with pytest.raises(ValueError, match="at most one"):
        b.add_soft_body(fissure.Mesh.icosphere(1.0, 0), mass=1.0, area_density=2.0)
    with pytest.raises(ValueError, match="particle 99"):
        b.add_cloth(grid, pins=[99])
    with pytest.raises(ValueError, match="not finite"):
        b.add_particle((float("nan"), 0.0, 0.0), mass=1.0)
    with pytest.raises(ValueError, match="restitution"):
        b.add_ground(restitution=2.0)
    with pytest.raises(ValueError, match="empty"):
        fissure.ModelBuilder().finalize()
    with pytest.raises(TypeError):
        b.add_soft_body("mesh")  # type: ignore[arg-type]
    with pytest.raises(TypeError):
        fissure.Solver(integrator="rk4")  # type: ignore[arg-type]


def test_bad_state_and_step_inputs():
    b = fissure.ModelBuilder()
    b.add_soft_body(fissure.Mesh.icosphere(0.1, 1), mass=0.1)
    model = b.finalize()
    state = model.state()
    with pytest.raises(ValueError, match=r"\(42, 3\)"):
        state.positions = np.zeros((41, 3))
    with pytest.raises(ValueError, match="not finite"):
        state.velocities = np.full((42, 3), np.nan)
    with pytest.raises(TypeError, match="float32"):
        state.copy_positions_into(np.zeros((42, 3)))
    with pytest.raises(ValueError, match="shape"):
        state.copy_positions_into(np.zeros((42, 2), dtype=np.float32))
    with pytest.raises(ValueError, match="C-contiguous"):
        state.copy_positions_into(np.zeros((3, 42), dtype=np.float32).T)
    solver = fissure.Solver()
    with pytest.raises(ValueError, match="time step"):
        solver.step(model, state, -1.0)
    other = fissure.ModelBuilder()
    other.add_particle((0, 0, 0), mass=1.0)
    with pytest.raises(ValueError, match="particles"):
        solver.step(other.finalize(), state, 1e-3)
    # A step far beyond the stability limit blows up: a ValueError that says so, not a crash.
    stiff = fissure.ModelBuilder(gravity=(0.0, 0.0, 0.0))
    stiff.add_soft_body(fissure.Mesh.icosphere(0.1, 2), mass=0.01, stiffness=1e6, pressure=1e5)
    m2 = stiff.finalize()
    s2 = m2.state()
    s2.velocities = np.random.default_rng(0).normal(size=(m2.particle_count, 3))
    with pytest.raises(ValueError, match="blew up"):
        fissure.Solver().step(m2, s2, 1e-2, steps=200)


def test_renumbered_for_locality_maps_every_vertex_and_triangle():
    ball = fissure.Mesh.icosphere(0.25, 3)
    rng = np.random.default_rng(7)
    perm = rng.permutation(ball.vertex_count)  # old vertex i becomes perm[i]
    p = np.empty_like(ball.positions)
    p[perm] = ball.positions
    shuffled = fissure.Mesh(p, perm[ball.triangles])
    mesh, vmap, tmap = shuffled.renumbered_for_locality()
    assert vmap.dtype == np.uint32 and tmap.dtype == np.uint32
    assert sorted(vmap.tolist()) == list(range(shuffled.vertex_count))
    assert np.array_equal(mesh.positions[vmap], shuffled.positions)
    assert np.array_equal(mesh.triangles[tmap], vmap[shuffled.triangles])
    edges = lambda m: np.abs(m.triangles.astype(np.int64) - np.roll(m.triangles, 1, axis=1)).max()  # noqa: E731
    assert edges(shuffled) > 500 and edges(mesh) < 60, (edges(shuffled), edges(mesh))
    assert abs(mesh.signed_volume() - ball.signed_volume()) < 1e-12
