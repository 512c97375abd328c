"""Safe user expressions of x, y, z, t (see `parse`)."""

from .parse import *  # noqa: F403
from .parse import __all__  # noqa: F401
