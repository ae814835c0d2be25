"""Shared fixtures: the repository, the command-line binary and a small, quick ball drop."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

import flexsurf

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def root() -> Path:
    """The repository root."""
    return ROOT


@pytest.fixture(scope="session")
def cli() -> Path:
    """The ``flexsurf`` command-line binary: ``$FLEXSURF_CLI``, else ``target/release/flexsurf`` (built if
    missing, with the workspace's own cargo settings)."""
    env = os.environ.get("FLEXSURF_CLI")
    if env:
        return Path(env)
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    path = target / "release" / "flexsurf"
    if not path.exists():
        cargo = shutil.which("cargo")
        assert cargo, "the CLI comparison needs cargo or $FLEXSURF_CLI"
        subprocess.run([cargo, "build", "--release", "-p", "flexsurf-cli"], cwd=ROOT, check=True)
    return path


@pytest.fixture
def small_drop() -> dict:
    """The ball drop on an 11 × 11 grid for 40 steps, frames every 20 (a second or so)."""
    d = flexsurf.scene_dict(ROOT / "scenes" / "ball_drop.toml")
    d["sheet"]["nodes"] = [11, 11]
    d["time"]["steps"] = 40
    d["time"]["output_every"] = 20
    d["output"]["image_size"] = [160, 120]
    return d


@pytest.fixture
def small_drop_file(tmp_path: Path, small_drop: dict) -> Path:
    """``small_drop`` written as a TOML file in the scenes folder's stead (same keys, same values)."""
    lines = []
    top = {k: v for k, v in small_drop.items() if not isinstance(v, (dict, list)) or k == "gravity"}
    for k, v in top.items():
        lines.append(f"{k} = {toml_value(v)}")
    for k, v in small_drop.items():
        if isinstance(v, dict):
            lines.append(f"[{k}]")
            lines.extend(f"{kk} = {toml_value(vv)}" for kk, vv in v.items())
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            for item in v:
                lines.append(f"[[{k}]]")
                lines.extend(f"{kk} = {toml_value(vv)}" for kk, vv in item.items())
    path = tmp_path / "small_drop.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def toml_value(v) -> str:
    """A Python value as TOML (enough for the scenes of these tests)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(v)
