"""Stub of the extension module talus._talus (Rust, pyo3): every class,
method and function the package `talus` exports, with its documentation."""

import os
from typing import Any, Callable, Dict, Iterator, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

PathLike = Union[str, "os.PathLike[str]"]

__version__: str
mpi: bool
"""False: the module is serial (each process runs the whole case)."""

class InputError(ValueError):
    """Bad input: a case, a particle file, a mesh or a value set from Python.
    The message names the file, key or line, and the value (the command line's message)."""

class RunError(RuntimeError):
    """A run that went wrong (NaN, a particle leaving the domain). Raised after
    the failure checkpoint is written; the message names the particle and the checkpoint."""

class Simulation:
    """A talus simulation: a case built into particles and walls, stepped from Python.

    Stepping (`step`, `run_until`, `run_phase`, `run`) releases the GIL; Ctrl-C
    raises KeyboardInterrupt between two steps and leaves the simulation
    consistent (call again to go on). Arrays are copies, rows in order of
    particle id (`ids`)."""

    @staticmethod
    def from_file(path: PathLike, threads: Optional[int] = None, overrides: Optional[Sequence[str]] = None) -> "Simulation":
        """Build a simulation from a case file (TOML), validated as by `talus run`.
        threads: threads of the run (default: the cores available).
        overrides: values to change, as `talus run --set` ("material[0].friction=0.3").
        Raises InputError with the command line's message."""
    @staticmethod
    def from_toml(
        text: str,
        base_dir: Optional[PathLike] = None,
        name: str = "case",
        threads: Optional[int] = None,
        overrides: Optional[Sequence[str]] = None,
    ) -> "Simulation":
        """Build a simulation from the text of a case (TOML). Files the case names
        are found relative to base_dir (default "."); messages name the case
        <base_dir>/<name>.toml."""
    @staticmethod
    def from_dict(d: dict, base_dir: Optional[PathLike] = None, name: str = "case", threads: Optional[int] = None) -> "Simulation":
        """Build a simulation from a dict laid out as a case file
        ({"simulation": {...}, "material": [{...}], "particles": {...}, "wall": [...], "phase": [...]});
        the same keys, defaults and validation as TOML."""
    @staticmethod
    def restart(checkpoint: PathLike, case: Union[PathLike, "Simulation"], threads: Optional[int] = None) -> "Simulation":
        """Continue from a checkpoint written by a run of the same case (the case
        file, or a Simulation built from it). Raises InputError if the
        checkpoint belongs to another case."""
    def step(self, n: int = 1) -> None:
        """Advance n time steps (phase ends are applied as in a run; stepping goes on after the last phase)."""
    def run_until(self, t: float) -> None:
        """Step until the simulated time reaches t (s), to the nearest step."""
    def run_phase(self) -> Optional[str]:
        """Step until the current phase ends (its end actions applied, such as
        walls removed). Returns the name of the phase that ended, None if every phase was done."""
    def run(self, out: Optional[PathLike] = None, progress: bool = False) -> dict:
        """Run every remaining phase. With out, write the same files as
        `talus run --out` (probes.csv, snapshots, checkpoints, summary.json).
        Returns the summary (as summary())."""
    def summary(self) -> dict:
        """The summary as a dict (the keys of summary.json): analysis figures,
        counts, times, throughput, state_hash. After run, that run's summary;
        otherwise the figures so far."""
    def fields(
        self,
        width: float,
        kernel: str = "gauss",
        profile: Optional[str] = None,
        grid: Optional[Tuple[int, int, int]] = None,
        points: Optional[int] = None,
    ) -> Dict[str, npt.NDArray[np.float64]]:
        """Continuum fields of the present state (coarse-grained, as `talus
        fields` computes them from one snapshot): a dict of arrays, a row per
        point: "at" (m, P x 3), "density" (kg/m^3, P), "velocity" (m/s, P x 3),
        "stress", "kinetic_stress", "contact_stress" (Pa, P x 3 x 3,
        compression positive; [a, b] is the force's a component times the
        branch's b component). profile="x"|"y"|"z" (points, default 100)
        averages over the other two axes; grid=(nx, ny, nz) gives the cell
        centres, x fastest. kernel "gauss" (width: standard deviation, cut off
        at 3 widths) or "lucy" (width: radius)."""
    def state_hash(self) -> str:
        """Hash of every particle's id, position, velocity and spin (16 hex
        digits), the same as `talus run` reports for the same state."""
    def save_checkpoint(self, path: PathLike) -> None:
        """Write a checkpoint (replaced atomically); Simulation.restart(path, case)
        continues from it as the run would have."""
    def every(self, n_steps: int, fn: Callable[["Simulation"], Any]) -> None:
        """Call fn(sim) after every n_steps steps (when the step count is a
        multiple of it) during step, run_until, run_phase and run. An exception
        in fn stops the stepping and propagates."""
    def clear_callbacks(self) -> None:
        """Remove every callback added by every."""
    @property
    def time(self) -> float:
        """Simulated time (s)."""
    @property
    def step_count(self) -> int:
        """Steps made since the start of the case."""
    @property
    def phase(self) -> str:
        """Name of the current phase ("end" after the last)."""
    @property
    def phase_index(self) -> int:
        """Index of the current phase (the number of phases after the last)."""
    @property
    def dt(self) -> float:
        """The time step (s)."""
    @property
    def particle_count(self) -> int:
        """Number of particles."""
    @property
    def kinetic_energy(self) -> float:
        """Kinetic energy of the particles, translational and rotational (J)."""
    @property
    def contacts(self) -> int:
        """Particle-particle and particle-wall contacts at the last step."""
    @property
    def ids(self) -> npt.NDArray[np.uint64]:
        """Particle ids, ascending: the row order of every array (a copy)."""
    @property
    def positions(self) -> npt.NDArray[np.float64]:
        """Positions (m), N x 3, a copy."""
    @property
    def velocities(self) -> npt.NDArray[np.float64]:
        """Velocities (m/s), N x 3, a copy."""
    @property
    def spins(self) -> npt.NDArray[np.float64]:
        """Angular velocities (rad/s), N x 3, a copy."""
    @property
    def radii(self) -> npt.NDArray[np.float64]:
        """Radii (m; an ellipse's semi-major axis), a copy."""
    @property
    def masses(self) -> npt.NDArray[np.float64]:
        """Masses (kg), a copy."""
    @property
    def forces(self) -> npt.NDArray[np.float64]:
        """Total force on each particle at the last step, gravity included (N), N x 3, a copy."""
    @property
    def torques(self) -> npt.NDArray[np.float64]:
        """Torque on each particle at the last step (N m), N x 3, a copy."""
    def set_positions(self, ids: npt.ArrayLike, values: npt.ArrayLike) -> None:
        """Set the positions (m) of the particles ids (N ids, N x 3 values; all or
        none): finite and inside the domain, else InputError. The neighbour
        lists are rebuilt at the next step."""
    def set_velocities(self, ids: npt.ArrayLike, values: npt.ArrayLike) -> None:
        """Set the velocities (m/s) of the particles ids; finite, else InputError."""
    def set_spins(self, ids: npt.ArrayLike, values: npt.ArrayLike) -> None:
        """Set the angular velocities (rad/s) of the particles ids; finite, else InputError."""
    @property
    def walls(self) -> "Walls":
        """The walls by name: sim.walls["gate"]."""

