"""narx: polynomial NARX models with Φ-functions (the numerical layer of mggp).

Typical use::

    import narx
    m = narx.Model(["y[k-1]", "Phi1(u[k-1],u[k-2])"]).fit(u, y)
    res = m.simulate(u, y, mode="freerun")      # or 'osa', 'ksa' (k=), 'ms' (window=)
    narx.mape(y, res.y_hat)

Layers: :mod:`narx.terms` (term language), :mod:`narx.phi` (Φ-functions),
:mod:`narx.regressors`, :mod:`narx.estimate` (LS, CLS),
:mod:`narx.simulate` and :mod:`narx.kernels` (the four simulation modes),
:mod:`narx.steady` (clusters, continuum-of-steady-states constraints),
:mod:`narx.metrics`, :mod:`narx.modelio` (JSON model files),
:mod:`narx.systems` and :mod:`narx.testsystems` (reference systems).
``narx`` never imports ``deap`` or ``mggp``.
"""
from ._moved import install as _install

#: the module paths before the subpackages, each to its new home; they import
#: for one release with a DeprecationWarning
MOVED = {}
_install(MOVED)

from .phi import (PhiFunction, PhiRegistry, register_phi, unregister_phi,
                  get_phi, default_registry)
from .exceptions import (TermError, DataError, EstimationError, ModelFileError,
                         RankWarning, NonMinimumPhaseWarning, ExtrapolationWarning,
                         SeedLeakError)
from .terms import Lag, PhiCall, Term, Signals, parse_term, parse_terms
from .data import Data
from .estimate import Estimate, least_squares, constrained_least_squares
from .regressors import regressor_matrix, max_lag
from .simulate import SimulationResult, simulate, MODES
from .steady import (Cluster, SteadyStateConstraints, clusters, cluster_sums,
                     steady_state_constraints)
from .metrics import mse, rmse, mape, rrse, nrmse
from .model import Model, load_model, save_model
from .refine import Refinement, refine
from .quasistatic import QuasiStaticResult, quasistatic

from .version import __version__
