"""Matplotlib figures drawn headless (Agg backend) and saved as PNG.

Typical use::

    from mggp.report.plotting import figure, save
    fig, ax = figure(figsize=(6, 4))
    ax.plot(t, y)
    save(fig, "report/y.png")

Matplotlib is imported on the first figure, so importing a module that draws
figures stays cheap for the command line.
"""
from __future__ import annotations

__all__ = ["figure", "save"]


def figure(*args, **kw):
    """A new figure and its axes, ``matplotlib.pyplot.subplots(*args, **kw)``,
    on the non-interactive Agg backend."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt.subplots(*args, **kw)


def save(fig, path):
    """Lay out ``fig``, write it to ``path`` (PNG, 110 dpi), close it and
    return ``path``."""
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    import matplotlib.pyplot as plt
    plt.close(fig)
    return path
