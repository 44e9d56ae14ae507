"""The protocol every analysis of a recorded session follows (no rclpy).

An analysis is one module of this package with one object that has a ``name``,
a ``title``, the ``inputs`` it needs, and ``run`` / ``write`` / ``summary`` /
``finding``; :mod:`tribo_bringup.analyses` registers it. The session report runs
the registered analyses through this protocol alone (its sections are generic),
and ``tribo campaign analyse`` may do the same; each analysis calls the Python API
its command is a shell over, so their numbers are the command's.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

Progress = Callable[[str], None]


def _quiet(_: str) -> None:
    """Progress sink that drops the lines."""


class AnalysisResult(Protocol):
    """What the API's results offer (:mod:`tribo_estimation.results`, :mod:`tribo_nvct.results`)."""

    def write(self, directory: str | Path) -> list[Path]:
        """Write the command's result files into ``directory``; return them."""
        ...

    def plot(self, directory: str | Path) -> list[Path]:
        """Draw the command's figures into ``directory``; return them."""
        ...

    def summary(self) -> Mapping[str, object]:
        """Return the headline numbers (SI; keys name the unit where not SI)."""
        ...


@dataclass(frozen=True)
class AnalysisInputs:
    """What an analysis of one session may be given.

    Attributes
    ----------
    source : Path
        The session (a bag; or a rig CSV / counts CSV for the analyses that read one).
    rig : Path or None
        RIG.yaml of the rig (the analyses with input ``rig``).
    nvct : Path or None
        NVCT.yaml of the test (the analyses with input ``nvct``).
    window : tuple of float
        (start, duration) [s] of the rig streams from the first sample (duration 0:
        to the end), for the analyses that take a window.
    progress : callable
        Receives progress lines.
    """

    source: Path
    rig: Path | None = None
    nvct: Path | None = None
    window: tuple[float, float] = (0.0, 0.0)
    progress: Progress = field(default=_quiet, compare=False)


class Analysis(Protocol):
    """One analysis of a recorded session.

    Attributes
    ----------
    name : str
        Registry key and output directory name (``friction``, ``wear``, ...).
    title : str
        Section title in the report.
    inputs : tuple of str
        What it needs: ``rig`` / ``nvct`` (a config of :class:`AnalysisInputs`) or a
        topic of the bag (names starting with ``/``).
    on_request : bool
        Runs in a report only when asked for (a long analysis); else by default.
    """

    name: str
    title: str
    inputs: tuple[str, ...]
    on_request: bool

    def call(self, inp: AnalysisInputs) -> str:
        """Return the library call it makes, in one line (shown with the results)."""
        ...

    def run(self, inp: AnalysisInputs) -> AnalysisResult:
        """Run the analysis (raises the packages' specific errors on bad input)."""
        ...

    def summary(self, result: AnalysisResult) -> dict[str, object]:
        """Return its numbers for results.json (SI; keys name the unit where not SI)."""
        ...

    def finding(self, result: AnalysisResult) -> str:
        """Return the finding in one line ('' when it has none)."""
        ...


def write(result: AnalysisResult, directory: Path) -> tuple[list[Path], list[Path]]:
    """Write a result's files and figures as its command does.

    Parameters
    ----------
    result : AnalysisResult
        The result.
    directory : Path
        Output directory.

    Returns
    -------
    tuple of (list of Path, list of Path)
        The files and the figures written.
    """
    return result.write(directory), result.plot(directory)


def missing(analysis: Analysis, inp: AnalysisInputs, topics: Mapping[str, int]) -> str:
    """Return why an analysis cannot run on these inputs ('' when it can).

    Parameters
    ----------
    analysis : Analysis
        The analysis.
    inp : AnalysisInputs
        The inputs given.
    topics : mapping of str to int
        Messages per topic in the bag.

    Returns
    -------
    str
        E.g. ``no RIG.yaml given (--rig)``, ``no /nvct/counts in the bag``.
    """
    for need in analysis.inputs:
        if need.startswith('/'):
            if not topics.get(need):
                return f'no {need} in the bag'
        elif getattr(inp, need, None) is None:
            return f'no {need.upper()}.yaml given (--{need})'
    return ''
