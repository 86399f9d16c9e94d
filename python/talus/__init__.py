"""talus: a discrete element method engine for granular flow, from Python.

    import talus
    sim = talus.Simulation.from_file("cases/H1-small.toml")
    sim.every(1000, lambda s: print(s.time, s.walls["hopper"].force))
    summary = sim.run(out="out/H1-small")

Everything is in the extension module ``talus._talus`` (Rust, pyo3); its stub
``_talus.pyi`` documents each item. The module is serial: under ``mpirun -n P
python script.py`` every process runs the whole case by itself (use the
``talus`` command under mpirun for a decomposed run); ``talus.mpi`` is False.
"""

import os as _os
import warnings as _warnings

from ._talus import (  # noqa: F401
    InputError,
    RunError,
    Simulation,
    Wall,
    Walls,
    __version__,
    cloud,
    drag,
    mpi,
)

__all__ = ["Simulation", "Wall", "Walls", "InputError", "RunError", "drag", "cloud", "mpi", "__version__"]


def _ranks_in_job() -> int:
    for key in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE", "MV2_COMM_WORLD_SIZE"):
        v = _os.environ.get(key)
        if v and v.isdigit():
            return int(v)
    return 1


if _ranks_in_job() > 1:
    _warnings.warn(
        f"talus: this Python module is serial, but the job has {_ranks_in_job()} MPI processes: "
        "each runs the whole case by itself. For a decomposed run use `mpirun -n P talus run CASE`.",
        RuntimeWarning,
        stacklevel=2,
    )
