"""narx: polynomial NARX models with Φ-functions (the numerical layer of mggp).

Typical use::

    import narx
    m = narx.Model(["y[k-1]", "Phi1(u[k-1],u[k-2])"]).fit(u, y)
    res = m.simulate(u, y, mode="freerun")      # or 'osa', 'ksa' (k=), 'ms' (window=)
    narx.mape(y, res.y_hat)

Subpackages, each importing only those listed before it:

- :mod:`narx.language`: the term language (:mod:`~narx.language.terms`),
  Φ-functions (:mod:`~narx.language.phi`), memory operators
  (:mod:`~narx.language.memory`) and their registries;
- :mod:`narx.records`: input/output records (:mod:`~narx.records.data`,
  :mod:`~narx.records.csvdata`), their regressor columns
  (:mod:`~narx.records.regressors`, :mod:`~narx.records.colbuild`), spikes,
  signal ranges and dead times;
- :mod:`narx.simulation`: the four simulation modes and their kernels,
  error metrics;
- :mod:`narx.analysis`: steady states and their constraints, quasi-static
  analysis, invertibility, model-based compensation, paired comparison;
- :mod:`narx.estimation`: LS and CLS (:mod:`~narx.estimation.estimate`),
  output-error estimation, the structure scorer of a search
  (:mod:`~narx.estimation.fitness`);
- :mod:`narx.systems`: reference systems, the zoo, known polynomial systems.

At the top: :mod:`narx.model` (the model), :mod:`narx.refine`
(simulation-error refinement of a model), :mod:`narx.modelio` (JSON model
files), :mod:`narx.export`, and the foundations :mod:`narx.linalg`,
:mod:`narx.atomic`, :mod:`narx.exceptions`, :mod:`narx.version`.
``narx`` never imports ``deap`` or ``mggp``.
"""
from ._moved import install as _install, keep_functions as _keep_functions

#: the module paths before the subpackages, each to its new home; they import
#: for one release with a DeprecationWarning
MOVED = {
    "narx.terms": "narx.language.terms",
    "narx.phi": "narx.language.phi",
    "narx.memory": "narx.language.memory",
    "narx.registry": "narx.language.registry",
    "narx.regressors": "narx.records.regressors",
    "narx.colbuild": "narx.records.colbuild",
    "narx.data": "narx.records.data",
    "narx.csvdata": "narx.records.csvdata",
    "narx.outliers": "narx.records.outliers",
    "narx.ranges": "narx.records.ranges",
    "narx.deadtime": "narx.records.deadtime",
    "narx.estimate": "narx.estimation.estimate",
    "narx.gram": "narx.estimation.gram",
    "narx.output_error": "narx.estimation.output_error",
    "narx.fitness": "narx.estimation.fitness",
    "narx.simulate": "narx.simulation.simulate",
    "narx.kernels": "narx.simulation.kernels",
    "narx.ms_kernel": "narx.simulation.ms_kernel",
    "narx.metrics": "narx.simulation.metrics",
    "narx.steady": "narx.analysis.steady",
    "narx.quasistatic": "narx.analysis.quasistatic",
    "narx.inverse_check": "narx.analysis.inverse_check",
    "narx.compensate": "narx.analysis.compensate",
    "narx.compensate_args": "narx.analysis.compensate_args",
    "narx.paired": "narx.analysis.paired",
    "narx.testsystems": "narx.systems.testsystems",
}
_install(MOVED)

from .language.phi import (PhiFunction, PhiRegistry, register_phi, unregister_phi,
                           get_phi, default_registry)
from .exceptions import (TermError, DataError, EstimationError, ModelFileError,
                         RankWarning, NonMinimumPhaseWarning, ExtrapolationWarning,
                         SeedLeakError)
from .language.terms import Lag, PhiCall, Term, Signals, parse_term, parse_terms
from .records.data import Data
from .estimation.estimate import Estimate, least_squares, constrained_least_squares
from .records.regressors import regressor_matrix, max_lag
from .simulation.simulate import SimulationResult, simulate, MODES
from .analysis.steady import (Cluster, SteadyStateConstraints, clusters, cluster_sums,
                              steady_state_constraints)
from .simulation.metrics import mse, rmse, mape, rrse, nrmse
from .model import Model, load_model, save_model
from .refine import Refinement, refine
from .analysis.quasistatic import QuasiStaticResult, quasistatic

from .version import __version__

_keep_functions(__name__)      # import narx.simulate (old path) leaves narx.simulate a function
