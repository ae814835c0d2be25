"""Type stubs of the extension module ``flexsurf._flexsurf`` (compiled from ``crates/flexsurf-py``)."""

import os
from typing import Any, Mapping, Sequence, Union, overload

import numpy as np
import numpy.typing as npt

_Path = Union[str, "os.PathLike[str]"]
_Vec3 = Union[Sequence[float], npt.NDArray[np.float64]]
_MaterialArg = Union["Material", Mapping[str, Any], _Path, None]

__version__: str

class FlexsurfError(Exception):
    """Base class of the errors flexsurf raises."""

class SceneError(FlexsurfError):
    """A scene or material that cannot be read or used."""

    key: str
    """The dotted key the error is about (``"time.dt"``, ``"obstacle[0].sphere.radius"``)."""

class SimulationError(FlexsurfError):
    """A run or step that failed (divergence, a failed solve, an output that cannot be written)."""

class FolderError(FlexsurfError):
    """An output folder that cannot be used as it is: another run's outputs (pass ``overwrite=True``), files
    flexsurf did not write, a symbolic link inside it, or another run writing into it now."""

class FlexsurfWarning(UserWarning):
    """A value outside the usual range of fabrics (most often a unit slip) or a setting that will not work well;
    the message names the file and the key, as the command line's warnings do."""

class Scene:
    """A built scene: model, initial state and run settings, read and checked by the library."""

    @staticmethod
    def from_toml(path: _Path) -> Scene:
        """Reads, checks and builds the TOML scene at ``path`` (as ``flexsurf run`` does)."""
    @staticmethod
    def from_dict(d: Mapping[str, Any], file: _Path | None = None) -> Scene:
        """Checks and builds a scene given as a dict with the TOML's keys; ``file`` is the path it stands for."""
    @property
    def name(self) -> str: ...
    @property
    def warnings(self) -> list[str]:
        """The scene's warnings (each issued as a :class:`FlexsurfWarning` when it was read)."""
    @property
    def file(self) -> str: ...
    @property
    def grid(self) -> tuple[int, int]:
        """Nodes ``(M, N)`` of a scene of one sheet (raises ``ValueError`` for several sheets or panels)."""
    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of the position arrays: ``(M, N, 3)`` for one sheet, else ``(n, 3)`` over the model's nodes."""
    @property
    def panels(self) -> list[dict[str, Any]]:
        """Each sheet or panel: ``shape`` ``(M, N)``, ``nodes`` (``(M, N)`` int64, the node numbers of the
        ``(n, 3)`` arrays) and, for a sewn garment, ``name``."""
    @property
    def dt(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def output_every(self) -> int: ...
    @property
    def material(self) -> str: ...
    @property
    def fabric(self) -> dict[str, Any]:
        """The fabric constants (SI)."""
    @property
    def is_static(self) -> bool: ...
    @property
    def total_mass(self) -> float: ...

class Simulation:
    """A scene being stepped."""

    def __init__(self, scene: Scene) -> None: ...
    def step(self, n: int = 1) -> int:
        """Takes ``n`` steps with the GIL released; returns the step count reached."""
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """Node positions (m), shape ``Scene.shape``: ``(M, N, 3)`` for one sheet, else ``(n, 3)``."""
    def positions_into(self, out: npt.NDArray[np.float64]) -> None:
        """Writes the positions into a C-contiguous float64 array of shape ``Scene.shape``."""
    @property
    def velocities(self) -> npt.NDArray[np.float64]:
        """Node velocities (m/s), shape ``Scene.shape``."""
    @property
    def grid(self) -> tuple[int, int]: ...
    @property
    def step_count(self) -> int: ...
    @property
    def time(self) -> float: ...
    @property
    def dt(self) -> float: ...
    @property
    def pinned(self) -> list[tuple[int, int]] | list[int]:
        """Pinned nodes: ``(i, j)`` on one sheet, node numbers ``k`` otherwise."""
    @overload
    def move_pin(self, i: int, j: int, position: _Vec3) -> None:
        """Moves pinned node ``(i, j)`` of one sheet's grid to ``position`` (m, each coordinate within ±1e6)."""
    @overload
    def move_pin(self, k: int, position: _Vec3) -> None:
        """Moves pinned node ``k`` of any scene (the ``(n, 3)`` arrays' numbering) to ``position`` (m)."""
    @property
    def spring_nodes(self) -> list[tuple[int, int]] | list[int]:
        """The springs' nodes: ``(i, j)`` on one sheet, node numbers ``k`` otherwise."""
    @property
    def spring_targets(self) -> npt.NDArray[np.float64]:
        """Spring targets (m), shape ``(S, 3)``."""
    def set_spring_target(self, index: int, target: _Vec3) -> None:
        """Moves spring ``index``'s target to ``target`` (m, each coordinate within ±1e6) before the next step."""
    def energies(self) -> dict[str, float]:
        """``step``, ``time``, ``kinetic``, ``membrane``, ``bending``, ``potential``, ``contact`` (J)."""
    @property
    def contacts(self) -> int: ...
    @property
    def max_penetration(self) -> float: ...
    def timings(self) -> dict[str, npt.NDArray[np.float64]]:
        """Per-step ``wall``, ``assembly``, ``contact``, ``factorization``, ``solve`` (s), ``solves``, ``contacts``."""

class Material:
    """A fabric: SI constants and a display name."""

    def __init__(self, **kwargs: Any) -> None:
        """The keys of a scene's ``[material]`` table (``units``, ``preset``, ``file``, ``name``, constants)."""
    @staticmethod
    def from_file(path: _Path) -> Material: ...
    @staticmethod
    def paper_cotton() -> Material: ...
    @property
    def name(self) -> str: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __getattr__(self, name: str) -> Any: ...

def read_toml(path: _Path) -> dict[str, Any]:
    """The keys of a TOML file as a dict (unchecked)."""

def run_into(
    scene: Scene, out: _Path, overwrite: bool = False
) -> tuple[dict[str, Any], list[int], npt.NDArray[np.float64]]:
    """Runs ``scene`` into ``out``; the summary, the output steps and the frames ``(F,) + Scene.shape``."""

def kes(material: _MaterialArg = None, calibration: str = "kes") -> dict[str, Any]: ...
def cantilever(
    material: _MaterialArg = None,
    direction: str = "warp",
    width: float = 0.02,
    overhang: float | None = None,
    calibration: str = "kes",
) -> dict[str, Any]: ...
def cusick(
    material: _MaterialArg = None,
    specimen: float = 0.30,
    level: int = 1,
    index: int = 0,
    calibration: str = "kes",
) -> dict[str, Any]: ...
def fit(problem: _Path | dict[str, Any], file: _Path | None = None) -> dict[str, Any]:
    """Material constants that explain measured targets (``flexsurf fit``): ``{"problem": …, "report": …}``."""
