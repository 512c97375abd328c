"""fsivsp: the velocity–stress–pressure FSI scheme of González & Selgas (2018).

    import fsivsp
    records = fsivsp.study(fsivsp.paper_case(dt=1e-2), range(0, 3))
    summary = fsivsp.run("examples/pressure_wave_2d.toml", out="wave2d")   # as `fsivsp run`
"""
from .case import Case, CaseError, Discretisation
from .expressions import ExpressionError, parse, parse_vector
from .fields import Field
from .geometry import paper_channel, refined
from .manufactured import ExactSolution, ManufacturedError
from .materials import Materials
from .paper import paper_case, reference_table
from .runner import run
from .data import Data
from .scheme import Scheme
from .spaces import Spaces, build_spaces
from . import threads
from .solvers import SolverSpec
from .study import manufactured_data, run_level, study, time_study
from .timeschemes import time_scheme

__version__ = "0.1.0"
__all__ = [
    "Scheme", "Case", "CaseError", "Data", "Discretisation", "ExactSolution", "ExpressionError", "Field",
    "ManufacturedError", "Materials", "SolverSpec", "Spaces", "build_spaces", "manufactured_data", "paper_case",
    "paper_channel", "parse", "parse_vector", "reference_table", "refined", "run", "run_level", "study",
    "time_scheme", "time_study",
]
