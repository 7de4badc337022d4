"""A Maxwell-slip friction record: does a kept constant term cost on validation?

Typical use::

    python -m benchmarks.maxwell_slip                     # seeds 1-5, population 40 x 8
    python -m benchmarks.maxwell_slip --seeds 1 2 --population 40 --generations 8

Records (:func:`maxwell_slip_record`): a smooth random displacement x (a
low-passed Gaussian noise spanning ±2, :func:`narx.systems.training_input`)
drives a Maxwell-slip model of friction, :data:`ELEMENTS` elastoplastic
elements in parallel, each a spring of stiffness :math:`k_i` whose end
slips once its deflection reaches :math:`\\Delta_i`:

.. math:: F_k = \\sum_i k_i \\bigl(x_k - \\mathcal{P}_{\\Delta_i}[x]_k\\bigr) + v_k,

:math:`\\mathcal{P}_r` the play operator of radius r
(:func:`narx.language.memory.play`), :math:`v_k` white noise at 40 dB below the
force (:math:`\\sigma_v = \\mathrm{std}(F)/100`). The force has no offset:
a model that needs a constant term to fit it has found a level the system
does not have (Lampaert, Swevers and Al-Bender, "Modification of the Leuven
integrated friction model structure", IEEE Trans. Automatic Control 47,
2002). Validation: another realisation (another seed for x and v).

For each seed, :class:`mggp.MGGPRegressor` with its defaults and with
``constant=False`` (else the same settings); the table gives whether the
default kept the constant and the free-run RMSE of both on the validation
record.
"""
from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from narx import Data
from narx.language.memory import play
from narx.systems import training_input

__all__ = ["ELEMENTS", "SNR_DB", "maxwell_slip_record", "validation_seed", "compare", "run",
           "markdown"]

#: (stiffness k_i, slip deflection Δ_i) of each element
ELEMENTS = ((40.0, 0.1), (30.0, 0.3), (20.0, 0.6), (10.0, 1.0))

#: output signal-to-noise ratio (dB)
SNR_DB = 40.0


def maxwell_slip_record(n: int = 1000, seed: int = 0, snr_db: float = SNR_DB,
                        amplitude: float = 2.0, bandwidth: float = 1.0,
                        dt: float = 0.01) -> Data:
    """The record of the module docstring: ``n`` samples, x from
    :func:`narx.systems.training_input` (``amplitude``, ``bandwidth`` Hz at
    ``dt`` s, seed ``seed``), F the Maxwell-slip force plus white noise at
    ``snr_db`` dB, drawn from ``numpy.random.default_rng(seed)`` after x."""
    rng = np.random.default_rng(seed)
    x = training_input(n, dt=dt, amplitude=amplitude, bandwidth=bandwidth, seed=rng)
    f = sum(k * (x - play(x, r)) for k, r in ELEMENTS)
    f = f + np.std(f) * 10.0 ** (-snr_db / 20.0) * rng.standard_normal(n)
    return Data(x, f, inputs=("x",), output="F")


def validation_seed(seed: int) -> int:
    """The seed of the validation record of training seed ``seed``."""
    return 1000 + seed


def compare(seed: int, population: int = 40, generations: int = 8, n: int = 1000,
            **kw) -> dict:
    """Fit the record of ``seed`` with the defaults and with
    ``constant=False`` (``random_state=seed``, ``kw`` for both): whether the
    default kept the constant, its choice line, and the validation free-run
    RMSE of both."""
    from mggp import MGGPRegressor
    train = maxwell_slip_record(n, seed)
    val = maxwell_slip_record(n, validation_seed(seed))
    out = {"seed": seed}
    for label, extra in (("default", {}), ("no_constant", dict(constant=False))):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.perf_counter()
            est = MGGPRegressor(population=population, generations=generations,
                                random_state=seed, **dict(kw, **extra)).fit(train)
        sim = est.simulate(val)
        out[f"{label}_rmse"] = float(sim.rmse)
        out[f"{label}_offset"] = float(np.mean(val.y[sim.start:] - sim.y_hat[sim.start:]))
        out[f"{label}_seconds"] = time.perf_counter() - t0
        if label == "default":
            out["constant"] = "1" in est.model_.term_texts
            out["why"] = est.choices_.get("constant", {}).get("why", "")
            out["terms"] = est.model_.term_texts
    return out


def run(seeds=(1, 2, 3, 4, 5), **kw) -> list:
    """:func:`compare` for each seed."""
    return [compare(s, **kw) for s in seeds]


def markdown(rows) -> str:
    """The table of :func:`run`'s rows."""
    lines = ["| seed | constant kept | val RMSE default | val RMSE no constant | ratio |",
             "|---:|:---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['seed']} | {'yes' if r['constant'] else 'no'} | "
                     f"{r['default_rmse']:.3g} | {r['no_constant_rmse']:.3g} | "
                     f"{r['default_rmse'] / r['no_constant_rmse']:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4, 5])
    p.add_argument("--population", type=int, default=40)
    p.add_argument("--generations", type=int, default=8)
    p.add_argument("--n", type=int, default=1000)
    a = p.parse_args(argv)
    rows = []
    for s in a.seeds:
        r = compare(s, a.population, a.generations, a.n)
        rows.append(r)
        print(f"seed {s}: constant {r['constant']}, val RMSE {r['default_rmse']:.4g} "
              f"(offset {r['default_offset']:.3g}) vs {r['no_constant_rmse']:.4g} without; "
              f"{r['default_seconds']:.0f}+{r['no_constant_seconds']:.0f} s; {r['why']}",
              flush=True)
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
