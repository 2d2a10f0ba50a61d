"""The compiled-kernel machinery: the one numba configuration, ``@compiled``, ``@leaf`` and
``@inlined`` with the kernels' argument types and shared compiled utilities (:mod:`.jit`),
where their machine code is cached, numba's and the one a wheel ships
(:mod:`.kernel_cache`), and the numba internals both need, in one place
(:mod:`.numba_internals`).

The package re-exports :mod:`.jit`'s public names (its ``__all__``), which the kernel modules
import from here.
"""

from optplan.geometry.compiled import jit
from optplan.geometry.compiled.jit import *  # noqa: F403

# the form of __all__ type checkers follow through a submodule (the typing spec's idioms)
__all__: list[str] = []
__all__ += jit.__all__
