"""cellmech: virtual mechanical tests on single living cells, from Python.

A nonlinear finite-element simulator of micropipette tension, microplate compression and
AFM indentation of single cells, written in Rust. This package is a thin layer over the
same library as the ``cellmech`` command-line tool: a scenario file gives the same model,
the same messages and the same numbers here as with ``cellmech run``.

Build an analysis from a scenario file or TOML text::

    import cellmech
    analysis = cellmech.load("examples/suspended-tension.toml")

or from keyword arguments (parameter names as in ``cellmech params suspended-cell``;
dotted names as a dict or with ``__`` for the dots; quantities as strings with units)::

    cell = cellmech.SuspendedCell(core_divisions=4, shell_layers=2, outer_layers=2,
                                  cytoplasm__shear_modulus="0.17 kPa")
    analysis = cellmech.experiment(cell, cellmech.MicropipetteTension())

then run it (the GIL is released while it solves) and read the results as numpy arrays::

    result = analysis.run("out/tension", progress=print)
    result.force, result.displacement      # the test curve (nN, um)
    result.curve["pipette_right_force_x_nN"]  # any column of curve.csv
    result.to_pandas()                     # the same as a DataFrame (needs pandas)

Errors: an invalid scenario or parameter raises :class:`ScenarioError` (a ``ValueError``)
with the CLI's message, naming the key. A run that cannot start or write raises
:class:`RunError`. An analysis that stops early (no convergence) is *not* an exception by
default, as with the CLI: the returned :class:`Result` has ``status == "failed"``,
``error`` says why, and every converged increment is in it; pass ``check=True`` to raise
:class:`AnalysisError` instead (its ``result`` attribute holds the same :class:`Result`).
"""

from __future__ import annotations

import json
import os
from typing import Any, Callable, Dict, List, Mapping, Optional, Union

import numpy as np

from . import _cellmech
from ._cellmech import AnalysisError, RunError, ScenarioError

__version__: str = _cellmech.__version__

__all__ = [
    "AdherentCell",
    "AfmIndentation",
    "Analysis",
    "AnalysisError",
    "Cell",
    "FitResult",
    "MicropipetteTension",
    "MicroplateCompression",
    "Prestress",
    "Protocol",
    "Result",
    "RunError",
    "ScenarioError",
    "SuspendedCell",
    "adherent_cell",
    "afm_indentation",
    "experiment",
    "fit",
    "load",
    "micropipette_tension",
    "microplate_compression",
    "parameters",
    "parse",
    "prestress",
    "suspended_cell",
]

PathLike = Union[str, "os.PathLike[str]"]
ProgressCallback = Callable[[Dict[str, Any]], Any]


