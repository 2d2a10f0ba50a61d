"""The compiled-kernel machinery: the one numba configuration, ``@compiled``, ``@leaf`` and
``@inlined`` with the kernels' argument types and shared compiled utilities (:mod:`.jit`),
where their machine code is cached, numba's and the one a wheel ships
(:mod:`.kernel_cache`), and the numba internals both need, in one place
(:mod:`.numba_internals`).
"""

from optplan.geometry.compiled.jit import (
    B1,
    B2,
    F1,
    F2,
    F3,
    FA2,
    I1,
    I2,
    argsort_stable,
    b1,
    compiled,
    f8,
    heap_pop,
    heap_push,
    i8,
    inlined,
    leaf,
)

__all__ = ["B1", "B2", "F1", "F2", "F3", "FA2", "I1", "I2", "argsort_stable", "b1",
           "compiled", "f8", "heap_pop", "heap_push", "i8", "inlined", "leaf"]
