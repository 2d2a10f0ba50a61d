"""The numba configuration of :mod:`optplan.geometry.compiled.jit`: ``@leaf`` compiles without
reference counting, refuses to allocate, and computes what ``@compiled`` computes."""

from __future__ import annotations

import numpy as np
import pytest
from numba.core.errors import NumbaError

from optplan.geometry.compiled.jit import F1, compiled, f8, i8, leaf
from optplan.geometry.compiled.numba_internals import NO_REFCOUNT


def _scale_into(a, out, s):
    for k in range(a.shape[0]):
        out[k] = s * a[k]
    return a.shape[0]


def test_a_leaf_computes_what_a_compiled_function_computes():
    a = np.random.default_rng(0).normal(size=17)
    out_leaf, out_comp = np.empty(17), np.empty(17)
    n = leaf(F1, F1, f8)(_scale_into)(a, out_leaf, 2.5)
    m = compiled(F1, F1, f8)(_scale_into)(a, out_comp, 2.5)
    assert n == m == 17
    assert np.array_equal(out_leaf, out_comp)
    assert np.array_equal(out_leaf, 2.5 * a)


def test_a_leaf_is_compiled_without_reference_counting():
    assert NO_REFCOUNT.items() <= leaf(F1, F1, f8)(_scale_into).targetoptions.items()
    assert not NO_REFCOUNT.keys() & compiled(F1, F1, f8)(_scale_into).targetoptions.keys()


def test_a_leaf_that_allocates_is_refused():
    def make(n):
        return np.zeros(n)

    fn = leaf(i8)(make)
    with pytest.raises(NumbaError):
        fn(3)


def test_a_leaf_calling_a_leaf_passes_arrays_through():
    inner = leaf(F1, F1, f8)(_scale_into)

    def outer(a, out):
        inner(a, out, 2.0)
        return inner(out, out, 3.0)

    fn = leaf(F1, F1)(outer)
    a = np.arange(5.0)
    out = np.empty(5)
    assert fn(a, out) == 5
    assert np.array_equal(out, 6.0 * a)