class Result:
    """The results of a run, read from what the run wrote into ``out_dir``.

    Attributes:
        status: ``"completed"`` or ``"failed"`` (the analysis stopped early).
        error: why the analysis stopped early, or ``None``.
        out_dir: the directory with every output file (``curve.csv``, ``summary.json``, ...).
        summary: ``summary.json`` as a dict (inputs, cell parameters, protocol results,
            convergence statistics, timings).
        curve: every column of ``curve.csv`` (one row per converged increment) as a dict
            of name -> 1-D float64 numpy array; names carry units (``..._nN``, ``..._um``).
        curve_columns: the column names of ``curve.csv`` in file order.
        test_curve: the protocol's own curve (``tension.csv``/``compression.csv``:
            ``displacement_um``, ``strain``, ``force_nn``, ``normalised_stiffness_kpa``,
            nucleus strain and aspect ratio) as a dict of numpy arrays; empty without a
            protocol.
        filaments: ``filaments.csv`` (one row per filament per increment: family, force at
            the FA end, max/min force, state, straightness, strain) as a dict of numpy
            arrays (numbers as float64 with NaN for empty fields, words as str arrays), or
            ``None`` for a model without filaments.
        filament_columns: the column names of ``filaments.csv`` (empty without filaments).
    """

    status: str
    error: Optional[str]
    out_dir: str
    summary: Dict[str, Any]
    curve: Dict[str, np.ndarray]
    curve_columns: List[str]
    test_curve: Dict[str, np.ndarray]
    filaments: Optional[Dict[str, np.ndarray]]
    filament_columns: List[str]

    def __init__(self, raw: Mapping[str, Any]) -> None:
        self.status = raw["status"]
        self.error = raw["error"]
        self.out_dir = os.fspath(raw["out_dir"])
        self.summary = json.loads(raw["summary_json"])
        names, columns = raw["curve"]
        self.curve_columns = list(names)
        self.curve = {n: np.asarray(c, dtype=np.float64) for n, c in zip(names, columns)}
        points = (self.summary.get("protocol") or {}).get("curve") or []
        keys = list(points[0].keys()) if points else []
        self.test_curve = {
            k: np.asarray([p[k] if p[k] is not None else np.nan for p in points], dtype=np.float64)
            for k in keys
        }
        if raw["filaments"] is None:
            self.filaments = None
            self.filament_columns = []
        else:
            fnames, fcolumns = raw["filaments"]
            self.filament_columns = list(fnames)
            self.filaments = {
                n: (np.asarray(c, dtype=np.float64) if c and isinstance(c[0], float) else np.asarray(c))
                for n, c in zip(fnames, fcolumns)
            }

    @property
    def ok(self) -> bool:
        """Whether the analysis completed."""
        return self.status == "completed"

    @property
    def displacement(self) -> np.ndarray:
        """The test curve's displacement (um): elongation, plate travel or indentation."""
        return self.test_curve.get("displacement_um", np.zeros(0))

    @property
    def force(self) -> np.ndarray:
        """The test curve's force on the moving tool (nN)."""
        return self.test_curve.get("force_nn", np.zeros(0))

    @property
    def last_force_nn(self) -> Optional[float]:
        """Force at the last point of the test curve (nN), as in ``summary.json``."""
        last = (self.summary.get("protocol") or {}).get("last")
        return None if last is None else float(last["force_nn"])

    @property
    def files(self) -> List[str]:
        """The files written, relative to ``out_dir``."""
        return list(self.summary.get("files", []))

    def to_pandas(self, table: str = "curve") -> Any:
        """One of the tables as a ``pandas.DataFrame``.

        Args:
            table: ``"curve"`` (curve.csv), ``"test"`` (the protocol's test curve) or
                ``"filaments"`` (filaments.csv).

        Raises:
            ImportError: pandas is not installed (``pip install pandas``).
            ValueError: an unknown table, or ``"filaments"`` for a model without filaments.
        """
        try:
            import pandas as pd
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError(
                "Result.to_pandas() needs pandas: pip install pandas "
                "(the arrays are in Result.curve, .test_curve and .filaments without it)"
            ) from e
        if table == "curve":
            return pd.DataFrame({n: self.curve[n] for n in self.curve_columns})
        if table == "test":
            return pd.DataFrame(self.test_curve)
        if table == "filaments":
            if self.filaments is None:
                raise ValueError("this model has no filaments")
            return pd.DataFrame({n: self.filaments[n] for n in self.filament_columns})
        raise ValueError(f'table: expected "curve", "test" or "filaments"; found {table!r}')

    def __repr__(self) -> str:
        last = self.last_force_nn
        tail = f", last force {last:.4g} nN" if last is not None else ""
        err = f", error: {self.error}" if self.error else ""
        return f"<cellmech.Result {self.status}: {len(self.curve_columns)} columns x {self._rows()} increments{tail}{err}>"

    def _rows(self) -> int:
        return len(next(iter(self.curve.values()))) if self.curve else 0


