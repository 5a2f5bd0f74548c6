"""Rig inversion from Python (docs/python.md).

Load and evaluate rig graphs, learn a rig's approximation and invert joint targets to rig parameter
curves, with NumPy arrays. The same library code as the command lines graph-eval, rig-learn and
rig-invert: the same numbers, reports and error messages.
"""

import os
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, Tuple, Union

import numpy
import numpy.typing

_Path = Union[str, os.PathLike]
_Report = dict[str, Any]

class Error(Exception):
    """A user-facing error: the one-line message the command lines print after 'error: ' (a bad file,
    glob, value or option)."""

class Graph:
    """A rig graph (a YAML rig file) loaded into its own stateful instance."""

    @staticmethod
    def load(path: _Path, plugins: Sequence[str] = []) -> Graph:
        """Loads a rig file (docs/rig-format.md) after the built-in node types and the plugins named (as
        graph-eval --plugin). Raises riginv.Error with graph-eval's message for a bad file."""
    def evaluate(
        self,
        get: Union[None, str, Sequence[str]] = None,
        set: Optional[Mapping[str, Any]] = None,
        frames: Union[None, str, Iterable[float]] = None,
        *,
        threads: int = 1,
    ) -> dict[str, Any]:
        """Sets plugs, evaluates and returns {plug name: NumPy array}, as graph-eval --set/--get/--frames/--threads.

        get: plug names or globs ('*.worldMatrix'); None: every output plug.
        set: {plug: value}, values as in a rig file (degrees for angles, cm; [x, y, z]; a 4x4 matrix as
        rows; enum names); they stay set on the graph.
        frames: None (the current time, one frame), 'A:B[:STEP]', or a list of frame numbers; the scene
        time is set to each.
        threads: evaluation threads, as graph-eval --threads (1 serial, N parallel, 0 every core); the values
        do not depend on it (a crowd's characters evaluate in parallel, docs/crowds.md).
        Arrays are in user units: (F,) for numbers (float64; int64 for whole numbers and enum indices;
        bool), (F, 3) for vectors, (F, 4, 4) for matrices (translation in the last column), (F, N) and
        (F, N, 4, 4) for arrays, a list of F strings for strings."""
    def plugs(self, glob: str = "*") -> list[str]:
        """Names of the plugs a glob matches (after an evaluation, so array outputs are listed), as
        graph-eval --get sees them. Raises riginv.Error when nothing matches."""
    def node_types(self) -> list[str]:
        """Names of every node type the graph can use (built-ins and plugins)."""
    @property
    def file(self) -> str:
        """The rig file, as given to load()."""
    @property
    def time(self) -> float:
        """The scene time (frame) last evaluated."""

