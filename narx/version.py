"""The version of the narx package (also written into model files). Typical use::

    from narx.version import __version__
"""

__version__ = "0.1.0"
