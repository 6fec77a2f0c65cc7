"""Type stubs of the native module ``cellmech._cellmech`` (the Rust part of the package).

Use the package ``cellmech`` (``__init__.py``, fully annotated); these functions are its
building blocks.
"""

from typing import Any, Callable, Dict, List, Optional, Tuple

__version__: str

class ScenarioError(ValueError):
    """A scenario, a parameter or an experiment is invalid (the CLI's message, naming the key)."""

class RunError(RuntimeError):
    """A run could not start or its outputs could not be written."""

class AnalysisError(RunError):
    """The analysis stopped early; raised by ``Analysis.run(..., check=True)``.
    ``result`` holds the Result with every converged increment."""

    result: Any

class NativeAnalysis:
    """A resolved model with its steps, ready to run."""

    @property
    def title(self) -> str: ...
    @property
    def origin(self) -> str: ...
    @property
    def steps(self) -> List[str]: ...
    @property
    def mesh_size(self) -> Tuple[int, int]: ...
    @property
    def toml(self) -> Optional[str]: ...
    def run(
        self,
        out_dir: str,
        progress: Optional[Callable[[Dict[str, Any]], Any]] = None,
        threads: int = 0,
    ) -> Dict[str, Any]:
        """Runs with the GIL released; returns raw results: ``status``, ``error``,
        ``out_dir``, ``summary_json`` (text), ``curve`` (names, columns) and ``filaments``
        ((names, columns) or None)."""

def load(path: str) -> NativeAnalysis:
    """Reads and resolves a scenario file; raises ScenarioError."""

def parse(text: str, origin: str = "<string>", base_dir: Optional[str] = None) -> NativeAnalysis:
    """Parses and resolves scenario text; raises ScenarioError."""

def check_cell(model: str, params: Dict[str, Any]) -> Dict[str, Any]:
    """Checks a cell model's parameters against its declared table; returns the nested
    ``[cell]`` section with ``model``."""

def check_protocol(kind: str, params: Dict[str, Any]) -> Dict[str, Any]:
    """Checks a protocol's parameters against its declared table; returns the nested
    ``[protocol]`` section with ``kind``."""

def experiment(
    cell: Dict[str, Any],
    protocol: Dict[str, Any],
    title: Optional[str] = None,
    output: Optional[Dict[str, Any]] = None,
    families: Optional[Dict[str, Any]] = None,
) -> NativeAnalysis:
    """Composes the scenario TOML of a cell and a protocol and resolves it."""

def parameters(name: str) -> str:
    """A declared parameter table as commented TOML."""

def fit_file(
    path: str,
    out_dir: str,
    progress: Optional[Callable[[Dict[str, Any]], Any]] = None,
    threads: int = 0,
) -> str:
    """Runs the fit of a fit file with the GIL released; returns ``fit.json`` as text.
    Raises ScenarioError (invalid fit) or RunError (the fit cannot proceed)."""

def fit_text(
    text: str,
    out_dir: str,
    origin: str = "<string>",
    base_dir: Optional[str] = None,
    progress: Optional[Callable[[Dict[str, Any]], Any]] = None,
    threads: int = 0,
) -> str:
    """The same from fit TOML text (``base_dir`` anchors relative paths)."""
