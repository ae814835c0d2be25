"""``flexsurf.run`` and the helpers that turn a scene argument (a path, a dict or a Scene) into a Scene."""

from __future__ import annotations

import copy
import os
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Union

import numpy as np

from ._flexsurf import Scene, read_toml, run_into

SceneLike = Union[Scene, str, "os.PathLike[str]", Mapping[str, Any]]


@dataclass
class RunResult:
    """What :func:`run` returns.

    Attributes:
        summary: ``summary.json`` as a dict.
        steps: the output steps, shape ``(F,)``.
        frames: the node positions at those steps (m), shape ``(F, M, N, 3)`` for a scene of one sheet, else
            ``(F, n, 3)`` over its nodes (``Scene.shape`` after ``F``).
        out: the output directory, or ``None`` when the files went to a removed temporary directory.
    """

    summary: dict
    steps: np.ndarray
    frames: np.ndarray
    out: Path | None


def scene_dict(path: str | os.PathLike[str]) -> dict:
    """The keys of the TOML scene at ``path`` as a dict (unchecked), for building variants of it."""
    return read_toml(os.fspath(path))


def with_overrides(d: Mapping[str, Any], overrides: Mapping[str, Any]) -> dict:
    """A deep copy of the scene dict ``d`` with ``overrides`` set; each key is dotted
    (``"material.bending_warp"``, ``"time.steps"``, ``"obstacle.0.sphere.radius"``: a number indexes a list, and
    the number one past a list's end adds an entry: ``"obstacle.1.plane.point"`` on a scene with one obstacle).
    Tables a key names that are not there yet are made. A key that cannot be set (an empty part, a list indexed
    by a name or beyond its end, a number where a table should be) raises naming the key."""
    out = copy.deepcopy(dict(d))
    for key, value in overrides.items():
        if not isinstance(key, str):
            raise TypeError(f"override keys must be dotted strings, got {key!r}")
        parts = key.split(".")
        if "" in parts:
            raise ValueError(f"override {key!r}: a dotted key has no empty parts")
        node: Any = out
        for k, part in enumerate(parts):
            node = _override_step(node, key, parts, k, value)
    return out


def _override_step(node: Any, key: str, parts: list[str], k: int, value: Any) -> Any:
    """Sets ``value`` at ``parts[k]`` of ``node`` (the last part) or returns the table or list there (made if
    missing) for the next part."""
    part, last = parts[k], k == len(parts) - 1
    where = f"`{'.'.join(parts[:k])}`" if k else "the scene"
    fresh = None if last else ([] if parts[k + 1].isdigit() else {})
    if isinstance(node, list):
        if not part.isdigit():
            raise ValueError(f"override {key!r}: {where} is a list, indexed by 0, 1, …, not by {part!r}")
        i = int(part)
        if i > len(node):
            entries = "entry" if len(node) == 1 else "entries"
            raise IndexError(f"override {key!r}: {where} has {len(node)} {entries}: index {i} is beyond its end")
        if i == len(node):
            node.append(value if last else fresh)
        elif last:
            node[i] = value
        return node[i]
    if isinstance(node, Mapping):
        if last:
            node[part] = value
            return value
        return node.setdefault(part, fresh)
    raise TypeError(f"override {key!r}: {where} is {node!r}, not a table or a list")


def as_scene(scene: SceneLike, file: str | os.PathLike[str] | None = None) -> Scene:
    """A :class:`Scene` from a Scene, a path to a TOML file or a dict (``file``: what the dict stands for)."""
    if isinstance(scene, Scene):
        return scene
    if isinstance(scene, Mapping):
        return Scene.from_dict(dict(scene), os.fspath(file) if file is not None else None)
    return Scene.from_toml(scene_path(scene))


def scene_path(scene: Any, may_be: str = "a Scene, a path to a TOML scene or a dict of its keys") -> str:
    """``scene`` as a path string, or a ``TypeError`` that names what the scene argument ``may_be``."""
    try:
        return os.fspath(scene)
    except TypeError:
        raise TypeError(f"scene: expected {may_be}, got {type(scene).__name__}") from None


def run(scene: SceneLike, out: str | os.PathLike[str] | None = None, overwrite: bool = False) -> RunResult:
    """Runs a scene as ``flexsurf run SCENE --out OUT`` does, with the GIL released.

    ``scene`` is a :class:`Scene`, a path to a TOML scene or a dict of its keys. With ``out`` the usual files
    (``frames/``, ``energy.csv``, ``summary.json``, ``snapshots.png``) are written there, bit for bit those of
    the command line (``summary.json``'s wall times aside); without it they go to a temporary directory that is
    removed. A folder holding another run's outputs raises :class:`FolderError` unless ``overwrite=True``
    (which removes exactly the files that run wrote, as its ``manifest.json`` lists them); files flexsurf did
    not write, a symbolic link inside the folder or another run writing into it now raise it too. Raises
    :class:`SceneError` for a bad scene and :class:`SimulationError` for a failed run. Each of ``summary.json``'s
    ``warnings`` (cloth that went deeper inside an obstacle than the contact offset) is also issued as a
    :class:`RuntimeWarning`.
    """
    built = as_scene(scene)
    if out is None:
        with tempfile.TemporaryDirectory(prefix="flexsurf-") as tmp:
            summary, steps, frames = run_into(built, tmp)
        result = RunResult(summary, np.asarray(steps), frames, None)
    else:
        summary, steps, frames = run_into(built, os.fspath(out), overwrite=bool(overwrite))
        result = RunResult(summary, np.asarray(steps), frames, Path(out))
    # What the command line prints as warnings (``summary.json``'s ``warnings``: cloth deeper inside an obstacle
    # than the contact offset), as Python warnings.
    for message in summary.get("warnings", []):
        warnings.warn(message, RuntimeWarning, stacklevel=2)
    return result