class Walls:
    """The walls of a simulation by name (a mapping: walls["gate"], len, iteration over names, in)."""

    def __getitem__(self, name: str) -> "Wall": ...
    def __len__(self) -> int: ...
    def __contains__(self, name: str) -> bool: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]:
        """The wall names, in the case's order."""

class Wall:
    """One wall of a simulation: its load at the last step, its velocity (settable), whether it acts, remove()."""

    @property
    def name(self) -> str:
        """The wall's name."""
    @property
    def force(self) -> npt.NDArray[np.float64]:
        """Force of the particles on the wall at the last step (N), a 3-array."""
    @property
    def torque(self) -> npt.NDArray[np.float64]:
        """Torque of the particles on the wall about the origin at the last step (N m), a 3-array."""
    @property
    def active(self) -> bool:
        """Whether the wall still acts (False once removed)."""
    @property
    def velocity(self) -> npt.NDArray[np.float64]:
        """The wall's prescribed velocity (m/s); set it to move the wall from the next step on."""
    @velocity.setter
    def velocity(self, v: npt.ArrayLike) -> None: ...
    @property
    def axis_torque(self) -> Optional[float]:
        """Torque of the particles on the wall about its rotation axis at the last step (N m); None if it never turns."""
    @property
    def angular_velocity(self) -> Optional[float]:
        """Its rate of turning about its axis (rad/s), None if it never turns; set it to change the rate from the next step on."""
    @angular_velocity.setter
    def angular_velocity(self, rate: float) -> None: ...
    def remove(self) -> None:
        """Remove the wall: it stops acting from the next step on."""

def drag(case: PathLike, out: Optional[PathLike] = None) -> dict:
    """Run a drag case (the drag paper's study) over its seeded beds into out
    (default out/drag/<id>); returns its summary. Releases the GIL; Ctrl-C
    raises KeyboardInterrupt after the bed being run."""

def cloud(case: PathLike) -> dict:
    """The initial particles of a case, as a dict of arrays in order of id:
    ids, positions, velocities, spins, radii, masses."""
