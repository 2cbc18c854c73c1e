"""Everything that decides: optimisers, reference policies, RL agents, the CLI.

Importing the package asks MKL (torch's BLAS on x86) for float32 results that do not depend
on the instruction set: ``MKL_CBWR=AVX2,STRICT`` unless the environment sets ``MKL_CBWR``, so
that on an Intel CPU MKL runs its AVX2 code whatever the CPU has (AVX-512 included) and sums
in a fixed order whatever the thread count. An AMD CPU does not take the request
(``MKL_VERBOSE=1`` prints ``CNR:AUTO,STRICT`` on an AMD EPYC): MKL runs its own choice there,
so agents' results can differ between Intel and AMD CPUs (docs/benchmarks.md). It acts only if
torch is not loaded yet; if it is, ``MKL_CBWR`` is set empty (MKL's default), so that worker
processes, which inherit it, compute as this one does. Why: an agent's network runs in
float32, MKL's kernels round differently per instruction set, and a closed loop grows that
rounding into a different result. ``COMPATIBLE``, which AMD CPUs take too, changes training;
this mode reproduces the shipped agents bit for bit on the AMD EPYC they were trained on, and
training runs as fast in it. The figures: docs/measurements.md, "agents".
"""

import os as _os
import sys as _sys

MKL_MODE = "MKL_CBWR"  # the variable; agents.parallel hands it to Ray workers

if MKL_MODE not in _os.environ:
    _os.environ[MKL_MODE] = "" if "torch" in _sys.modules else "AVX2,STRICT"
