"""The term language of NARX models: terms, Φ-functions, memory operators.

Typical use::

    from narx.language.terms import parse_terms
    terms = parse_terms(["y[k-1]", "Phi1(u[k-1],u[k-2])"])

Modules: :mod:`~narx.language.terms` (parse and print canonical term
text), :mod:`~narx.language.phi` (the Φ-function table and plug-ins),
:mod:`~narx.language.memory` (hysteresis operators with memory and
plug-ins) and :mod:`~narx.language.registry` (the base of both registries).
"""
