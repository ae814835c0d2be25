"""Sweeps: each row equals running its case alone, on the process pool and on a local Ray instance."""

from __future__ import annotations

import socket
import time

import pandas as pd
import pytest

import flexsurf
from flexsurf._sweep import run_case

# The wall-clock columns differ from run to run.
TIMED = ("wall_seconds", "steps_per_second", "timings.")


def deterministic(row: dict) -> dict:
    return {k: v for k, v in row.items() if not k.startswith(TIMED)}


def check_rows_equal_single_runs(table: pd.DataFrame, base: dict, cases: list[dict]):
    assert list(table["case"]) == list(range(len(cases)))
    assert table["error"].isna().all(), table["error"].tolist()
    for k, case in enumerate(cases):
        alone = deterministic(run_case(base, None, case))
        row = deterministic(table.iloc[k].to_dict())
        for key, value in alone.items():
            assert row[key] == value, (k, key)
        for key, value in case.items():
            assert row[key] == value


def test_process_sweep_equals_single_runs(small_drop, tmp_path):
    grid = {"material.bending_warp": [5e-5, 5e-4], "contact.friction": [0.0, 0.5]}
    cases = flexsurf._sweep.cases(grid)
    assert len(cases) == 4
    table = flexsurf.sweep(small_drop, grid, backend="process", workers=2)
    check_rows_equal_single_runs(table, small_drop, cases)
    assert table["final.min_z"].nunique() == 4


def test_sweep_writes_parquet(small_drop, tmp_path):
    pytest.importorskip("pyarrow", reason="Parquet needs pyarrow (pip install \"./python[parquet]\")")
    path = tmp_path / "sweep.parquet"
    table = flexsurf.sweep(small_drop, {"contact.friction": [0.0, 0.5]}, backend="process", workers=2, parquet=path)
    back = pd.read_parquet(path)
    assert back["final.min_z"].tolist() == table["final.min_z"].tolist()
    assert [p.name for p in tmp_path.iterdir()] == ["sweep.parquet"]  # written atomically, nothing left over


def test_regression_a_sweep_without_a_parquet_engine_ran_every_case_first(small_drop, tmp_path, monkeypatch):
    # Without pyarrow, or with no folder to write into, a sweep ran every case and only then raised, returning
    # nothing: hours of results lost. Both are now refused before any case runs.
    import importlib.util

    import flexsurf._sweep as sweep_module

    ran = []
    monkeypatch.setattr(sweep_module, "_run_processes", lambda *a: ran.append(a) or [])
    find_spec = importlib.util.find_spec
    missing = ("pyarrow", "fastparquet")
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name in missing else find_spec(name, *a))
    with pytest.raises(ImportError, match="needs pyarrow.*no case was run"):
        flexsurf.sweep(small_drop, {"contact.friction": [0.0, 0.5]}, parquet=tmp_path / "sweep.parquet")
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: True if name == "pyarrow" else None)
    with pytest.raises(FileNotFoundError, match="has no folder .* no case was run"):
        flexsurf.sweep(small_drop, {"contact.friction": [0.0, 0.5]}, parquet=tmp_path / "none" / "sweep.parquet")
    with pytest.raises(FileNotFoundError, match="is a folder"):
        flexsurf.sweep(small_drop, {"contact.friction": [0.0, 0.5]}, parquet=tmp_path)
    assert ran == []


def test_failed_cases_are_rows_with_errors(small_drop):
    table = flexsurf.sweep(small_drop, [{"time.dt": 0.01}, {"time.dt": -1.0}], workers=1)
    assert pd.isna(table["error"].iloc[0])
    assert "time.dt" in table["error"].iloc[1]


def test_sweep_of_a_virtual_test():
    table = flexsurf.sweep("cantilever", [{"material.bending_warp": b} for b in (1e-4, 4e-4)], workers=2)
    assert table["error"].isna().all()
    assert table["bending_length"].iloc[1] > table["bending_length"].iloc[0]


def test_bad_sweeps_raise(small_drop):
    with pytest.raises(ValueError, match="backend"):
        flexsurf.sweep(small_drop, [{}], backend="mpi")
    with pytest.raises(TypeError, match="list of values"):
        flexsurf.sweep(small_drop, {"time.dt": 0.01})
    for workers, error in ((0, ValueError), (-3, ValueError), (True, ValueError), (1.5, TypeError)):
        with pytest.raises(error, match=rf"workers: {workers!r} must be a positive number"):
            flexsurf.sweep(small_drop, [{}], workers=workers)
    with pytest.raises(ValueError, match=r"'kez' is neither a scene file nor a virtual test \(\"kes\""):
        flexsurf.sweep("kez", [{}])


def test_a_ray_sweep_to_an_address_nothing_answers_at_fails_at_once(small_drop):
    pytest.importorskip("ray", reason="ray cannot be imported here (pip install './python[ray]')")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]  # free once closed: nothing listens there
    start = time.monotonic()
    with pytest.raises(ConnectionError, match=rf"no Ray cluster answers at '127\.0\.0\.1:{port}'"):
        flexsurf.sweep(small_drop, [{}], backend="ray", address=f"127.0.0.1:{port}")
    assert time.monotonic() - start < 30  # ray.init alone waits minutes


def test_ray_sweep_equals_single_runs(small_drop):
    try:
        import ray  # noqa: F401
    except ImportError:
        pytest.skip("ray cannot be imported here (pip install './python[ray]')")
    cases = [{"material.bending_warp": 5e-5}, {"material.bending_warp": 5e-4}]
    table = flexsurf.sweep(small_drop, cases, backend="ray", workers=2)
    check_rows_equal_single_runs(table, small_drop, cases)