class Approximation:
    """A rig's learned approximation (docs/rig-learn.md): made by riginv.learn() or
    Approximation.load(), inverted with invert()."""

    @staticmethod
    def load(path: _Path) -> Approximation:
        """Reads an approximation file written by rig-learn or save() (docs/approximation-format.md)."""
    def save(self, path: _Path, allow_inexact: bool = False) -> None:
        """Writes the approximation file (through a temporary file, as rig-learn -o). An approximation
        whose validation exceeds epsilon is refused with riginv.Error unless allow_inexact (rig-learn
        --allow-inexact)."""
    def invert(
        self,
        targets: Union[Mapping[str, numpy.typing.NDArray[numpy.float64]], _Path],
        rig: _Path,
        map: Optional[_Path] = None,
        progress: Optional[Callable[[int, int], Any]] = None,
        *,
        plugins: Sequence[str] = [],
        frames: Optional[str] = None,
        take: Optional[str] = None,
        contacts: Optional[_Path] = None,
        threads: int = 1,
        no_partition: bool = False,
        block_by_block: bool = False,
        jacobian: str = "analytic",
        polish: int = 0,
        restart_every: int = 120,
        rest_starts: bool = False,
        hybrid: bool = False,
        term: str = "jointTarget",
    ) -> Tuple[numpy.typing.NDArray[numpy.float64], list[str], _Report]:
        """Inverts targets to the rig's parameters, as rig-invert, and returns (values, names, report).

        targets: a dict {joint: (F, 4, 4) float64 array of world matrices, cm}, frames numbered 0 to
        F - 1, or a clip path (.bvh, or .json as graph-eval writes world matrices).
        rig: the rig file the approximation was learned from; map: a map file (scale, joint renames,
        ignored joints, weights, and retarget: for a clip path; docs/retargeting.md).
        progress: called as progress(frames done, frames total), with the GIL held.
        plugins, frames: as rig-invert's --plugin and --frames ('A:B' in the clip's numbering).
        threads, no_partition, block_by_block, jacobian, polish, restart_every, rest_starts, hybrid, term: the
        solve settings, as rig-invert's flags of those names ('-' for '_'; a flag's keyword is True or False);
        threads counts the solver's threads (0: all cores; the values do not depend on it).
        values: an (F, P) float64 array in the curves' units (degrees, cm); names: its P parameter
        names; report: the dict rig-invert --report-json writes (curves.file is None: nothing is
        written). The GIL is released while solving; Ctrl-C stops it (between frames, seen every 0.1 s)."""
    @property
    def report(self) -> Optional[_Report]:
        """The dict rig-learn --report-json writes, for an approximation learned by riginv.learn()
        ('approximation' and 'written' name the file once saved); None for one loaded from a file."""
    @property
    def parameters(self) -> list[str]:
        """The modelled parameters' names, in composition order: the columns of invert()'s values."""
    @property
    def outputs(self) -> list[str]:
        """The output joints' names: the possible targets."""
    @property
    def held(self) -> dict[str, float]:
        """The plugs held at a value while learning (rig-learn --set), in the rig file's units."""
    @property
    def rig_file(self) -> str:
        """The rig file it was learned from, as given then."""
    @property
    def file(self) -> Optional[str]:
        """The file it was loaded from or saved to, or None."""

def learn(
    rig_path: _Path,
    params: Sequence[str],
    outputs: Sequence[str] = [],
    epsilon: float = 0.001,
    orderer: str = "structured",
    progress: Optional[Callable[[float, float], Any]] = None,
    *,
    plugins: Sequence[str] = [],
    world_space: bool = False,
    set: Optional[Mapping[str, float]] = None,
    ranges: Optional[Mapping[str, Sequence[float]]] = None,
    ranges_from: Optional[_Path] = None,
    ranges_map: Optional[_Path] = None,
    ranges_take: Optional[str] = None,
    ranges_frames: Optional[str] = None,
) -> Approximation:
    """Learns a rig's approximation, as rig-learn, and returns an Approximation.

    params: parameter plug globs ('L_arm_*.rotate?'); outputs: output joint globs (empty: every joint).
    epsilon: the validation threshold, cm per unit of a parameter; orderer: 'structured' or 'talk';
    plugins, world_space: rig-learn's --plugin and --world-space; set: {plug: value}, plugs held at a
    value while learning, in the rig file's units (rig-learn --set); ranges: {parameter glob: (min, max)},
    the range a control without declared limits is learned over, in the rig file's units (a spec's ranges:,
    rig-learn --range; each glob must match such a parameter).
    ranges_from: a clip whose motion the ranges must cover (rig-learn --ranges-from): learned once, the clip
    inverted on it, each range the clip leaves widened (10% of its width past the values reached), learned
    again; ranges_map, ranges_take, ranges_frames read the clip as invert()'s map, take and frames do.
    report['ranges_from'] says what was widened.
    progress: called as progress(fraction done, 1.0), with the GIL held.
    An approximation over epsilon is returned (report['within_epsilon'] is False) but save() refuses
    it. The GIL is released while learning; Ctrl-C stops it (between learning steps, seen every 0.1 s)."""
