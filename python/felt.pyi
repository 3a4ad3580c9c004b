"""felt, the field-expression language and volume renderer, from Python.

A Session runs felt scripts in this process. Values come back as Python values; caches and
sampled fields as NumPy arrays (felt.Grid), rendered images through read_image. See the
README's "From Python" section.
"""

from os import PathLike
from typing import Any, Mapping, Sequence

import numpy as np
import numpy.typing as npt

__version__: str

ParamValue = int | float | bool | str | tuple[float, float, float] | Sequence[float]
Vector = tuple[float, float, float]

class FeltError(Exception):
    """A script failed. str(error) is the report `felt run` prints."""

    diagnostics: list[Diagnostic]

class Diagnostic:
    """One diagnostic of a check or a run."""

    severity: str
    """"error" or "warning"."""
    message: str
    help: str | None
    file: str | None
    line: int | None
    """1-based, as in the CLI's report; None for a diagnostic about no place in a source."""
    column: int | None
    source_line: str | None

class Grid:
    """Cells read from felt: values[i, j, k] (or values[i, j, k, c]) is the cell centred at
    origin + (i + 0.5, j + 0.5, k + 0.5) * cell along the domain's axes."""

    values: npt.NDArray[np.float32]
    origin: Vector
    cell: Vector
    lengths: Vector
    orientation: Vector
    """The domain's rotation vector (axis times angle in radians)."""
    def __array__(self, dtype: Any = None, copy: bool | None = None) -> np.ndarray: ...

class Session:
    """A memory budget, a worker pool and an interrupt flag shared by its runs.

    Each run starts from a fresh felt session (nothing carries over but caches given with
    set_cache); get and sample read the globals of the latest run.
    """

    output: str
    """What the latest run printed."""
    warnings: list[Diagnostic]
    """The warnings of the latest run."""

    def __init__(self, memory_limit: int | None = None, threads: int | None = None) -> None:
        """memory_limit: the budget in bytes (default: half the memory felt may use).
        threads: worker threads of this Python thread's pool (default: all cores); the first
        session made on a thread sets it."""
    def run_file(
        self, path: str | PathLike[str], params: Mapping[str, ParamValue] | None = None
    ) -> str:
        """Runs a script file; returns what it printed. Raises FeltError, or
        KeyboardInterrupt on Ctrl-C."""
    def run(
        self,
        source: str,
        params: Mapping[str, ParamValue] | None = None,
        name: str = "<python>",
    ) -> str:
        """Runs script text as a file called name; imports are relative to the current
        directory. Returns what it printed."""
    def check(
        self,
        source: str | None = None,
        path: str | PathLike[str] | None = None,
        params: Mapping[str, ParamValue] | None = None,
        name: str = "<python>",
    ) -> list[Diagnostic]:
        """Checks a script without running it; returns all its diagnostics."""
    def get(self, name: str) -> Any:
        """A global of the latest run: int, float, bool, str, a vector as a 3-tuple, a matrix
        as three rows, an array as a list, a cache as a Grid."""
    def sample(self, expression: str, domain: str | tuple[Vector, Vector, float]) -> Grid:
        """A field (a global's name or an expression) at the cell centres of a domain: a
        domain global's name or (origin, lengths, cell)."""
    def set_cache(
        self,
        name: str,
        array: npt.ArrayLike,
        origin: Vector,
        cell: float,
        background: float = 0.0,
    ) -> None:
        """Declares a cache global for the next runs from an array indexed [i, j, k] (or
        [i, j, k, c] with 3 or 9 components). Values must be finite."""

def read_image(path: str | PathLike[str]) -> dict[str, np.ndarray]:
    """The channels of an OpenEXR image `render` wrote (R, G, B, A and every AOV), by name,
    each a float32 array indexed [row, column] with row 0 at the top."""
    ...
