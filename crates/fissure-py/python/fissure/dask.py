"""Scenes and sweeps on a Dask cluster: more runs than one machine holds.

Each run is one task. Its payload is plain data: the scene file's text, its name and the overrides (a dict of
key: value), so workers need no shared file system (a scene that loads an OBJ mesh by ``file = ...`` needs that
file on the workers: pass ``ship_text=False`` and a path they can all read). A worker runs its task with
``fissure.run_many`` on one thread and returns numpy arrays; the client gathers them into one table with the same
keys as ``run_many`` (``ok``, ``events``, ``spring_events``, ..., ``gas_volume``, ``wall``, ``error``), in the
order of the runs. The outcomes are bit-identical to ``run_many`` on one machine (each run is deterministic).

    from dask.distributed import Client, LocalCluster
    import fissure.dask

    with LocalCluster(n_workers=2, threads_per_worker=1) as cluster, Client(cluster) as client:
        table = fissure.dask.run_sweep(
            client, "scenes/fracture.toml",
            {"body[0].pressure": [2000, 3000, 4000], "body[0].load_limit": [2.0, 3.0]},
            duration=0.3,
        )

Dask is optional: ``pip install fissure[dask]`` (``dask[distributed]``).
"""

from __future__ import annotations

import itertools
import os
import tempfile
from typing import Any, Mapping, Sequence

import numpy as np

from ._fissure import run_many

__all__ = ["map_scenes", "run_sweep", "sweep_overrides"]


def _run_one(payload: tuple[str, str, str | None, dict[str, Any], float | None]) -> dict[str, Any]:
    """One task on a worker: the scene from its text (or path), one run, one thread."""
    kind, name, text, overrides, duration = payload
    if kind == "path":
        return run_many([(name, overrides)], duration=duration, threads=1)
    with tempfile.TemporaryDirectory(prefix="fissure-") as tmp:
        path = os.path.join(tmp, os.path.basename(name))
        with open(path, "w", encoding="utf-8") as f:
            f.write(text or "")
        return run_many([(path, overrides)], duration=duration, threads=1)


def _merge(parts: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """One table from one-row tables, in order."""
    if not parts:
        return {"error": []}
    out: dict[str, Any] = {}
    for key in parts[0]:
        if key == "error":
            out[key] = [e for p in parts for e in p[key]]
        else:
            out[key] = np.concatenate([p[key] for p in parts])
    return out


def map_scenes(
    client: Any,
    runs: Sequence[Any],
    overrides: Mapping[str, Any] | None = None,
    *,
    duration: float | None = None,
    ship_text: bool = True,
) -> dict[str, Any]:
    """Runs scenes on a ``dask.distributed`` client, one task per run; returns the outcome table.

    ``runs`` is as for ``fissure.run_many``: scene paths, or ``(path, overrides)`` pairs; ``overrides`` applies to
    runs without their own. ``duration`` [s] defaults to each scene's. With ``ship_text`` (the default) the scene's
    text travels with the task; otherwise the path does, and must be readable on every worker.
    """
    payloads = []
    texts: dict[str, str] = {}
    for run in runs:
        if isinstance(run, (tuple, list)) and len(run) == 2:
            path, own = os.fspath(run[0]), dict(run[1] or {})
        else:
            path, own = os.fspath(run), dict(overrides or {})
        if ship_text:
            if path not in texts:
                with open(path, encoding="utf-8") as f:
                    texts[path] = f.read()
            payloads.append(("text", path, texts[path], own, duration))
        else:
            payloads.append(("path", path, None, own, duration))
    futures = client.map(_run_one, payloads, pure=False)
    return _merge(client.gather(futures))


def sweep_overrides(values: Mapping[str, Sequence[Any]]) -> list[dict[str, Any]]:
    """Every combination of the values (the product over the keys, the last key varying fastest)."""
    keys = list(values)
    return [dict(zip(keys, combo)) for combo in itertools.product(*(values[k] for k in keys))]


def run_sweep(
    client: Any,
    scene: str | os.PathLike[str],
    values: Mapping[str, Sequence[Any]],
    *,
    duration: float | None = None,
) -> dict[str, Any]:
    """``fissure sweep`` on a cluster: the product of ``values`` (key: list of values) over one scene.

    Returns the outcome table with one extra column per swept key (its value in each run), rows in the order of
    ``sweep_overrides(values)``.
    """
    combos = sweep_overrides(values)
    table = map_scenes(client, [(scene, c) for c in combos], duration=duration)
    for key in values:
        table[key] = np.asarray([c[key] for c in combos])
    return table
