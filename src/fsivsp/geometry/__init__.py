"""Meshes conforming to the interface (see `shapes`)."""

from .shapes import *  # noqa: F403
