"""Shared fixtures of the independent narx test suite.

The published models of the case study (DESIGN.md) are written here once,
exactly as DESIGN.md prints them (not in canonical order, on purpose: the
parser must canonicalise them).
"""
import numpy as np
import pytest

import narx

# Reference model (19), parameters from CLS (DESIGN.md table).
MODEL19_TERMS = (
    "y[k-1]",
    "Phi1(u[k-2],u[k-3])",
    "Phi2(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])*u[k-2]",
    "Phi2(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])*y[k-1]",
    "Phi1(u[k-2],u[k-3])*u[k-2]*u[k-2]",
    "Phi1(u[k-2],u[k-3])*u[k-2]*y[k-1]",
    "Phi2(u[k-2],u[k-3])*y[k-1]",
    "Phi1(u[k-1],u[k-2])",
    "Phi2(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])*Phi1(u[k-2],u[k-3])",
)
MODEL19_THETA = (1.0, -0.2310, 0.0146, -0.0099, 3.2333e-4, -2.5494e-4, 1.7891e-5,
                 1.0080, -0.0604)

# MS model (33), theta_1 .. theta_15 in this order.
MODEL33_TERMS = (
    "y[k-2]*u[k-1]*u[k-3]", "u[k-5]", "u[k-1]*u[k-5]*y[k-5]", "u[k-1]*u[k-3]*u[k-3]",
    "u[k-5]*y[k-4]*Phi2(u[k-4],u[k-1])", "u[k-5]*y[k-1]*Phi2(u[k-3],u[k-1])",
    "y[k-1]", "Phi1(u[k-5],u[k-1])", "Phi2(u[k-4],u[k-6])",
    "y[k-3]*y[k-8]*Phi2(u[k-4],u[k-1])", "y[k-5]*y[k-8]*Phi2(u[k-4],u[k-1])",
    "u[k-3]*u[k-3]*Phi2(u[k-4],u[k-1])", "u[k-1]*u[k-1]*u[k-3]",
    "u[k-1]*u[k-4]*Phi2(u[k-5],u[k-1])", "u[k-10]",
)

# PEM model (32).
MODEL32_TERMS = (
    "u[k-1]*u[k-4]*y[k-1]", "u[k-2]*u[k-4]", "u[k-3]*y[k-1]",
    "u[k-1]*y[k-1]*Phi2(u[k-4],u[k-6])", "u[k-1]*y[k-1]", "y[k-1]", "y[k-3]",
    "Phi2(u[k-1],u[k-8])", "Phi2(u[k-1],u[k-3])", "Phi2(u[k-1],u[k-2])",
    "Phi2(u[k-5],u[k-1])", "Phi2(u[k-5],u[k-2])", "y[k-2]", "u[k-1]", "u[k-4]",
)


@pytest.fixture(scope="session")
def model19():
    return MODEL19_TERMS, MODEL19_THETA


@pytest.fixture(scope="session")
def model33_terms():
    return MODEL33_TERMS


@pytest.fixture(scope="session")
def model32_terms():
    return MODEL32_TERMS


@pytest.fixture
def abs_registry():
    """A fresh registry with the user Φ-function Abs (never the default one)."""
    reg = narx.PhiRegistry()
    reg.register("Abs", 1, np.abs, steady=np.abs, doc="absolute value")
    return reg


def piezo_record(n=50_000, seed=None):
    """(u, y): the training input of ``n`` samples and the piezo output."""
    from narx.systems import piezo_bouc_wen, training_input
    u = training_input(n) if seed is None else training_input(n, seed=seed)
    return u, piezo_bouc_wen(u)


@pytest.fixture(scope="session")
def piezo_training():
    """The published training record: N = 50,000, piezo Bouc-Wen."""
    return piezo_record()


@pytest.fixture(scope="session")
def piezo_validation():
    """u = 40 sin(2 pi t), 5 s at 1 ms, and the piezo output."""
    from narx.systems import piezo_bouc_wen, sine_input
    _, u = sine_input()
    return u, piezo_bouc_wen(u)


def first_order_record(n=300, seed=0, noise=0.0):
    """u ~ U(-1, 1) and y[k] = 0.5 y[k-1] + u[k-1] (+ N(0, noise²) equation noise)."""
    rng = np.random.default_rng(seed)
    u = rng.uniform(-1, 1, n)
    y = np.zeros(n)
    for k in range(1, n):
        y[k] = 0.5 * y[k - 1] + u[k - 1] + (noise * rng.standard_normal() if noise else 0.0)
    return u, y
