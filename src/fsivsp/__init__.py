"""fsivsp: the velocity–stress–pressure FSI scheme of González & Selgas (2018).

    import fsivsp
    records = fsivsp.study(fsivsp.paper_case(dt=1e-2), range(0, 3))
    summary = fsivsp.run("examples/pressure_wave_2d.toml", out="wave2d")   # as `fsivsp run`
    modes = fsivsp.modes("examples/modes_2d.toml", out="modes")            # as `fsivsp modes`
"""
from .app.api import harmonic, modes, run
from .config.case import Case, CaseError, Discretisation
from .experiments.paper import paper_case, reference_table
from .experiments.study import manufactured_data, run_level, study, time_study
from .fem.spaces import Spaces, build_spaces
from .geometry import Phases, mesh_phases, paper_channel, refined
from .model.data import Data, FlowRate, Support, Windkessel, resistance
from .model.expressions import ExpressionError, parse, parse_vector
from .model.fields import Field
from .model.manufactured import ExactSolution, ManufacturedError
from .model.materials import Materials
from .runtime import threads  # noqa: F401  (fsivsp.threads.using: the public API)
from .solvers import SolverSpec
from .timestepping.scheme import Scheme
from .timestepping.schemes import time_scheme

__version__ = "0.1.0"
__all__ = [
    "Scheme", "Case", "CaseError", "Data", "Discretisation", "ExactSolution", "ExpressionError", "Field", "FlowRate",
    "ManufacturedError", "Materials", "Phases", "SolverSpec", "Spaces", "Support", "Windkessel", "build_spaces",
    "harmonic", "manufactured_data", "mesh_phases", "modes", "paper_case", "paper_channel", "parse", "parse_vector",
    "reference_table", "refined", "resistance", "run", "run_level", "study", "time_scheme", "time_study",
]
