"""The version of the narx package (also written into model files)."""

__version__ = "0.1.0"
