"""flexsurf from Python: thin flexible surfaces (cloth, paper, non-wovens).

The simulator is the Rust library of this repository, compiled into ``flexsurf._flexsurf``; this package adds
the Python side (``run``'s result, sweeps). See ``docs/python.md``.

- :class:`Scene` — a scene read from TOML (:meth:`Scene.from_toml`) or a dict with the same keys
  (:meth:`Scene.from_dict`), checked by the library; errors raise :class:`SceneError` naming the key, and
  unusual values (a unit slip) are issued as :class:`FlexsurfWarning` (``Scene.warnings`` lists them).
- :class:`Simulation` — step a scene, read positions and velocities as ``(M, N, 3)`` arrays, move pinned nodes
  and spring targets between steps.
- :func:`run` — run a scene as ``flexsurf run`` does; the summary as a dict and the frames as arrays (an output
  folder that cannot be used as it is raises :class:`FolderError`; ``overwrite=True`` replaces another run's).
- :func:`kes`, :func:`cantilever`, :func:`cusick` — the virtual textile tests; :func:`fit` — material constants
  from measured bending lengths, KES values and a Cusick DC, with standard errors and identifiability.
- :class:`Material` — a fabric from a file or from keyword arguments.
- :func:`sweep` — many independent runs on a process pool or on Ray, into a pandas DataFrame.
"""

from ._flexsurf import (
    FlexsurfError,
    FlexsurfWarning,
    FolderError,
    Material,
    Scene,
    SceneError,
    Simulation,
    SimulationError,
    __version__,
    cantilever,
    cusick,
    fit,
    kes,
    read_toml,
)
from ._run import RunResult, run, scene_dict, with_overrides
from ._sweep import sweep

__all__ = [
    "FlexsurfError",
    "FlexsurfWarning",
    "FolderError",
    "Material",
    "RunResult",
    "Scene",
    "SceneError",
    "Simulation",
    "SimulationError",
    "__version__",
    "cantilever",
    "cusick",
    "fit",
    "kes",
    "read_toml",
    "run",
    "scene_dict",
    "sweep",
    "with_overrides",
]
