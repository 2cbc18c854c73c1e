"""The servo loop: the batched closed loop of DESIGN.md, one servo tick at a time.

:class:`ServoLoop` (:mod:`contour_gym.loop.core`) packs a stage, a path, the axis controllers,
the estimator, the CCC and the interpolator into arrays with a leading batch dimension and runs
the compiled kernel (:mod:`contour_gym.loop.kernel`) on them. Its parts:

* :mod:`~contour_gym.loop.state`: the arrays by name (blob layouts, row layouts, kernel views);
* :mod:`~contour_gym.loop.member`: what the env and tasks may read of a member, and the
  parameters they may set: the loop's one boundary;
* :mod:`~contour_gym.loop.build`: how the arrays are sized and first filled;
* :mod:`~contour_gym.loop.views`: the arrays as attributes, and the state's read-outs;
* :mod:`~contour_gym.loop.bank`: the members' paths (the path bank, ``loop.bank``);
* :mod:`~contour_gym.loop.parameters`: the parameter setter (``loop.parameters``);
* :mod:`~contour_gym.loop.noise`, :mod:`~contour_gym.loop.record`,
  :mod:`~contour_gym.loop.threads`, :mod:`~contour_gym.loop.options`: random numbers, the
  per-tick record, members on threads, the loop's options;
* :mod:`~contour_gym.loop.axis`: one axis driven open-loop through the loop's plant step.
"""

from contour_gym.loop.core import (
    DEFAULT_SETTLE,
    MAX_RECORD_BYTES,
    MAX_RUN_TICKS,
    NOISE_CHUNK,
    REASON_NAMES,
    LoopOptions,
    ServoLoop,
    Trace,
    member_bytes,
    simulate_axis,
)
from contour_gym.loop.state import REASON_HARD_LIMIT

__all__ = [
    "DEFAULT_SETTLE", "MAX_RECORD_BYTES", "MAX_RUN_TICKS", "NOISE_CHUNK", "REASON_HARD_LIMIT",
    "REASON_NAMES",
    "LoopOptions", "ServoLoop", "Trace", "member_bytes", "simulate_axis",
]
