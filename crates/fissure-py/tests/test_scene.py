"""Scene files from Python: the same loader as the CLI and the examples (fissure::scene)."""

import pathlib

import numpy as np
import pytest

import fissure

SCENES = pathlib.Path(__file__).resolve().parents[3] / "scenes"


def test_cloth_scene_is_blown_downwind() -> None:
    s = fissure.load_scene(SCENES / "cloth_wind.toml")
    world = s["world"]
    assert s["dt"] == pytest.approx(2e-4) and s["duration"] > 0 and "cloth" in s["title"]
    start = world.state.positions.copy()
    world.advance(0.4, s["dt"])
    moved = world.state.positions - start
    # The wind blows along +z: the sheet's mean displacement is downwind and finite.
    assert np.isfinite(moved).all()
    assert moved[:, 2].mean() > 0.05


def test_fracture_scene_loads_with_its_settings() -> None:
    s = fissure.load_scene(SCENES / "fracture.toml")
    assert s["dt"] == pytest.approx(2e-4)
    assert s["world"].model.particle_count == 642


def test_scene_errors_name_the_key(tmp_path: pathlib.Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('[solver]\ndtt = 1e-4\n')
    with pytest.raises(ValueError, match="dtt"):
        fissure.load_scene(bad)
    bad.write_text('[[body]]\nshape = "cloth"\nresolution = [8, 8]\npressure = 5.0\n')
    with pytest.raises(ValueError, match=r"body\[0\]\.pressure"):
        fissure.load_scene(bad)
    with pytest.raises(OSError):
        fissure.load_scene(tmp_path / "missing.toml")
