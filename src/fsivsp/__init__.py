"""fsivsp: the velocity–stress–pressure FSI scheme of González & Selgas (2018).

    import fsivsp
    records = fsivsp.study(fsivsp.paper_case(dt=1e-2), range(0, 3))
"""
import ngsolve as _ngsolve

# One NGSolve thread. With its default, NGSolve's sparsecholesky (the multigrid's coarsest level, F of the
# least-squares commutator, the error norms' Gram matrices) gave factors that differed at round-off from one
# factorisation of the same matrix to the next (4e-12 on a 3 782-dof P1 block of the paper's level 2), so that
# two identical iterative runs ended apart; with one thread they are bit-identical (tests/test_iterative.py).
# The price: sparsecholesky of the 47 643-dof vertex block of the 3D ball's level 3 takes 8.2 s against 4.2 s.
_ngsolve.SetNumThreads(1)

from .expressions import ExpressionError, parse, parse_vector
from .fields import Field
from .geometry import paper_channel, refined
from .manufactured import ExactSolution, ManufacturedError
from .materials import Materials
from .paper import paper_case, reference_table
from .scheme import Scheme, Data
from .spaces import Spaces, build_spaces
from .study import Case, manufactured_data, run_level, study, time_study
from .timeschemes import time_scheme

__version__ = "0.1.0"
__all__ = [
    "Scheme", "Case", "Data", "ExactSolution", "ExpressionError", "Field", "ManufacturedError",
    "Materials", "Spaces", "build_spaces", "manufactured_data", "paper_case", "paper_channel", "parse",
    "parse_vector", "reference_table", "refined", "run_level", "study", "time_scheme", "time_study",
]
