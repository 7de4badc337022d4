"""Figures and Markdown summaries of what mggp found.

Typical use::

    from mggp.report.summary import write_fit_report

Modules: :mod:`~mggp.report.summary` (the report of a fit),
:mod:`~mggp.report.quasistatic` (Fig. 7 of Abreu et al. 2020) and
:mod:`~mggp.report.plotting` (headless Matplotlib).
"""


def __getattr__(name):        # the names of the former module mggp.report, for one release
    from narx._moved import moved_attribute
    return moved_attribute(__name__, "mggp.report.summary", name)
