"""Export models to sympy expressions and LaTeX.

Typical use::

    model.to_sympy()      # 1.0*y[k-1] - 0.231*Phi1(u[k-2], u[k-3]) + ...
    model.to_latex()      # 'y_{k} = 1\\, y_{k-1} - 0.231\\, \\Phi_{1}(...)'

Lagged signals become sympy symbols named like the term text (``y[k-1]``);
Φ-functions become undefined sympy functions of those symbols.
"""
from __future__ import annotations

from .language.terms import Lag, format_param

__all__ = ["to_sympy", "to_latex", "factor_latex"]


def _lag_latex(f: Lag) -> str:
    return f"{f.signal}_{{k}}" if f.lag == 0 else f"{f.signal}_{{k-{f.lag}}}"


def factor_latex(f) -> str:
    if isinstance(f, Lag):
        return _lag_latex(f)
    name = f.name
    if name.startswith("Phi") and name[3:].isdigit():
        name = f"\\Phi_{{{name[3:]}}}"
    elif name == "Play" and getattr(f, "params", None):
        name = f"P_{{{format_param(f.params[0])}}}"       # play of radius r: P_r
    else:
        name = f"\\mathrm{{{name}}}"
    params = "".join(", " + format_param(p) for p in getattr(f, "params", ())
                     if f.name != "Play")
    return f"{name}({', '.join(_lag_latex(a) for a in f.args)}{params})"


def to_sympy(model):
    try:
        import sympy
    except ImportError:
        raise ImportError("to_sympy needs sympy, which is not installed: "
                          "pip install sympy (or the 'export' extra)") from None
    expr = 0
    syms = {}
    for t, v in zip(model.terms, model._need_theta()):
        prod = sympy.Float(float(v))
        for f in t.factors:
            if isinstance(f, Lag):
                prod *= syms.setdefault(str(f), sympy.Symbol(str(f)))
            else:
                args = [syms.setdefault(str(a), sympy.Symbol(str(a))) for a in f.args]
                args += [sympy.Float(p) for p in getattr(f, "params", ())]
                prod *= sympy.Function(f.name)(*args)
        expr += prod
    return expr


def to_latex(model, precision: int = 4) -> str:
    out = []
    for i, (t, v) in enumerate(zip(model.terms, model._need_theta())):
        mag = f"{abs(v):.{precision}g}"
        if "e" in mag:
            m, e = mag.split("e")
            mag = f"{m} \\cdot 10^{{{int(e)}}}"
        body = mag + "".join(f"\\, {factor_latex(f)}" for f in t.factors)
        sign = "-" if v < 0 else "+"
        out.append(body if i == 0 and sign == "+" else f"{sign} {body}")
    return f"{model.output}_{{k}} = " + " ".join(out)
