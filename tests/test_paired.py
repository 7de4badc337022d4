"""narx.analysis.paired: the moving-block bootstrap of a paired loss difference."""
import numpy as np
import pytest
from scipy.signal import lfilter

from narx.analysis.paired import block_length, paired_bootstrap


def _ar1(rng, n, rho):
    return lfilter([1.0], [1.0, -rho], rng.standard_normal(n))


def test_block_length_follows_the_dependence():
    """White noise gets blocks of 1-3 samples; an AR(1) of ρ = 0.9 longer
    ones; a constant series 1."""
    rng = np.random.default_rng(0)
    assert block_length(rng.standard_normal(400)) <= 3
    assert block_length(_ar1(rng, 400, 0.9)) >= 8
    assert block_length(np.ones(50)) == 1 and block_length([1.0, 2.0]) == 1


def test_a_clear_difference_is_significant_and_none_is_not():
    rng = np.random.default_rng(1)
    e = _ar1(rng, 300, 0.8)
    a = (e + 3.0) ** 2                          # a biased model
    b = e ** 2
    t = paired_bootstrap(a, b, seed=3)
    assert t.p_value < 0.01 and t.diff > 0 and t.spread(np.sqrt) > 0
    # control: b no better than a (same errors, a little noise on b)
    t0 = paired_bootstrap(b, b + 0.01 * rng.standard_normal(300), seed=3)
    assert t0.p_value > 0.2
    # one-sided: a lower than b is no evidence for b
    assert paired_bootstrap(b, a, seed=3).p_value > 0.99


def test_the_seed_fixes_the_result_and_no_global_state_is_used():
    rng = np.random.default_rng(2)
    a, b = rng.random(200), rng.random(200)
    np.random.seed(0)
    t1 = paired_bootstrap(a, b, seed=7)
    np.random.seed(99)
    t2 = paired_bootstrap(a, b, seed=7)
    assert (t1.p_value, t1.se, t1.block) == (t2.p_value, t2.se, t2.block)
    np.testing.assert_array_equal(t1.a_star, t2.a_star)
    assert paired_bootstrap(a, b, seed=8).se != t1.se


def test_blocks_keep_the_level_for_dependent_differences():
    """Under no difference, an AR(1) loss difference of ρ = 0.8 over 300
    samples: the block bootstrap rejects at 5 % in about a tenth of the
    records (the moving-block bootstrap's known excess on short series),
    the bootstrap of single samples (block 1, as if independent) in over
    a fifth."""
    rng = np.random.default_rng(0)
    rej = {None: 0, 1: 0}
    for r in range(100):
        d = _ar1(rng, 300, 0.8)
        for blk in rej:
            rej[blk] += paired_bootstrap(1.0 + d, np.ones(300), seed=r, block=blk,
                                         replicates=199).p_value < 0.05
    assert rej[None] <= 16 and rej[1] >= 20


def test_segments_resample_within_each_segment():
    """Two segments (e.g. both ends of a record held out): each resample
    keeps each segment's samples and length."""
    a = np.r_[np.zeros(100), np.ones(50)]
    t = paired_bootstrap(a, np.zeros(150), seed=0, segments=[100, 50], replicates=50)
    np.testing.assert_allclose(t.a_star, 50 / 150)        # the second segment's share
    with pytest.raises(ValueError, match=r"segments must be positive lengths adding up to "
                                         r"the 150 samples, got \[100, 40\]"):
        paired_bootstrap(a, np.zeros(150), segments=[100, 40])


@pytest.mark.parametrize("kw, said", [
    (dict(loss_b=np.zeros(5)), "loss_a and loss_b must be non-empty and of equal length, "
                               "got 10 and 5"),
    (dict(replicates=0), "replicates must be >= 1, got 0"),
    (dict(block=11), r"block must be within 1..10 \(the samples of the shortest segment\), "
                     r"got 11"),
    (dict(loss_b=np.r_[np.zeros(9), np.nan]), "loss_a and loss_b must be finite"),
])
def test_bad_input_names_the_parameter(kw, said):
    args = dict(loss_a=np.zeros(10), loss_b=np.zeros(10))
    args.update(kw)
    with pytest.raises(ValueError, match=said):
        paired_bootstrap(args.pop("loss_a"), args.pop("loss_b"), **args)
