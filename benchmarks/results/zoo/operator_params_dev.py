"""Development study of the estimate of the winner's operator parameters
(zoo seeds 0-399): per draw, the measured RMSE of the grid model, of the
estimate always taken, and of the rule (``ops``), beside the oracle.

    python benchmarks/results/zoo/operator_params_dev.py OUT.jsonl 0-199   # and 200-399 beside it
"""
import sys, time, warnings, math, json
import numpy as np
from mggp.diagnose import Budget, diagnose
from mggp.diagnose.candidates import estimate_operators
from narx.systems import zoo
from benchmarks.zoo import STUDY_N, STUDY_BUDGET, _measured, oracle, parse_seeds
warnings.simplefilter("ignore")
out = open(sys.argv[1], 'a')
for seed in parse_seeds(sys.argv[2:]):
    try:
        with zoo.tuning():          # development seeds only
            d = zoo.draw(seed, n=STUDY_N)
        t0 = time.perf_counter()
        dx = diagnose(d.train, validation=d.validation, budget=Budget(**STUDY_BUDGET), seed=seed, jobs=1)
        secs = time.perf_counter() - t0
        w = dx.verdict.winner
        rec = dict(seed=seed, family=d.family, placement=d.placement, hyst=d.hysteretic, input=d.input_kind,
                   winner=None if w is None else w.structure.name, named=dx.effects, secs=secs,
                   base=_measured(dx.baseline.model, dx, d.validation)[0], ops=dx.operator_params,
                   ext=_measured(dx.extended.model, dx, d.validation)[0])
        if w is not None:
            rec['grid'] = _measured(w.model, dx, d.validation)[0]
            t = time.perf_counter(); r = estimate_operators(w.model, dx.fit_data); rec['refine_secs'] = time.perf_counter() - t
            rec['refined'] = None if r is None else _measured(r.model, dx, d.validation)[0]
            if r is not None: rec['nfev'] = r.nfev
        try:
            orc = oracle(d)
            rec['oracle'] = _measured(orc.model, dx, d.validation)[0] if dx.split.measure[0] else orc.rmse
        except Exception as e:
            rec['oracle'] = None
    except Exception as e:
        rec = dict(seed=seed, error=repr(e))
    out.write(json.dumps(rec, default=float) + "\n"); out.flush()