class Analysis:
    """A model with its protocol, ready to run (from :func:`load`, :func:`parse` or
    :func:`experiment`).

    Attributes:
        title: the scenario's title.
        origin: where it came from (a path, ``"<string>"``, ``"<cellmech.experiment>"``).
        steps: the names of the analysis steps, in order.
        mesh_size: (nodes, elements) of the model's mesh.
        toml: the scenario TOML of a keyword-built experiment (``cellmech run`` runs the
            same file to the same numbers), ``None`` for a loaded file.
    """

    def __init__(self, native: Any) -> None:
        self._native = native

    @property
    def title(self) -> str:
        return self._native.title

    @property
    def origin(self) -> str:
        return self._native.origin

    @property
    def steps(self) -> List[str]:
        return list(self._native.steps)

    @property
    def mesh_size(self) -> tuple:
        return tuple(self._native.mesh_size)

    @property
    def toml(self) -> Optional[str]:
        return self._native.toml

    def run(
        self,
        out_dir: PathLike,
        progress: Optional[ProgressCallback] = None,
        *,
        check: bool = False,
        threads: int = 0,
    ) -> Result:
        """Runs the analysis, writing every output into ``out_dir`` as ``cellmech run`` does.

        The GIL is released while the solver works, so other Python threads go on.

        Args:
            out_dir: output directory (created if needed).
            progress: called after every converged increment with a dict: ``step`` (index),
                ``step_name``, ``increment`` (in the step, from 1), ``step_time`` (0..1),
                ``total_time``, ``iterations`` (Newton iterations of the increment),
                ``energy`` (nN um). An exception it raises stops further calls and is
                raised when the run returns.
            check: raise :class:`AnalysisError` when the analysis stops early instead of
                returning a ``Result`` with ``status == "failed"``.
            threads: solver threads (0: all cores).

        Returns:
            The :class:`Result` (also when the analysis stopped early, unless ``check``).

        Raises:
            RunError: the model could not be built or the outputs not written.
            AnalysisError: with ``check=True``, the analysis stopped early.
        """
        if threads < 0:
            raise ValueError(f"threads: expected 0 (all cores) or more; found {threads}")
        raw = self._native.run(os.fspath(out_dir), progress, threads)
        result = Result(raw)
        if check and result.error is not None:
            err = AnalysisError(result.error)
            err.result = result  # type: ignore[attr-defined]
            raise err
        return result

    def __repr__(self) -> str:
        return f"<cellmech.Analysis {self.title!r} from {self.origin}: steps {', '.join(self.steps)}>"


def load(path: PathLike) -> Analysis:
    """Reads, parses and resolves a scenario file (relative mesh paths are relative to it).

    Raises:
        ScenarioError: the file cannot be read or is invalid (the CLI's message: file,
            line and key).
    """
    return Analysis(_cellmech.load(os.fspath(path)))


def parse(text: str, origin: str = "<string>", base_dir: Optional[PathLike] = None) -> Analysis:
    """Parses and resolves scenario TOML text.

    Args:
        text: the scenario, as in a ``.toml`` file.
        origin: its name in messages.
        base_dir: directory that relative mesh paths are relative to (default ``.``).

    Raises:
        ScenarioError: the text is invalid (message with line and key).
    """
    return Analysis(
        _cellmech.parse(text, origin, None if base_dir is None else os.fspath(base_dir))
    )


def parameters(name: str) -> str:
    """The declared parameters of a cell model or protocol as commented TOML with every
    default (``"suspended-cell"``, ``"adherent-cell"``, ``"micropipette-tension"``,
    ``"microplate-compression"``, ``"afm-indentation"``), as ``cellmech params NAME``."""
    return _cellmech.parameters(name)


def _merge(section: str, params: Optional[Mapping[str, Any]], kwargs: Mapping[str, Any]) -> Dict[str, Any]:
    merged: Dict[str, Any] = {}
    for source in (params or {}, kwargs):
        for k, v in source.items():
            if not isinstance(k, str):
                raise TypeError(f"`{section}`: parameter names must be strings; found {k!r}")
            key = k.replace("__", ".")
            if key in merged:
                raise ScenarioError(f"<cellmech.{section}>: `{section}.{key}`: given twice")
            merged[key] = v
    return merged


