"""``flexsurf.sweep``: many independent runs of one scene (or one virtual test) with overrides, on a local
process pool or on Ray, collected into a pandas DataFrame."""

from __future__ import annotations

import itertools
import multiprocessing
import operator
import os
import socket
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Iterable, Mapping, Sequence, Union

from ._flexsurf import Material, Scene, cantilever, cusick, kes, read_toml
from ._run import run, scene_path, with_overrides

LAB_TESTS = ("kes", "cantilever", "cusick")
"""The virtual tests a sweep can run instead of a scene."""

Overrides = Union[Mapping[str, Sequence[Any]], Iterable[Mapping[str, Any]]]


def cases(overrides: Overrides) -> list[dict]:
    """The list of cases of ``overrides``: a list of dicts is taken as it is; a dict of lists is the grid of
    every combination (the last key varying fastest)."""
    if isinstance(overrides, Mapping):
        keys = list(overrides)
        for k in keys:
            if isinstance(overrides[k], (str, bytes)) or not isinstance(overrides[k], Iterable):
                raise TypeError(f"overrides[{k!r}]: a grid needs a list of values, got {overrides[k]!r}")
        return [dict(zip(keys, values)) for values in itertools.product(*(list(overrides[k]) for k in keys))]
    out = [dict(c) for c in overrides]
    for c in out:
        for k in c:
            if not isinstance(k, str):
                raise TypeError(f"override keys must be dotted strings, got {k!r}")
    return out


def _flatten(d: Mapping[str, Any], prefix: str = "") -> dict:
    """Nested dicts to dotted keys; lists of numbers to ``key.0``, ``key.1``, …; other lists are left out."""
    row: dict = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            row.update(_flatten(v, key + "."))
        elif isinstance(v, (list, tuple)):
            if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
                row.update({f"{key}.{n}": x for n, x in enumerate(v)})
        else:
            row[key] = v
    return row


def run_case(task: str | dict, file: str | None, overrides: Mapping[str, Any]) -> dict:
    """One case of a sweep, as a flat dict of results (what ``sweep`` puts in a row, besides the overrides).

    ``task`` is a scene dict (run with :func:`flexsurf.run`, no files kept; the summary's ``frames`` list is
    left out) or the name of a virtual test (``"kes"``, ``"cantilever"``, ``"cusick"``: keys ``material.*`` make
    the :class:`Material`, on the paper's cotton unless ``material.preset`` or ``material.file`` is given; the
    other keys are the test's keyword arguments). Raises what the run raises.
    """
    if isinstance(task, str):
        material = {k.split(".", 1)[1]: v for k, v in overrides.items() if k.startswith("material.")}
        if "preset" not in material and "file" not in material:
            material["preset"] = "paper-cotton"
        kwargs = {k: v for k, v in overrides.items() if not k.startswith("material.")}
        test = {"kes": kes, "cantilever": cantilever, "cusick": cusick}[task]
        return _flatten(test(Material(**material), **kwargs))
    scene = Scene.from_dict(with_overrides(task, overrides), file)
    summary = dict(run(scene).summary)
    summary.pop("frames", None)
    return _flatten(summary)


def _case_row(task: str | dict, file: str | None, index: int, overrides: Mapping[str, Any]) -> dict:
    row: dict = {"case": index, **overrides}
    try:
        row.update(run_case(task, file, overrides))
        row["error"] = None
    except Exception as e:  # a failed case is a row with its message: the others still count
        row["error"] = f"{type(e).__name__}: {e}"
    return row


def sweep(
    scene: Any,
    overrides: Overrides,
    backend: str = "process",
    workers: int | None = None,
    parquet: str | os.PathLike[str] | None = None,
    address: str | None = None,
):
    """Runs one simulation per case of ``overrides`` and returns a pandas DataFrame, one row per case.

    Args:
        scene: a path to a TOML scene, a dict of its keys, or ``"kes"``, ``"cantilever"``, ``"cusick"`` for a
            virtual test (see :func:`run_case`).
        overrides: a list of dicts of dotted keys (``{"material.bending_warp": 1e-4}``), or a dict of lists
            (the grid of all combinations).
        backend: ``"process"`` (a local process pool, default) or ``"ray"`` (the Ray cluster at ``address``,
            or the one this process is connected to, or a local one started for the call and shut down after).
        workers: processes (``"process"``; default the CPU count) or CPUs of a local Ray instance.
        parquet: a path to also write the table to as Parquet (needs pyarrow).
        address: a Ray cluster address (``"ray"`` backend).

    Columns: ``case``, the override keys, the results (``summary.json``'s values flattened to dotted keys:
    ``final.min_z``, ``final.projected_area_xy``, …; or the test's report), and ``error`` (``None``, or why the
    case failed). Every case runs alone, so each row equals running that case by itself (wall times aside).
    """
    import pandas as pd

    _check_workers(workers)
    if parquet is not None:
        parquet = _check_parquet(parquet)
    file: str | None = None
    if isinstance(scene, str) and scene in LAB_TESTS:
        task: str | dict = scene
    elif isinstance(scene, str) and not os.path.exists(scene) and os.sep not in scene and "." not in scene:
        tests = ", ".join(f'"{t}"' for t in LAB_TESTS)
        raise ValueError(f"scene: {scene!r} is neither a scene file nor a virtual test ({tests})")
    elif isinstance(scene, Mapping):
        task = dict(scene)
    else:
        file = scene_path(scene, f"a path to a TOML scene, a dict of its keys or one of {LAB_TESTS}")
        task = read_toml(file)
    todo = cases(overrides)
    if backend == "process":
        rows = _run_processes(task, file, todo, workers)
    elif backend == "ray":
        rows = _run_ray(task, file, todo, workers, address)
    else:
        raise ValueError(f'backend: {backend!r} must be "process" or "ray"')
    table = pd.DataFrame(rows)
    if parquet is not None:
        # Atomically: a reader never sees half a table, and a failed write leaves the earlier file.
        partial = f"{parquet}.{os.getpid()}.partial"
        try:
            table.to_parquet(partial, index=False)
            os.replace(partial, parquet)
        finally:
            if os.path.exists(partial):
                os.remove(partial)
    return table


