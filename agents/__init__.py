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
rounding. Measured on an Intel Xeon, ``ppo_ccc_infinity`` on 002's B-spline (max contour
error): 199.0 um with AVX-512 kernels, 188.8 with MKL held to AVX2, 184.1 held to SSE4.2;
177.4 in this mode with AVX-512 allowed or MKL held to AVX2, at one or two threads; MKL's
compatible code gave 174.1, as does an AMD EPYC in this mode. ``COMPATIBLE``, which AMD CPUs
take too, gave the AMD EPYC's default suite bit for bit (not measured on an Intel CPU), but it
changes training: the shipped ``ppo_002_ccc_general`` retrained under it came out different,
while this mode reproduces it bit for bit on the AMD EPYC it was trained on. Training ran as
fast either way (PPO, 120 000 steps on 000's circle: 19.0-20.3 s without, 19.2-19.8 s with).
"""

import os as _os
import sys as _sys

MKL_MODE = "MKL_CBWR"  # the variable; agents.parallel hands it to Ray workers

if MKL_MODE not in _os.environ:
    _os.environ[MKL_MODE] = "" if "torch" in _sys.modules else "AVX2,STRICT"