class Cell:
    """A built-in cell model with its parameters, checked against the declared table.

    Use :class:`SuspendedCell` or :class:`AdherentCell`. ``params`` (the nested ``[cell]``
    section, with ``model``) is what :func:`experiment` writes into the scenario.
    """

    model: str = ""

    def __init__(self, params: Optional[Mapping[str, Any]] = None, **kwargs: Any) -> None:
        self.params: Dict[str, Any] = _cellmech.check_cell(self.model, _merge("cell", params, kwargs))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.params!r})"


class SuspendedCell(Cell):
    """The suspended bendo-tensegrity cell (``[cell] model = "suspended"``).

    Parameters are those of ``cellmech params suspended-cell`` (``cellmech.parameters(
    "suspended-cell")``): give dotted names in the ``params`` dict
    (``{"cytoplasm.shear_modulus": "0.2 kPa"}``) or as keywords with ``__`` for the dots
    (``cytoplasm__shear_modulus="0.2 kPa"``). Quantities are strings with units; counts,
    plain numbers and words as Python values. Unknown names, wrong units and values out of
    range raise :class:`ScenarioError` naming the key (with "did you mean").
    """

    model = "suspended"


class AdherentCell(Cell):
    """The adherent bendo-tensegrity cell (``[cell] model = "adherent"``); parameters as
    ``cellmech params adherent-cell``, given as for :class:`SuspendedCell`."""

    model = "adherent"


class Protocol:
    """A built-in virtual experiment with its parameters, checked against its table.

    Use :class:`MicropipetteTension`, :class:`MicroplateCompression`,
    :class:`AfmIndentation` or :class:`Prestress`.
    """

    kind: str = ""

    def __init__(self, params: Optional[Mapping[str, Any]] = None, **kwargs: Any) -> None:
        self.params: Dict[str, Any] = _cellmech.check_protocol(self.kind, _merge("protocol", params, kwargs))

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.params!r})"


class MicropipetteTension(Protocol):
    """Micropipette tension of the suspended cell (parameters: ``cellmech params
    micropipette-tension``, e.g. ``elongation="6.3 um"``, ``increments=20``)."""

    kind = "micropipette-tension"


class MicroplateCompression(Protocol):
    """Microplate compression of the suspended cell (``cellmech params
    microplate-compression``)."""

    kind = "microplate-compression"


class AfmIndentation(Protocol):
    """AFM indentation of the adherent cell (``cellmech params afm-indentation``)."""

    kind = "afm-indentation"


class Prestress(Protocol):
    """Only the prestress step (3-2-1 supports, no tool)."""

    kind = "prestress"


def suspended_cell(params: Optional[Mapping[str, Any]] = None, **kwargs: Any) -> SuspendedCell:
    """Same as :class:`SuspendedCell`."""
    return SuspendedCell(params, **kwargs)


def adherent_cell(params: Optional[Mapping[str, Any]] = None, **kwargs: Any) -> AdherentCell:
    """Same as :class:`AdherentCell`."""
    return AdherentCell(params, **kwargs)


def micropipette_tension(params: Optional[Mapping[str, Any]] = None, **kwargs: Any) -> MicropipetteTension:
    """Same as :class:`MicropipetteTension`."""
    return MicropipetteTension(params, **kwargs)


def microplate_compression(params: Optional[Mapping[str, Any]] = None, **kwargs: Any) -> MicroplateCompression:
    """Same as :class:`MicroplateCompression`."""
    return MicroplateCompression(params, **kwargs)


def afm_indentation(params: Optional[Mapping[str, Any]] = None, **kwargs: Any) -> AfmIndentation:
    """Same as :class:`AfmIndentation`."""
    return AfmIndentation(params, **kwargs)


def prestress() -> Prestress:
    """Same as :class:`Prestress`."""
    return Prestress()


