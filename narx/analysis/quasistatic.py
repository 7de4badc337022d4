"""Quasi-static analysis: the fixed points that attract or repel a model's output.

Typical use::

    import narx
    qs = narx.quasistatic(model, u)          # u: the input record (N,) or (N, m)
    qs.roots[k], qs.attracting[k]            # solutions ỹ at sample k and their class
    qs.branch[k]                             # 'loading', 'unloading' or 'rest'
    qs.y                                     # the model's free run on u
    qs.bounding.loading.roots                # equilibria over the input's range

**The frozen equation** (Abreu et al. 2020 [1]_, section 4). At sample k every
factor that holds no output keeps its value at k: ``u[k-2]`` is u_{k-2},
``Phi1(u[k-2],u[k-3])`` is u_{k-2} − u_{k-3}, a plug-in Φ of inputs is its
registered function of those samples. Every output lag ``y[k-j]`` is
replaced by one unknown ỹ, and the fixed-point equation

.. math::  \\tilde y = F_k(\\tilde y)

is solved. A Φ-call whose arguments are all output lags takes the
registry's *steady value* at ỹ (its value when all arguments are equal:
``Phi1(y[k-1],y[k-2])`` and ``Phi2(...)`` are 0); a Φ-call mixing output
and input lags is its registered function with each output argument at ỹ
and each input argument at its value at k. Noise lags ``e[k-j]`` are 0, as
in simulation.

**Solving.** When every output-dependent factor is polynomial in ỹ (output
lags, Phi1 of any arguments, Φ-calls of outputs only whose steady value is
a number), G_k(ỹ) = F_k(ỹ) − ỹ is a polynomial whose coefficients are
collected per sample; all its real roots are found (closed form for degree
1, eigenvalues of the companion matrices, batched over samples, above; a
root is real when its imaginary part is below 1e-6 (1 + |ỹ|)). Otherwise (a plug-in of outputs with a callable steady
value, a mixed Φ-call other than Phi1) G_k is evaluated on a grid of
``grid`` points over ``y_range`` (default: the free run's range and 0,
widened on each side by 5 times the largest of its span, its largest
magnitude and 1) and every sign change is refined by 60 bisections; a sign
change across a jump (|G_k| at the limit above 1e-6 of its larger
magnitude at the two grid points) is not a root. This method does not find
roots outside ``y_range``, roots where G_k touches 0 without changing sign,
or two roots within one grid step.

**Polish.** Every root, of either method, then takes up to three Newton
steps ỹ ← ỹ − G_k(ỹ)/G_k'(ỹ) with G_k summed in double-double arithmetic
(error-free sums and products of the terms, rounded once), so that terms
that cancel, as θ1 y[k-1] − ỹ with θ1 = 1 in a CLS model, lose no digits;
a step is kept only where it lowers |G_k| and moves the root by at most
1e-3 (1 + |ỹ|), else the root stays as found. On model (19) of [1]_
(u = 70 sin(2πt), Ts = 1 ms), where 1 − a_k of eq. (20) falls to 2e-6,
the roots then agree with eq. (20) in exact arithmetic to 2e-16
(relative) instead of 4e-11.

**Continuum.** When every coefficient of G_k (or, numerically, G_k at every
grid point) is below ``tol`` times the size of the terms that make it, the
equation holds for every ỹ: no isolated solution, a *continuum* (the
continuum of steady states of a CLS model with the input held).

**Class.** A root ỹ* attracts when the recursion linearised in the output
lags, with the non-output factors frozen at k, is stable there: with
d_j = ∂ŷ_k/∂ŷ_{k-j} at every lag equal to ỹ*, the roots of the
characteristic polynomial z^n − d_1 z^{n−1} − … − d_n lie inside the unit
circle (spectral radius < 1; for one output lag this is |d_1| < 1, eq. 21
of [1]_). Derivatives are exact for output lags and Phi1, 0 for Phi2 (its
derivative wherever it has one), and central differences of the registered
function (step 1e-6 max(1, |x|)) for plug-ins.

**Branch.** Sample k is on the ``loading`` branch when the (first) input
rises, u_k > u_{k-1}, ``unloading`` when it falls, ``rest`` when it is
equal (row 0 takes the sign of u_1 − u_0). Samples before the model's
largest lag have no frozen equation (solution ``'initial'``).

**Bounding structure** (eq. 17 of [1]_). Over ``bounding_points`` values ū
spanning the first input's range, the equation is solved with the input on
a ramp through ū: u_{k-j} = ū − s δ j, s = +1 on the loading branch, −1 on
unloading, 0 at rest (other inputs held at their mean). Every input factor
(lags, Φ-calls built-in and plug-in) takes its value on that ramp. With
``bounding_step`` δ > 0 this is the input moving at δ per sample. With the
default δ = 0 each factor takes its limit as the step goes to 0 from the
branch's side (linear extrapolation to 0 from the steps δ₀ and 2δ₀,
δ₀ = 1e-7 times the input's scale; a value that cancels to within
1e-6 of the two it comes from is 0). So on every branch Phi1 (the rate)
is held at 0; ``Phi2(u[k-a],u[k-b])`` is held at s·sign(b − a) (+1 under
loading and −1 under unloading for the usual a < b; 0 at rest); a plug-in
such as regressor (18) of [1]_ is held at its one-sided limit; at rest
every Φ-call of inputs is its function at equal arguments (its steady
value). For model (16), y_k = 0.9 y_{k-1} + 0.5 Φ2_{k-1}, this gives
ỹ = ±Σ_{Φ2}/(1 − Σ_y) = ±5 and, at rest, ỹ = 0; a model under the
continuum-of-steady-states constraints gives a continuum at rest.

References
----------
.. [1] Abreu, P. E. O. G. B., Tavares, L. A., Teixeira, B. O. S., Aguirre,
   L. A., "Identification and nonlinearity compensation of hysteresis using
   NARX models", Nonlinear Dynamics, 2020 (eqs. 16-21, Fig. 7).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from ..records.data import Data, DataError, as_data
from ..records.regressors import factor_column
from ..language.terms import Lag

__all__ = ["quasistatic", "QuasiStaticResult", "Equilibria", "BoundingStructure",
           "BRANCHES"]

#: branch names, indexed by the sign of the input's change (+1, -1, 0)
BRANCHES = ("loading", "unloading", "rest")
_SIGN = {"loading": 1, "unloading": -1, "rest": 0}
_REAL = 1e-6         # |imag| / (1 + |root|) below which a companion eigenvalue is real
_JUMP = 1e-6         # |G| at a bisection limit / |G| at the grid points: above, a jump
_BISECT = 60
_NEWTON = 3          # Newton steps that polish each root


# ------------------------------------------------------------ the frozen model
class _Out:
    """An output-dependent factor: an output lag, or a Φ-call with output args.

    ``args`` holds, per argument, ``('y', lag)`` or ``('u', values)`` (the
    input argument's values at the analysed rows).
    """

    __slots__ = ("lag", "fn", "args")

    def __init__(self, lag=None, fn=None, args=()):
        self.lag, self.fn, self.args = lag, fn, list(args)

    @property
    def all_outputs(self) -> bool:
        return all(kind == "y" for kind, _ in self.args)

    def poly(self):
        """Coefficients (ascending, arrays or numbers) in ỹ, or None."""
        if self.fn is None:
            return [0.0, 1.0]
        if self.all_outputs:
            return [self.fn.steady_value()] if self.fn.steady_is_constant else None
        if self.fn.form == "difference":
            (ka, va), (kb, vb) = self.args
            return [(0.0 if ka == "y" else va) - (0.0 if kb == "y" else vb),
                    float(ka == "y") - float(kb == "y")]
        return None

    def _argv(self, x, idx, shift=None):
        out = []
        for p, (kind, v) in enumerate(self.args):
            a = x if kind == "y" else v[idx].reshape(v[idx].shape + (1,) * (x.ndim - 1))
            if shift is not None and p == shift[0]:
                a = a + shift[1]
            out.append(a)
        return out

    def value(self, x, idx):
        if self.fn is None:
            return x
        if self.all_outputs:
            return np.broadcast_to(np.asarray(self.fn.steady_value(x), float), x.shape)
        with np.errstate(all="ignore"):
            return np.asarray(self.fn.func(*self._argv(x, idx)), dtype=float)

    def value_dd(self, x, idx):
        """:meth:`value` as a double-double ``(hi, lo)``: exact for an
        output lag, a constant steady value and a difference of an output
        and an input; the float value (``lo`` 0) otherwise."""
        zero = np.zeros(x.shape)
        if self.fn is None:
            return x, zero
        if self.fn.form == "difference" and not self.all_outputs:
            a, b = self._argv(x, idx)
            return _two_sum(a, -b)
        return self.value(x, idx), zero

    def derivative(self, x, idx, lag):
        """∂(factor)/∂y_{k-lag} with every output lag at ``x``."""
        if self.fn is None:
            return np.full(x.shape, 1.0 if self.lag == lag else 0.0)
        d = np.zeros(x.shape)
        for p, (kind, v) in enumerate(self.args):
            if kind != "y" or v != lag:
                continue
            if self.fn.form == "difference":
                d += 1.0 if p == 0 else -1.0
            elif self.fn.form != "sign":
                h = 1e-6 * np.maximum(1.0, np.abs(x))
                with np.errstate(all="ignore"):
                    hi = self.fn.func(*self._argv(x, idx, (p, h)))
                    lo = self.fn.func(*self._argv(x, idx, (p, -h)))
                d += (np.asarray(hi, float) - np.asarray(lo, float)) / (2 * h)
        return d


class _Frozen:
    """θ_i c_i Π f(ỹ) per term, the non-output factors frozen at ``rows``."""

    def __init__(self, model, data: Data, rows: np.ndarray):
        reg = model.registry
        self.rows = rows
        self.theta, self.cfac, self.outs = [], [], []
        lags = set()
        for t, th in zip(model.terms, model.theta):
            if t.has_noise:
                continue
            cf = [factor_column(f, data, registry=reg)[rows] for f in t.input_factors]
            outs = []
            for f in t.output_factors:
                if isinstance(f, Lag):
                    outs.append(_Out(lag=f.lag))
                    lags.add(f.lag)
                    continue
                args = []
                for a in f.args:
                    if a.role == "y":
                        args.append(("y", a.lag))
                        lags.add(a.lag)
                    else:
                        args.append(("u", factor_column(a, data)[rows]))
                outs.append(_Out(fn=reg.get(f.name), args=args))
            self.theta.append(float(th))
            self.cfac.append(cf)
            self.outs.append(outs)
        self.lags = tuple(sorted(lags))

    def arrays(self):
        """Every frozen value array, in a fixed order (for extrapolation)."""
        for cf, outs in zip(self.cfac, self.outs):
            yield from cf
            for o in outs:
                yield from (v for kind, v in o.args if kind == "u")

    def extrapolate_from(self, other: "_Frozen"):
        """In place: 2 self − other for every frozen value (step → 0)."""
        for a, b in zip(list(self.arrays()), list(other.arrays())):
            size = np.abs(a) + np.abs(b)
            a *= 2.0
            a -= b
            a[np.abs(a) <= 1e-6 * size] = 0.0       # cancelled: the limit is 0

    def finish(self):
        n = self.rows.shape[0]
        self.c = [th * (np.prod(cf, axis=0) if cf else np.ones(n))
                  for th, cf in zip(self.theta, self.cfac)]
        self.c_dd = []                              # θ Π c as double-doubles
        for th, cf in zip(self.theta, self.cfac):
            v = (np.full(n, th), np.zeros(n))
            for col in cf:
                v = _dd_mul(v, (col, np.zeros(n)))
            self.c_dd.append(v)
        return self

    # ---- polynomial form
    def polynomial(self):
        """(G, S): coefficients of F_k(ỹ) − ỹ (rows, D+1), ascending, and the
        size of the terms that make each coefficient; None if not polynomial."""
        n = self.rows.shape[0]
        polys = []
        for c, outs in zip(self.c, self.outs):
            p = np.ones((n, 1))
            for o in outs:
                q = o.poly()
                if q is None:
                    return None
                q = np.column_stack([np.broadcast_to(np.asarray(v, float), (n,)) for v in q])
                p = _pmul(p, q)
            polys.append(c[:, None] * p)
        deg = max([1] + [p.shape[1] - 1 for p in polys])
        G = np.zeros((n, deg + 1))
        S = np.zeros((n, deg + 1))
        for p in polys:
            G[:, :p.shape[1]] += p
            S[:, :p.shape[1]] += np.abs(p)
        G[:, 1] -= 1.0
        S[:, 1] += 1.0
        return G, S

    # ---- evaluation
    def terms_at(self, x, idx):
        """Per-term values θ c Π f(x) at rows ``idx`` (x: (len(idx), R))."""
        out = []
        for c, outs in zip(self.c, self.outs):
            v = np.broadcast_to(c[idx][:, None], x.shape).copy()
            for o in outs:
                v *= o.value(x, idx)
            out.append(v)
        return out

    def G(self, x, idx):
        """(F(x) − x, size of its terms) at rows ``idx``."""
        with np.errstate(all="ignore"):
            tv = self.terms_at(x, idx)
            g = sum(tv) - x if tv else -x
            s = sum(np.abs(v) for v in tv) + np.abs(x) if tv else np.abs(x)
        return g, s

    def residual(self, x, idx):
        """F(x) − x at rows ``idx``, summed in double-double arithmetic
        (:func:`_two_sum`, :func:`_two_prod`) and rounded once: no
        cancellation between the terms (y[k-1] − ỹ with θ = 1 cancels
        exactly), so the root of the rounded residual is the root of the
        equation to a few units of the last place."""
        zero = np.zeros(x.shape)
        g = (-x, zero)
        with np.errstate(all="ignore"):
            for (ch, cl), outs in zip(self.c_dd, self.outs):
                v = (np.broadcast_to(ch[idx][:, None], x.shape),
                     np.broadcast_to(cl[idx][:, None], x.shape))
                for o in outs:
                    v = _dd_mul(v, o.value_dd(x, idx))
                g = _dd_add(g, v)
            return g[0] + g[1]

    def slope(self, x, idx):
        """dG/dx = Σ_j d_j − 1 at rows ``idx`` (G = F − x, every lag = x)."""
        if not self.lags:
            return np.full(x.shape, -1.0)
        return np.sum(self.lag_derivatives(x, idx), axis=0) - 1.0

    def lag_derivatives(self, x, idx):
        """d_j = ∂ŷ_k/∂ŷ_{k-j} at every lag = x, j = 1 .. largest lag."""
        n = max(self.lags)
        d = np.zeros((n,) + x.shape)
        with np.errstate(all="ignore"):
            vals = [[o.value(x, idx) for o in outs] for outs in self.outs]
            for c, outs, vs in zip(self.c, self.outs, vals):
                cc = c[idx][:, None]
                for j in self.lags:
                    for a, o in enumerate(outs):
                        dv = o.derivative(x, idx, j)
                        if not np.any(dv):
                            continue
                        for b, v in enumerate(vs):
                            if b != a:
                                dv = dv * v
                        d[j - 1] += cc * dv
        return d

    def radius(self, x, idx):
        """Spectral radius of the recursion linearised at every lag = x."""
        if not self.lags:
            return np.zeros(x.shape)
        d = self.lag_derivatives(x, idx)
        n = d.shape[0]
        if n == 1:
            return np.abs(d[0])
        flat = d.reshape(n, -1).T                       # (points, n): d_1 .. d_n
        r = np.full(flat.shape[0], np.inf)
        ok = np.all(np.isfinite(flat), axis=1)
        if ok.any():
            C = np.zeros((int(ok.sum()), n, n))
            C[:, 0, :] = flat[ok]                       # z^n - d1 z^(n-1) - ... - dn
            C[:, np.arange(1, n), np.arange(n - 1)] = 1.0
            r[ok] = np.max(np.abs(np.linalg.eigvals(C)), axis=1)
        return r.reshape(x.shape)


def _pmul(a, b):
    """Row-wise product of polynomials with ascending coefficients."""
    out = np.zeros((a.shape[0], a.shape[1] + b.shape[1] - 1))
    for i in range(a.shape[1]):
        for j in range(b.shape[1]):
            out[:, i + j] += a[:, i] * b[:, j]
    return out


_SPLIT = 134217729.0      # 2**27 + 1: Dekker's split of a float64


def _two_sum(a, b):
    """(s, e) with s = fl(a + b) and s + e = a + b exactly (Knuth)."""
    s = a + b
    bb = s - a
    return s, (a - (s - bb)) + (b - bb)


def _two_prod(a, b):
    """(p, e) with p = fl(a b) and p + e = a b exactly (Dekker)."""
    p = a * b
    ca, cb = _SPLIT * a, _SPLIT * b
    ah, bh = ca - (ca - a), cb - (cb - b)
    al, bl = a - ah, b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def _dd_add(x, y):
    """Sum of two double-doubles ``(hi, lo)``."""
    s, e = _two_sum(x[0], y[0])
    return _two_sum(s, e + (x[1] + y[1]))


def _dd_mul(x, y):
    """Product of two double-doubles ``(hi, lo)``."""
    p, e = _two_prod(x[0], y[0])
    return _two_sum(p, e + (x[0] * y[1] + x[1] * y[0]))


# ------------------------------------------------------------ solving
def _compact(x, rel=1e-7):
    """Rows of roots (NaN: none): sorted, near-equal ones merged, NaN last,
    trailing all-NaN columns dropped (at least one column kept)."""
    x = np.sort(x, axis=1)
    if x.shape[1] > 1:
        dup = np.zeros(x.shape, dtype=bool)
        dup[:, 1:] = np.diff(x, axis=1) <= rel * (1 + np.abs(x[:, 1:]))
        x = np.sort(np.where(dup, np.nan, x), axis=1)
    keep = max(1, int(np.max(np.sum(np.isfinite(x), axis=1), initial=0)))
    return x[:, :keep]


def _solve_polynomial(G, S, tol):
    """Real roots (rows, R) NaN-padded and the solution kind per row."""
    n = G.shape[0]
    Gz = np.where(np.abs(G) <= tol * S, 0.0, G)
    nz = Gz != 0.0
    deg = np.where(nz.any(axis=1), G.shape[1] - 1 - np.argmax(nz[:, ::-1], axis=1), -1)
    roots = np.full((n, max(1, int(deg.max(initial=1)))), np.nan)
    one = deg == 1
    roots[one, 0] = -Gz[one, 0] / Gz[one, 1]
    for d in np.unique(deg[deg >= 2]):
        rows = np.flatnonzero(deg == d)
        monic = Gz[rows, :d] / Gz[rows, d:d + 1]
        C = np.zeros((rows.size, d, d))
        C[:, np.arange(1, d), np.arange(d - 1)] = 1.0
        C[:, :, d - 1] = -monic
        with np.errstate(all="ignore"):
            ev = np.linalg.eigvals(C)
        real = np.abs(ev.imag) <= _REAL * (1 + np.abs(ev.real))
        roots[rows, :d] = np.where(real, ev.real, np.nan)
    roots = _compact(roots)
    kind = np.where(deg < 0, "continuum", "none").astype(object)
    kind[np.any(np.isfinite(roots), axis=1)] = "isolated"
    return roots, kind


def _polish(fz: _Frozen, roots):
    """Each root refined by up to :data:`_NEWTON` Newton steps on the
    frozen equation, x ← x − G(x)/G'(x), G evaluated by
    :meth:`_Frozen.residual`; a step is kept only where it lowers |G| and
    moves the root by at most 1e-3 (1 + |x|) (so it stays on its root),
    else the root stays where it was."""
    ok = np.isfinite(roots)
    if not ok.any():
        return roots
    rr, cc = np.nonzero(ok)
    x = roots[rr, cc][:, None]
    g = fz.residual(x, rr)
    for _ in range(_NEWTON):
        with np.errstate(all="ignore"):
            step = g / fz.slope(x, rr)
            xn = x - step
            gn = fz.residual(xn, rr)
            keep = np.isfinite(xn) & (np.abs(step) <= 1e-3 * (1 + np.abs(x))) & \
                (np.abs(gn) < np.abs(g))
        if not keep.any():
            break
        x, g = np.where(keep, xn, x), np.where(keep, gn, g)
    out = roots.copy()
    out[rr, cc] = x[:, 0]
    return out


def _solve_numerical(fz: _Frozen, y_range, grid, tol):
    """Roots by grid scan and bisection (see the module doc)."""
    n = fz.rows.shape[0]
    idx = np.arange(n)
    X = np.linspace(y_range[0], y_range[1], int(grid))
    x = np.broadcast_to(X, (n, X.size))
    g, s = fz.G(x, idx)
    fin = np.isfinite(g)
    small = fin & (np.abs(g) <= tol * s)
    kind = np.where(np.all(small, axis=1), "continuum", "none").astype(object)
    zr, zc = np.nonzero(small & (kind == "none")[:, None])
    rows, vals = [zr], [X[zc]]
    sg = np.sign(np.where(fin & ~small, g, 0.0))
    pr, pc = np.nonzero(sg[:, :-1] * sg[:, 1:] < 0)
    if pr.size:
        lo, hi = X[pc].copy(), X[pc + 1].copy()
        slo = sg[pr, pc]
        for _ in range(_BISECT):
            mid = 0.5 * (lo + hi)
            gm, _s = fz.G(mid[:, None], pr)
            same = np.sign(gm[:, 0]) == slo
            lo = np.where(same, mid, lo)
            hi = np.where(same, hi, mid)
        mid = 0.5 * (lo + hi)
        gm, _s = fz.G(mid[:, None], pr)
        ends = np.maximum(np.abs(g[pr, pc]), np.abs(g[pr, pc + 1]))
        root = np.abs(gm[:, 0]) <= _JUMP * ends
        rows.append(pr[root])
        vals.append(mid[root])
    rows, vals = np.concatenate(rows), np.concatenate(vals)
    order = np.lexsort((vals, rows))
    rows, vals = rows[order], vals[order]
    count = np.bincount(rows, minlength=n)
    pos = np.arange(rows.size) - np.repeat(np.cumsum(count) - count, count)
    roots = np.full((n, max(1, int(count.max(initial=0)))), np.nan)
    roots[rows, pos] = vals
    roots = _compact(roots)
    kind[np.any(np.isfinite(roots), axis=1)] = "isolated"
    return roots, kind


# ------------------------------------------------------------ results
@dataclass(frozen=True)
class Equilibria:
    """Solutions of the frozen equation ỹ = F(ỹ) at a set of samples.

    Attributes
    ----------
    roots : ndarray (n, R)
        Real solutions, ascending, NaN-padded to the largest count R.
    attracting : ndarray of bool (n, R)
        True where the solution attracts (spectral radius < 1).
    radius : ndarray (n, R)
        Spectral radius of the linearised recursion at each solution
        (|∂ŷ_k/∂ŷ_{k-1}| for one output lag).
    solution : ndarray of str (n,)
        ``'isolated'`` (at least one root), ``'continuum'`` (the equation
        holds for every ỹ), ``'none'`` (no real root; numerically: none in
        ``y_range``), ``'initial'`` (before the model's largest lag).
    """

    roots: np.ndarray
    attracting: np.ndarray
    radius: np.ndarray
    solution: np.ndarray

    def at(self, i) -> Tuple[list, list]:
        """(roots, attracting) of sample ``i`` as Python lists."""
        ok = np.isfinite(self.roots[i])
        return ([float(v) for v in self.roots[i][ok]],
                [bool(v) for v in self.attracting[i][ok]])

    def lists(self) -> Tuple[list, list]:
        """(roots, attracting) of every sample as lists of Python lists."""
        rs, at = self.roots.tolist(), self.attracting.tolist()
        keep = [[v == v for v in r] for r in rs]            # NaN pads dropped
        return ([[v for v, k in zip(r, kk) if k] for r, kk in zip(rs, keep)],
                [[a for a, k in zip(r, kk) if k] for r, kk in zip(at, keep)])

    def to_dict(self) -> dict:
        rs, at = self.lists()
        return {"roots": rs, "attracting": at, "solution": [str(s) for s in self.solution]}


@dataclass(frozen=True)
class BoundingStructure:
    """Equilibria with the input on a ramp through ū (see the module doc).

    Attributes
    ----------
    u : ndarray (G,)
        The values ū of the first input, spanning its range.
    step : float
        δ, the input's change per sample on the branches (0: the limit).
    loading, unloading, rest : Equilibria
    """

    u: np.ndarray
    step: float
    loading: Equilibria
    unloading: Equilibria
    rest: Equilibria

    def branch(self, name: str) -> Equilibria:
        return getattr(self, name)

    def envelope(self) -> Tuple[float, float]:
        """Lowest and highest attracting equilibrium over the input's range
        on the loading and unloading branches (NaN when there is none)."""
        vals = np.concatenate([np.where(e.attracting, e.roots, np.nan).ravel()
                               for e in (self.loading, self.unloading)])
        vals = vals[np.isfinite(vals)]
        return (float(vals.min()), float(vals.max())) if vals.size else (np.nan, np.nan)

    def to_dict(self) -> dict:
        return {"u": [float(v) for v in self.u], "step": float(self.step),
                "rule": "input on a ramp u[k-j] = u - s*step*j through u (s = +1 loading, "
                        "-1 unloading, 0 rest); step 0: every factor at its limit "
                        "(Phi1 = 0, Phi2 = s)",
                "envelope": [None if not np.isfinite(v) else v for v in self.envelope()],
                **{b: self.branch(b).to_dict() for b in BRANCHES}}


@dataclass(frozen=True)
class QuasiStaticResult:
    """Quasi-static analysis of a model on an input record.

    Attributes
    ----------
    k : ndarray of int (N,)
        Sample index (0-based row of the record).
    U : ndarray (N, m)
        The input record (column j: input ``inputs[j]``).
    branch : ndarray of str (N,)
        ``'loading'``, ``'unloading'`` or ``'rest'`` (sign of u_k − u_{k-1}
        of the first input).
    points : Equilibria
        Solutions of the frozen equation at every sample.
    y : ndarray (N,)
        The model's free run on the record.
    y_data : ndarray (N,) or None
        The measured output, when given.
    diverged : bool
        The free run diverged.
    bounding : BoundingStructure
    method : str
        ``'polynomial'`` or ``'numerical'`` (see the module doc).
    lags : tuple of int
        The output lags of the model.
    inputs : tuple of str
    output : str
    """

    k: np.ndarray
    U: np.ndarray
    branch: np.ndarray
    points: Equilibria
    y: np.ndarray
    y_data: Optional[np.ndarray]
    diverged: bool
    bounding: BoundingStructure
    method: str
    lags: Tuple[int, ...]
    inputs: Tuple[str, ...]
    output: str

    @property
    def u(self) -> np.ndarray:
        """The first input."""
        return self.U[:, 0]

    @property
    def roots(self) -> np.ndarray:
        return self.points.roots

    @property
    def attracting(self) -> np.ndarray:
        return self.points.attracting

    @property
    def solution(self) -> np.ndarray:
        return self.points.solution

    def sets(self, branch: str, attracting: bool) -> Tuple[np.ndarray, np.ndarray]:
        """(u, ỹ) of every attracting (or repelling) solution on ``branch``:
        the sets ŷ_L^a, ŷ_L^r, ŷ_U^a, ŷ_U^r of [1]_ for loading/unloading."""
        if branch not in _SIGN:
            raise ValueError(f"branch must be one of {', '.join(BRANCHES)}, got {branch!r}")
        on = (self.branch == branch)[:, None] & np.isfinite(self.roots) & \
            (self.attracting == bool(attracting))
        return np.broadcast_to(self.u[:, None], on.shape)[on], self.roots[on]

    def counts(self) -> dict:
        """Per branch: samples, and how many have an attracting root, only
        repelling roots, a continuum, no solution."""
        out = {}
        for b in BRANCHES:
            on = (self.branch == b) & (self.solution != "initial")
            iso = on & (self.solution == "isolated")
            att = iso & np.any(self.attracting & np.isfinite(self.roots), axis=1)
            out[b] = {"samples": int(on.sum()), "attracting": int(att.sum()),
                      "repelling_only": int((iso & ~att).sum()),
                      "continuum": int((on & (self.solution == "continuum")).sum()),
                      "none": int((on & (self.solution == "none")).sum())}
        return out

    def to_dict(self) -> dict:
        """JSON-able: ``{"points": [...], "bounding": {...}, ...}``."""
        rs, at = self.points.lists()
        us = self.U[:, 0].tolist() if self.U.shape[1] == 1 else self.U.tolist()
        ys = [v if np.isfinite(v) else None for v in self.y.tolist()]
        pts = [{"k": k, "u": u, "branch": b, "roots": r, "attracting": a, "solution": s,
                "y": y} for k, u, b, r, a, s, y in
               zip(self.k.tolist(), us, self.branch.tolist(), rs, at,
                   self.solution.tolist(), ys)]
        return {"output": self.output, "inputs": list(self.inputs), "method": self.method,
                "output_lags": list(self.lags), "diverged": bool(self.diverged),
                "points": pts, "bounding": self.bounding.to_dict()}


# ------------------------------------------------------------ entry point
def _branches(u):
    d = np.zeros(u.shape[0])
    if u.shape[0] > 1:
        d[1:] = np.diff(u)
        d[0] = d[1]
    return np.array(BRANCHES, dtype=object)[np.where(d > 0, 0, np.where(d < 0, 1, 2))]


def _equilibria(fz: _Frozen, y_range, grid, tol):
    fz.finish()
    poly = fz.polynomial()
    if poly is not None:
        roots, kind = _solve_polynomial(*poly, tol)
    else:
        roots, kind = _solve_numerical(fz, y_range, grid, tol)
    roots = _compact(_polish(fz, roots))
    rad = np.full(roots.shape, np.nan)
    ok = np.isfinite(roots)
    if ok.any():
        rr, _ = np.nonzero(ok)
        rad[ok] = fz.radius(roots[ok][:, None], rr)[:, 0]
    return Equilibria(roots, ok & (rad < 1.0), rad, kind), poly is not None


def _ramps(U, grid_u, s, step, maxlag):
    """Record of one ramp per ū (first input), each ``maxlag + 1`` long; the
    last row of each is the analysed sample."""
    L = maxlag + 1
    j = np.arange(L - 1, -1, -1.0)                      # lag of each row from the end
    first = (grid_u[:, None] - s * step * j[None, :]).ravel()
    cols = [first] + [np.full(first.size, float(np.mean(c))) for c in U[:, 1:].T]
    return np.column_stack(cols), np.arange(L - 1, first.size, L)


def _bounding(model, U, y_range, grid, tol, npoints, step):
    u0 = U[:, 0]
    lo, hi = float(u0.min()), float(u0.max())
    gu = np.linspace(lo, hi, int(npoints)) if hi > lo else np.array([lo])
    scale = max(hi - lo, abs(lo), abs(hi), 1e-300)
    d0 = 1e-7 * scale
    out = {}
    for b in BRANCHES:
        s = _SIGN[b]

        def frozen(st):
            R, rows = _ramps(U, gu, s, st, model.max_lag)
            return _Frozen(model, Data(R, inputs=model.inputs), rows)
        if s == 0 or step > 0:
            fz = frozen(step)
        else:
            fz = frozen(d0)
            fz.extrapolate_from(frozen(2 * d0))
        out[b] = _equilibria(fz, y_range, grid, tol)[0]
    return BoundingStructure(gu, float(step), **out)


def _check_int(name, v, low):
    if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < low:
        raise ValueError(f"{name} must be an integer >= {low}, got {v!r}")
    return int(v)


def quasistatic(model, u, y=None, *, y0=None, y_range=None, grid: int = 801,
                bounding_points: int = 201, bounding_step: float = 0.0,
                tol: float = 1e-9) -> QuasiStaticResult:
    """Quasi-static analysis of ``model`` on the input ``u`` (module doc).

    Parameters
    ----------
    model : narx.Model
        A model with θ, in the term language (any terms, built-in and
        plug-in Φ-functions of its registry).
    u : array_like (N,) or (N, m), or narx.Data
        The input record (a ``Data`` record may carry the output).
    y : array_like (N,), optional
        Measured output: its first samples start the free run, and it is
        kept as ``y_data``.
    y0 : array_like, optional
        Initial outputs of the free run when there is no measured output
        (default zeros).
    y_range : (float, float), optional
        Search interval of the numerical method (non-polynomial models).
    grid : int
        Grid points of the numerical method (>= 3).
    bounding_points : int
        Values ū of the bounding structure (>= 2).
    bounding_step : float
        δ >= 0, the input's change per sample on the bounding branches
        (0: the limit of a vanishing rate, Phi1 held at 0).
    tol : float
        Relative size under which a coefficient of the frozen equation is
        0 (an identically satisfied equation is a continuum).

    Returns
    -------
    QuasiStaticResult

    Raises
    ------
    ValueError
        A model without θ, a record too short for the model's lags, a bad
        option value.
    """
    if getattr(model, "theta", None) is None:
        raise ValueError("the model has no parameters yet: call fit() or pass theta")
    grid = _check_int("grid", grid, 3)
    bounding_points = _check_int("bounding_points", bounding_points, 2)
    step = float(bounding_step)
    if not (np.isfinite(step) and step >= 0):
        raise ValueError(f"bounding_step must be a finite number >= 0, got {bounding_step!r}")
    if not (np.isfinite(tol) and 0 <= tol < 1):
        raise ValueError(f"tol must be in [0, 1), got {tol!r}")
    data = as_data(u, y, inputs=model.inputs, output=model.output)
    if tuple(data.inputs) != tuple(model.inputs):
        raise ValueError(f"data inputs {list(data.inputs)} do not match the model's "
                         f"{list(model.inputs)}")
    ml, n = model.max_lag, data.n
    if n <= ml + 1:
        raise DataError(f"record of {n} samples is too short for the model's largest "
                        f"lag {ml} (need at least {ml + 2})")
    if data.y is not None and y0 is not None:
        raise ValueError("give the measured output y or the initial outputs y0, not both "
                         "(y's first samples start the free run)")
    if data.y is None:
        y0 = np.zeros(ml) if y0 is None else np.asarray(y0, float).ravel()
        sim = model.simulate(data, mode="freerun", y0=y0)
    else:
        sim = model.simulate(data, mode="freerun")
    yfr = np.asarray(sim.y_hat, float)
    if y_range is None:
        fin = yfr[np.isfinite(yfr)]
        fin = np.concatenate([fin, [0.0]])
        span = max(float(np.ptp(fin)), float(np.max(np.abs(fin))), 1.0)
        y_range = (float(fin.min()) - 5 * span, float(fin.max()) + 5 * span)
    else:
        try:
            lo, hi = (float(v) for v in y_range)
        except (TypeError, ValueError):
            lo = hi = np.nan
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise ValueError(f"y_range must be two finite numbers LOW < HIGH, got {y_range!r}")
        y_range = (lo, hi)
    U = data.U.T
    rows = np.arange(ml, n)
    fz = _Frozen(model, data, rows)
    eq, is_poly = _equilibria(fz, y_range, grid, tol)
    width = eq.roots.shape[1]
    roots = np.full((n, width), np.nan)
    att = np.zeros((n, width), dtype=bool)
    rad = np.full((n, width), np.nan)
    kind = np.full(n, "initial", dtype=object)
    roots[rows], att[rows], rad[rows], kind[rows] = eq.roots, eq.attracting, eq.radius, \
        eq.solution
    bound = _bounding(model, U, y_range, grid, tol, bounding_points, step)
    return QuasiStaticResult(np.arange(n), np.array(U), _branches(U[:, 0]),
                             Equilibria(roots, att, rad, kind), yfr,
                             None if data.y is None else data.y.copy(), bool(sim.diverged),
                             bound, "polynomial" if is_poly else "numerical", fz.lags,
                             tuple(model.inputs), model.output)
