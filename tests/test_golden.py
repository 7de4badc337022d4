"""Same seeds give the same models and fitness values, bit for bit, as the
values recorded from main before the reshape of the core (issue 16):
S1–S6 recovery, the quick case study and a diagnosis, at small budgets
(:mod:`tests.golden_cases`). The record is per BLAS kernel
(:func:`tests.golden_cases.blas_kernel`): on a kernel without one, the
comparison cannot be made, and the tests skip saying how to record it."""
import json
import os

import pytest

from tests import golden_cases

HERE = os.path.dirname(__file__)


@pytest.fixture(scope="module")
def recorded():
    with open(os.path.join(HERE, "data", "golden.json")) as fh:
        doc = json.load(fh)
    kernel = golden_cases.blas_kernel()
    if kernel not in doc:
        pytest.skip(f"no golden record for the BLAS kernel {kernel!r} (recorded: "
                    f"{', '.join(sorted(doc))}); record one on main with "
                    "python -m tests.golden_cases --write tests/data/golden.json")
    return doc[kernel]


@pytest.fixture(scope="module")
def now():
    return json.loads(json.dumps(golden_cases.record(), sort_keys=True))


@pytest.mark.parametrize("case", ["recovery", "case_study", "diagnosis"])
def test_same_numbers_as_recorded(recorded, now, case):
    assert now[case] == recorded[case]