def experiment(
    cell: Cell,
    protocol: Protocol,
    *,
    title: Optional[str] = None,
    output: Optional[Mapping[str, Any]] = None,
    families: Optional[Mapping[str, Any]] = None,
) -> Analysis:
    """A cell and a protocol as an :class:`Analysis`.

    The scenario TOML is composed (``Analysis.toml``) and resolved by the same parser as a
    file, so ``cellmech run`` on that text gives the same numbers.

    Args:
        cell: a :class:`SuspendedCell` or :class:`AdherentCell`.
        protocol: a :class:`Protocol`.
        title: title for outputs and plots.
        output: the ``[output]`` section, e.g. ``{"vtk_every": 0}`` (no ParaView frames).
        families: the ``[families]`` section, e.g. ``{"microtubule": {"enabled": False}}``.

    Raises:
        ScenarioError: the protocol does not fit the cell, or a section is invalid.
    """
    if not isinstance(cell, Cell):
        raise TypeError(f"cell: expected a cellmech.SuspendedCell or AdherentCell; found {type(cell).__name__}")
    if not isinstance(protocol, Protocol):
        raise TypeError(f"protocol: expected a cellmech protocol (e.g. MicropipetteTension()); found {type(protocol).__name__}")
    return Analysis(
        _cellmech.experiment(
            cell.params,
            protocol.params,
            title,
            None if output is None else dict(output),
            None if families is None else dict(families),
        )
    )


FitProgressCallback = Callable[[Dict[str, Any]], Any]


class FitResult:
    """What :func:`fit` found, read from ``fit.json`` (``cellmech fit`` writes the same).

    Values are in cellmech's internal units (um, nN, kPa; pure numbers as fractions):
    ``units[i]`` names the unit of parameter ``i``.

    Attributes:
        keys: the fitted parameters' dotted scenario keys, in the fit file's order.
        units: their units.
        values: fitted values (float64 array).
        errors: standard errors (NaN where the data do not determine them).
        start, lower, upper: the start values and bounds (arrays).
        at_bound: whether each value ended on a bound (its error is then meaningless).
        correlation: correlation matrix of the estimates (p x p array, NaN if undetermined).
        covariance: covariance matrix in the parameters' units.
        rms, r_squared, sigma: RMS residual, coefficient of determination, and
            sqrt(SSR / (m - p)).
        evaluations: FE evaluations the optimiser made (cached ones included).
        runs: FE runs solved by this call (the others came from ``out_dir/runs/``).
        iterations, stop, converged: the optimiser's iterations, why it stopped
            (``"cost-change"``, ``"step-size"``, ``"gradient"``, ``"no-progress"``,
            ``"max-evaluations"``, ``"max-iterations"``) and whether that is convergence.
        wall_time_s: wall time of this call.
        curve: the measured and fitted curve as numpy arrays: ``x``, ``measured``,
            ``fitted`` (the model at the fitted values, at the measured x), ``in_range``
            (bool), and the model's own curves ``model_x``/``model_y`` (fitted values) and
            ``start_x``/``start_y`` (start values).
        history: iteration history: ``iteration``, ``evaluations``, ``cost``, ``rms``,
            ``damping`` (arrays) and ``values`` (iterations x p array).
        out_dir: the output directory; ``raw``: ``fit.json`` as a dict.
    """

    keys: List[str]
    units: List[str]
    values: np.ndarray
    errors: np.ndarray
    start: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    at_bound: np.ndarray
    correlation: np.ndarray
    covariance: np.ndarray
    rms: float
    r_squared: float
    sigma: Optional[float]
    evaluations: int
    runs: int
    iterations: int
    stop: str
    converged: bool
    wall_time_s: float
    curve: Dict[str, np.ndarray]
    history: Dict[str, np.ndarray]
    out_dir: str
    raw: Dict[str, Any]

    def __init__(self, fit_json: str, out_dir: str) -> None:
        raw = json.loads(fit_json)
        self.raw = raw
        self.out_dir = out_dir
        params = raw["parameters"]
        p = len(params)
        self.keys = [q["key"] for q in params]
        self.units = [q["unit"] for q in params]

        def column(name: str) -> np.ndarray:
            return np.asarray([np.nan if q[name] is None else q[name] for q in params], dtype=np.float64)

        self.values = column("value")
        self.errors = column("standard_error")
        self.start = column("start")
        self.lower = column("lower")
        self.upper = column("upper")
        self.at_bound = np.asarray([q["at_bound"] for q in params], dtype=bool)
        nan = np.full((p, p), np.nan)
        self.correlation = nan.copy() if raw["correlation"] is None else np.asarray(raw["correlation"], dtype=np.float64)
        self.covariance = nan.copy() if raw["covariance"] is None else np.asarray(raw["covariance"], dtype=np.float64)
        self.rms = float(raw["rms"])
        self.r_squared = float("nan") if raw["r_squared"] is None else float(raw["r_squared"])
        self.sigma = raw["sigma"]
        self.evaluations = int(raw["evaluations"])
        self.runs = int(raw["fe_runs_solved"])
        self.iterations = int(raw["iterations"])
        self.stop = raw["stop"]
        self.converged = bool(raw["converged"])
        self.wall_time_s = float(raw["wall_time_s"])
        c = raw["curve"]
        self.curve = {
            k: np.asarray([np.nan if v is None else v for v in c[k]], dtype=np.float64)
            for k in ("x", "measured", "fitted", "model_x", "model_y", "start_x", "start_y")
        }
        self.curve["in_range"] = np.asarray(c["in_range"], dtype=bool)
        h = raw["history"]
        self.history = {
            k: np.asarray([np.nan if row[k] is None else row[k] for row in h], dtype=np.float64)
            for k in ("iteration", "evaluations", "cost", "rms", "damping")
        }
        self.history["values"] = np.asarray([row["values"] for row in h], dtype=np.float64).reshape(len(h), p)

    @property
    def parameters(self) -> Dict[str, Any]:
        """``key -> (value, standard error, unit)``."""
        return {k: (float(v), float(e), u) for k, v, e, u in zip(self.keys, self.values, self.errors, self.units)}

    def __repr__(self) -> str:
        parts = ", ".join(f"{k} = {v:.5g} ± {e:.2g} {u}" for k, (v, e, u) in self.parameters.items())
        state = "converged" if self.converged else f"not converged ({self.stop})"
        return f"<cellmech.FitResult {state}: {parts}; {self.evaluations} evaluations, {self.runs} FE runs solved>"


