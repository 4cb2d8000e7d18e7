"""The Python examples run with few frames, and their outcome is checked."""

import importlib.util
import pathlib

import numpy as np

EXAMPLES = pathlib.Path(__file__).resolve().parents[3] / "examples" / "python"


def load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_ball_drop_example(tmp_path):
    r = load("ball_drop").main(frames=20, out=str(tmp_path))
    assert r["lowest"] >= 0.0
    data = np.load(tmp_path / "frames.npz")
    assert data["positions"].shape == (20, 642, 3) and np.isfinite(data["positions"]).all()
    # It fell.
    assert data["positions"][-1][:, 1].mean() < data["positions"][0][:, 1].mean()


def test_cloth_wind_example(tmp_path):
    r = load("cloth_wind").main(frames=30, n=12, out=str(tmp_path))
    assert r["downwind"] > 0.02, "the cloth should be pushed downwind"
    assert (tmp_path / "last.obj").exists()


def test_fracture_example():
    r = load("fracture").main(duration=0.4)
    kinds = [e["kind"] for e in r["events"]]
    assert len(kinds) >= 3 and "core" in kinds
    assert r["bodies"] > 1, "a core block becomes its own body"
    assert r["volume_end"] < r["volume_at_puncture"], "the punctured ball deflates"
