"""Diagnosis: what a model's simulation gets wrong, why, and the gain of fixing it.

Typical use::

    from narx.csvdata import read_csv
    from mggp.diagnose import diagnose, Budget
    dx = diagnose(read_csv("train.csv"), validation=read_csv("val.csv"),
                  budget=Budget(population=100, generations=20), seed=0, jobs=2)
    print(dx.summary())                 # findings, changes, gain
    dx.effects                          # e.g. ['hysteresis', 'prediction-bias']
    dx.to_dict()                        # the ``mggp diagnose --json`` document
    from mggp.diagnose.report import write_report
    write_report("report/", dx)         # Markdown + figures

Steps (:func:`diagnose`): the baseline (the user's model, or MGGP with
multiple-shooting fitness and no Φ-functions); evidence from the
registered diagnose tests (:mod:`.registry`, the built-in ones listed in
:mod:`.catalogue`), each returning its checks: loop gap (:mod:`.loopgap`),
Φ-augmentation in sample and held out, and operator augmentation
(:mod:`.augmentation`), rest levels (:mod:`.restlevels`),
prediction-bias bootstrap (:mod:`.bias`), drift in held-input segments
(:mod:`.drift`, segments found by :mod:`.holds`) and the Billings–Voon
correlation tests of one-step residuals (:mod:`.correlation`); findings
named from the checks by the rule and vocabulary of :mod:`.findings`; the
extension the causes call for (:mod:`.extend`); the gain measured on
samples not used for fitting (:mod:`.run`); report and figures
(:mod:`.report`).

A new test is one module and one line (:mod:`.registry`)::

    from mggp.diagnose import DiagnosticTest, Outcome, Check, register
    register(DiagnosticTest("my test", ("hysteresis",), lambda ctx: Outcome([...])))

JSON document (``Diagnosis.to_dict``)::

    {"findings": [{"effect", "evidence", "statistic", "threshold"}],
     "baseline": {"terms", "theta", "validation": {"rmse", "mape"}},
     "extended": {"terms", "theta", "validation": {"rmse", "mape"}, "changes"},
     "gain": {"metric": "rmse", "baseline", "extended", "ratio", "recommended"},
     "samples": {"fit": {...}, "measure": {...}}, "tests": [...], "settings": {...}}

``validation`` holds the free-run errors on the measuring samples (the
validation record, or the training tail); ``ratio`` = baseline / extended
RMSE (> 1: the extension is better); ``recommended`` is ``"extended"``
only when the ratio is above 1, else ``"baseline"`` (an extension that did
not help is not recommended, and the summary says so); ``null`` stands for
a diverged simulation (an infinite error).
"""
from .budget import Budget
from .context import Context
from .findings import EXTENSIONS, VOCABULARY, Check, Finding
from .registry import DiagnosticTest, Outcome, register, registered, unregister
from .run import Diagnosis, Gain, Scored, Split, diagnose

__all__ = ["diagnose", "Diagnosis", "Budget", "Finding", "Check", "Gain", "Scored", "Split",
           "VOCABULARY", "EXTENSIONS", "DiagnosticTest", "Outcome", "Context", "register",
           "unregister", "registered"]