def fit(
    fit: Union[PathLike, str],
    out_dir: PathLike,
    progress: Optional[FitProgressCallback] = None,
    *,
    threads: int = 0,
    base_dir: Optional[PathLike] = None,
) -> FitResult:
    """Fits model parameters to a measured curve: ``cellmech fit FIT --out out_dir``.

    Args:
        fit: a fit file (TOML, see ``docs/fitting.md``), or the fit's TOML text itself
            (anything that contains a newline is taken as text).
        out_dir: output directory: the FE runs go to ``out_dir/runs/HASH/`` and are reused
            by a later call (an interrupted fit resumes), the report is ``fit.json``,
            ``fit-history.csv``, ``fit.csv``, ``fit.svg``/``fit.png`` and ``fit.md``.
        progress: called after every FE evaluation with a dict: ``evaluation``, ``values``,
            ``hash``, ``cached``, ``status``, ``rejected`` (why the run cannot be used, or
            None), ``rms``, ``wall_time_s``.
        threads: solver threads per FE run (0: all cores).
        base_dir: with TOML text, the directory ``base`` and ``data`` paths are relative
            to (default: the current directory).

    Returns:
        a :class:`FitResult`.

    Raises:
        ScenarioError: the fit file, its data or a parameter key is invalid.
        RunError: the fit could not proceed (the start run does not reach the fitted
            range, a derivative cannot be evaluated, outputs cannot be written).
    """
    out = os.fspath(out_dir)
    if isinstance(fit, str) and "\n" in fit:
        raw = _cellmech.fit_text(
            fit, out, "<string>", None if base_dir is None else os.fspath(base_dir), progress, threads
        )
    else:
        path = os.fspath(fit)
        if not os.path.exists(path):
            raise ScenarioError(f"{path}: expected a fit file or fit TOML text; found no such file")
        raw = _cellmech.fit_file(path, out, progress, threads)
    return FitResult(raw, out)
