"""fsivsp: the velocity-stress-pressure FSI scheme of Gonzalez & Selgas (2018)."""
__version__ = "0.1.0"
