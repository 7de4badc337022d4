"""The paired held-out test of the diagnosis: :mod:`narx.analysis.paired`.

Typical use::

    import numpy as np
    from mggp.diagnose.paired import paired_test, holm
    t = paired_test(e_baseline, e_candidate, np.random.default_rng(0), floor=0.01)
    t.p_value, t.block, t.mean_difference      # one-sided: the candidate is better

The diagnosis (:mod:`.verdict`) and the automatic choices of ``mggp fit``
(:mod:`mggp.fit.choices`) use the one test of :mod:`narx.analysis.paired`; this module
names it where the diagnosis's other parts live.
"""
from narx.analysis.paired import BOOTSTRAP_DRAWS, PairedTest, block_length, holm, paired_test

__all__ = ["PairedTest", "paired_test", "block_length", "holm", "BOOTSTRAP_DRAWS"]
