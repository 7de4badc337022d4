"""Gram entries of regressor columns with a fixed summation order.

Typical use (internal: :class:`narx.estimation.fitness.StructureScorer` keeps a
slot-indexed cache of entries and fills the missing ones)::

    from narx.estimation.gram import fixed_dot, fill_gram
    G_sub, b = fill_gram(G, bv, store.array, slots, y, start)

Every entry :math:`\\psi_i^T\\psi_j = \\sum_k \\psi_{i,k}\\psi_{j,k}` is
summed in one fixed order (four interleaved partial sums, then
:math:`(s_0+s_1)+(s_2+s_3)`), whatever the memory layout, the process or
the number of products computed together, so a search's results do not
depend on the number of workers. BLAS ``ddot`` rounds differently with the
arrays' alignment and its thread count.
"""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["fixed_dot", "fill_gram", "cross_products"]


@njit(cache=True, nogil=True)
def fixed_dot(a, b):
    """Dot product with a fixed summation order (4 interleaved partial sums).

    BLAS ``ddot`` may round differently depending on memory alignment; the
    cache layout differs between worker processes, so a search whose
    results must not depend on the number of workers needs this one.
    """
    n = a.shape[0]
    m = n - n % 4
    s0 = s1 = s2 = s3 = 0.0
    for i in range(0, m, 4):
        s0 += a[i] * b[i]
        s1 += a[i + 1] * b[i + 1]
        s2 += a[i + 2] * b[i + 2]
        s3 += a[i + 3] * b[i + 3]
    for i in range(m, n):
        s0 += a[i] * b[i]
    return (s0 + s1) + (s2 + s3)


@njit(cache=True, nogil=True)
def _dot4(a, b0, b1, b2, b3):
    """:func:`fixed_dot` of ``a`` with four columns in one pass, each with
    exactly its own 4 partial sums and order, so the four values are bit
    for bit those of four ``fixed_dot`` calls. One pass reads ``a`` once and
    keeps 16 independent sums in flight: a single product is bound by the
    latency of its additions, four together by memory."""
    n = a.shape[0]
    m = n - n % 4
    p0 = p1 = p2 = p3 = q0 = q1 = q2 = q3 = 0.0
    r0 = r1 = r2 = r3 = t0 = t1 = t2 = t3 = 0.0
    for i in range(0, m, 4):
        x0 = a[i]
        x1 = a[i + 1]
        x2 = a[i + 2]
        x3 = a[i + 3]
        p0 += x0 * b0[i]
        p1 += x1 * b0[i + 1]
        p2 += x2 * b0[i + 2]
        p3 += x3 * b0[i + 3]
        q0 += x0 * b1[i]
        q1 += x1 * b1[i + 1]
        q2 += x2 * b1[i + 2]
        q3 += x3 * b1[i + 3]
        r0 += x0 * b2[i]
        r1 += x1 * b2[i + 1]
        r2 += x2 * b2[i + 2]
        r3 += x3 * b2[i + 3]
        t0 += x0 * b3[i]
        t1 += x1 * b3[i + 1]
        t2 += x2 * b3[i + 2]
        t3 += x3 * b3[i + 3]
    for i in range(m, n):
        p0 += a[i] * b0[i]
        q0 += a[i] * b1[i]
        r0 += a[i] * b2[i]
        t0 += a[i] * b3[i]
    return (p0 + p1) + (p2 + p3), (q0 + q1) + (q2 + q3), (r0 + r1) + (r2 + r3), \
        (t0 + t1) + (t2 + t3)


@njit(cache=True, nogil=True)
def _store(G, bv, a, c, v):
    """Keep the product of column ``a`` with column ``c`` (-1: with y)."""
    if c < 0:
        bv[a] = v
    else:
        G[a, c] = v
        G[c, a] = v


@njit(cache=True, nogil=True)
def fill_gram(G, bv, arr, slots, y, s):
    """Gram entries of the columns ``arr[slots]`` and their products with
    ``y`` over rows ``s..``: the missing (NaN) ones of the slot-indexed
    cache ``G``/``bv`` are computed and stored; returns the set's (G, b).

    Each entry is :func:`fixed_dot` of its two columns, bit for bit; the
    missing products of one column are computed four at a time
    (:func:`_dot4`, one pass over that column; y, when missing, comes
    first)."""
    t = slots.shape[0]
    part = np.empty(t + 1, dtype=np.int64)      # -1: y
    for i in range(t):
        a = slots[i]
        k = 0
        if bv[a] != bv[a]:
            part[k] = -1
            k += 1
        for j in range(i, t):
            c = slots[j]
            if G[a, c] != G[a, c]:
                part[k] = c
                k += 1
        col = arr[a, s:]
        q = 0
        while q < k:
            if k - q == 1:
                c = part[q]
                _store(G, bv, a, c, fixed_dot(col, y[s:] if c < 0 else arr[c, s:]))
                q += 1
                continue
            # four at a time; a group of 2 or 3 repeats its last column
            # (as fast as a 2-column pass: the repeat is read from cache)
            g = min(4, k - q)
            c0 = part[q]
            c1 = part[q + 1]
            c2 = part[q + min(2, g - 1)]
            c3 = part[q + g - 1]
            v = _dot4(col, y[s:] if c0 < 0 else arr[c0, s:], arr[c1, s:],
                      arr[c2, s:], arr[c3, s:])
            for e in range(g):
                _store(G, bv, a, part[q + e], v[e])
            q += g
    sub = np.empty((t, t))
    b = np.empty(t)
    for i in range(t):
        a = slots[i]
        b[i] = bv[a]
        for j in range(t):
            sub[i, j] = G[a, slots[j]]
    return sub, b


@njit(cache=True, nogil=True)
def cross_products(A, B):
    """:math:`AB^T` of row-major column sets ``A`` (p, n) and ``B`` (q, n):
    entry (i, j) is :func:`fixed_dot` of rows ``A[i]`` and ``B[j]``, so the
    products do not depend on the arrays' alignment or on BLAS threads."""
    out = np.empty((A.shape[0], B.shape[0]))
    for i in range(A.shape[0]):
        for j in range(B.shape[0]):
            out[i, j] = fixed_dot(A[i], B[j])
    return out
