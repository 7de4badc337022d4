"""Diagnosis: what a model's simulation gets wrong, why, and the gain of fixing it.

Typical use::

    from narx.records.csvdata import read_csv
    from mggp.diagnose import diagnose, Budget
    dx = diagnose(read_csv("train.csv"), validation=read_csv("val.csv"),
                  budget=Budget(population=100, generations=20), seed=0, jobs=2)
    print(dx.summary())                 # findings, changes, gain
    dx.effects                          # e.g. ['hysteresis']
    dx.verdict.p_values                 # p-value of each effect class
    dx.to_dict()                        # the ``mggp diagnose --json`` document
    from mggp.diagnose.report import write_report
    write_report("report/", dx)         # Markdown + figures

Steps (:func:`diagnose`): the samples are cut into fitting, selection
and measuring samples (:class:`Split`: with a validation record, the
training record's head fits and its tail selects, the validation record's
blocks select and measure in turn; without one, three consecutive parts of the training record);
the baseline (the user's model, or MGGP with multiple-shooting fitness
and no Φ-functions, fitted on the fitting samples); evidence from the
registered residual tests (:mod:`.registry`; none runs by default,
:mod:`.catalogue` says why), which explains but does not decide;
candidate extensions grouped by the effect
they fix (:mod:`.candidates`: Φ-functions, plays, Deng–Tan, Bouc–Wen
and output-driven memory for ``hysteresis``; more lags, more degree, CLS
for the memory-free effects), each fitted on the fitting samples; the
verdict (:mod:`.verdict`): every candidate against the baseline by a
paired block-bootstrap test of their free-run losses on the selection
samples (:mod:`narx.analysis.paired`, Holm over the candidates;
``hysteresis`` must also beat the best memory-free class), the effect
named by the class that wins; the gain of the winner measured on the
measuring samples, which played no part in any choice; report and
figures (:mod:`.report`).

A new test is one module and one line (:mod:`.registry`)::

    from mggp.diagnose import DiagnosticTest, Outcome, Check, register
    register(DiagnosticTest("my test", ("hysteresis",), lambda ctx: Outcome([...])))

JSON document (``Diagnosis.to_dict``)::

    {"findings": [{"effect", "evidence", "statistic": p-value, "threshold": level}],
     "baseline": {"terms", "theta", "validation": {"rmse", "mape"}},
     "extended": {"terms", "theta", "validation": {"rmse", "mape"}, "changes"},
     "gain": {"metric": "rmse", "baseline", "extended", "ratio", "recommended"},
     "samples": {"fit": {"record", "first", "last"},
                 "select": {"record", "first", "last", "scored_from"},
                 "measure": {"record", "first", "last", "scored_from", "blocks"},
                 "select_validation": {"record", "blocks", "scored_from"}
                 (with a validation record that selects)},
     "tests": [...], "evidence": [...],
     "verdict": {"level", "candidates": [{"effect", "name", "changes", "terms",
                 "selection_rmse", "p_value", ...}],
                 "p_values": {effect: p}, "baseline_selection_rmse", "winner"},
     "separation": null or one line, "settings": {...}}

``findings`` are the named effects (one: the class of the winner), each
with its p-value and the level; ``evidence`` the effects the registered
residual tests point to (their checks are in ``tests``; both empty when
none is registered, the default). ``verdict.p_values``
holds each class's p-value: an effect is named at level α only if its
p-value is at most α (for ``hysteresis`` the larger of its p-values
against the baseline and against the best memory-free class).
``blocks`` are ``[first, last]`` sample pairs (the measuring samples
are those of ``measure.blocks`` from ``scored_from`` on);
``validation`` holds the free-run errors on the measuring samples;
``ratio`` = baseline / extended RMSE (> 1: the extension is better);
``recommended`` is ``"extended"`` when the extension won the test on the
selection samples, else ``"baseline"`` (then extended = baseline); the
ratio is measured on samples no choice has seen. ``null`` stands for a
diverged simulation (an infinite error) or a class not tested.
"""
from .budget import Budget
from .context import Context
from .findings import EXTENSIONS, VOCABULARY, Check, Finding
from .registry import DiagnosticTest, Outcome, register, registered, unregister
from .run import Diagnosis, Gain, Scored, Split, diagnose

__all__ = ["diagnose", "Diagnosis", "Budget", "Finding", "Check", "Gain", "Scored", "Split",
           "VOCABULARY", "EXTENSIONS", "DiagnosticTest", "Outcome", "Context", "register",
           "unregister", "registered"]
