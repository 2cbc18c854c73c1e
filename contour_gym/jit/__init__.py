"""Compiled code: the kernels bound to their components, cached, warmed up, counted.

* :mod:`~contour_gym.jit.binding`: templates, slots and the families that fill them;
  :func:`bind` and :func:`specialise` make a kernel module; :func:`slot_table` says what code
  each slot runs;
* :mod:`~contour_gym.jit.slots`: the slots' stubs (what a component must look like);
* :mod:`~contour_gym.jit.cache`: numba's cache folder, named by a digest of the kernel modules;
* :mod:`~contour_gym.jit.precompile`, :mod:`~contour_gym.jit.warmups`: the built-ins' kernels
  compiled up front in worker processes; :mod:`~contour_gym.jit.tiers`: a run's own kernel
  or the built-ins' one, and compiles in the background;
* :mod:`~contour_gym.jit.progress`: the progress line of a first run, and a census of what
  it compiled; :mod:`~contour_gym.jit.stack`, :mod:`~contour_gym.jit.inline_copy`,
  :mod:`~contour_gym.jit.flags_eq`: three fixes that make numba's compile faster.

**What a kernel calls compiles with it.** A function a kernel calls (the exact search and
ground truth, the estimators, the history ring) is a :func:`contour_gym._callee.callee`: an
``@numba.njit`` without ``cache`` and without the entry points Python calls through. It
compiles in the process that compiles the kernel, where LLVM can inline it; one loaded from
numba's cache is machine code LLVM cannot inline. The public building blocks of
:mod:`contour_gym.contour.kernels` stay plain ``@numba.njit`` (a user may call them from
Python). The kernels themselves and the functions called from Python
(:mod:`contour_gym.paths._batch`, the estimator API's kernel) are cached.

**Inlined by whom.** ``inline="always"`` makes numba inline a function's IR at every call
site, typing it again each time; ``forceinline=True`` types it once and has LLVM inline it.
The path's evaluation, called at many sites (:func:`contour_gym.paths._geom.eval_segment`,
``find_segment``, ``eval_path``, :func:`contour_gym.contour._history.eval_path_memo`) and a
blob's sizes are the second kind; the other per-tick helpers the first.
``tests/test_compile_budget.py`` counts what a first run compiles.
"""

from contour_gym.jit.binding import (
    GENERATED_PACKAGE,
    Called,
    Family,
    bind,
    builtin_packages,
    dispatcher_source,
    identity,
    is_builtin,
    is_generic,
    slot_table,
    specialise,
)
from contour_gym.jit.cache import (
    cache_root,
    code_digest,
    configure,
    current_digest,
    generated_dir,
    kernel_sources,
    mark_compiled,
    needs_compile,
    package_digest,
)
from contour_gym.jit.progress import Census, census, compiling

__all__ = [
    "GENERATED_PACKAGE", "Called", "Census", "Family", "bind", "builtin_packages", "cache_root",
    "census", "code_digest", "compiling", "configure", "current_digest", "dispatcher_source",
    "generated_dir", "identity", "is_builtin", "is_generic", "kernel_sources", "mark_compiled",
    "needs_compile", "package_digest", "slot_table", "specialise",
]