MAIN_GUARD = (
    'the "process" backend starts its workers by re-importing the script that called sweep(), so that script '
    'must run its top-level code only under `if __name__ == "__main__":` (see docs/python.md); without the guard '
    "every worker runs the sweep again and dies"
)


def _run_processes(task: str | dict, file: str | None, todo: list[dict], workers: int | None) -> list[dict]:
    if not todo:
        return []
    if getattr(multiprocessing.current_process(), "_inheriting", False):
        # A spawned worker still starting up, re-running an unguarded script: say why (multiprocessing's own
        # check, which would refuse to start processes from it, does not).
        raise RuntimeError(f"sweep() was called in a worker process: {MAIN_GUARD}")
    n = max(1, min(workers or os.cpu_count() or 1, len(todo)))
    # Spawned workers: a fork of a process that already runs native threads is not safe.
    try:
        with ProcessPoolExecutor(max_workers=n, mp_context=multiprocessing.get_context("spawn")) as pool:
            futures = [pool.submit(_case_row, task, file, k, c) for k, c in enumerate(todo)]
            return [f.result() for f in futures]
    except BrokenProcessPool as e:
        raise RuntimeError(f"the sweep's worker processes stopped: {MAIN_GUARD}") from e


def _run_ray(
    task: str | dict, file: str | None, todo: list[dict], workers: int | None, address: str | None
) -> list[dict]:
    try:
        import ray
    except ImportError as e:
        raise ImportError('backend="ray" needs Ray: pip install "./python[ray]" (or pip install ray)') from e
    started = False
    if not ray.is_initialized():
        if address is None:
            ray.init(num_cpus=workers, include_dashboard=False, log_to_driver=False)
        else:
            _reachable(address)
            ray.init(address=address, log_to_driver=False)
        started = True
    try:
        remote = ray.remote(_case_row)
        return ray.get([remote.remote(task, file, k, c) for k, c in enumerate(todo)])
    finally:
        if started:
            ray.shutdown()


def _reachable(address: str) -> None:
    """Raises ``ConnectionError`` where ``address`` is a ``host:port`` (or ``ray://host:port``) that accepts no
    connection within 10 s: ``ray.init`` would wait minutes for it. Other forms (``"auto"``, ``"local"``) are
    Ray's to resolve."""
    target = address[len("ray://") :] if address.startswith("ray://") else address
    host, sep, port = target.rpartition(":")
    if not sep or not host or not port.isdigit():
        return
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=10).close()
    except OSError as e:
        raise ConnectionError(
            f"address: no Ray cluster answers at {address!r} ({e}); start one (ray start --head) or leave address "
            "out for a local one"
        ) from e


def _check_parquet(parquet: str | os.PathLike[str]) -> str:
    """The Parquet path, checked before any case runs (a sweep of hours that found no Parquet engine, or no
    folder to write into, only at its end raised and returned nothing)."""
    import importlib.util

    path = os.fspath(parquet)
    if not any(importlib.util.find_spec(engine) for engine in ("pyarrow", "fastparquet")):
        raise ImportError(
            f'parquet: writing {path!r} needs pyarrow (pip install "./python[parquet]"); no case was run'
        )
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder) or os.path.isdir(path):
        what = "is a folder" if os.path.isdir(path) else f"has no folder {folder!r} to be written in"
        raise FileNotFoundError(f"parquet: {path!r} {what}; no case was run")
    if not os.access(folder, os.W_OK | os.X_OK):
        raise PermissionError(f"parquet: the folder {folder!r} cannot be written in; no case was run")
    return path


def _check_workers(workers: Any) -> None:
    """Raises unless ``workers`` is ``None`` or a positive integer (numpy's included, not a bool)."""
    if workers is None:
        return
    what = f"workers: {workers!r} must be a positive number of processes (or None for the CPU count)"
    try:
        n = operator.index(workers)
    except TypeError:
        raise TypeError(what) from None
    if isinstance(workers, bool) or n < 1:
        raise ValueError(what)
