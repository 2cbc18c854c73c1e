"""The package's warm-ups (:mod:`contour_gym.jit.precompile`): tiny runs that compile its kernels.

Each kernel of the built-in components is one for every combination of them, so one run of
any combination compiles it for all.
"""

from __future__ import annotations

import numpy as np


def path_api() -> None:
    """The path API's searches (plots, the exact estimator API) and free-form curves' series."""
    from contour_gym.paths import _batch, load

    for name in ("circle", "helix"):
        path = load(name)
        points = np.zeros((2, path.dim))
        path.nearest(points, s_hint=np.zeros(2))
        path.nearest(points)
        path.track(points, np.zeros(2))
    _batch.chebyshev_many(np.zeros((1, 2, 2)), np.zeros(1, np.int64), np.zeros(1),
                          np.empty((1, 2)))


def servo_loop() -> None:
    """The servo loop of the built-in components (and the shared searches it calls)."""
    from contour_gym.api import make_scenario

    scenario = make_scenario("xy_dc_servo")
    scenario.loop(batch_size=1, ccc_gains=scenario.preset.ccc_gains.as_tuple()).step(3)


def env_step() -> None:
    """The env step (actions, the loop's run, rewards, observations) on the built-in loop."""
    import gymnasium as gym

    import contour_gym  # noqa: F401 (registers the ids)

    env = gym.make("contour_gym/CCC-Circle-v0")
    env.reset(seed=0)
    env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    env.close()


def estimators() -> None:
    """The estimator API's batch kernel of the built-in estimators."""
    from contour_gym.contour import estimate
    from contour_gym.paths import load

    estimate("exact", load("circle"), 0.0, np.array([[0.0101, 0.0]]))


def axes() -> None:
    """The axis-controller bank and the single-axis plant (identification, studies)."""
    from contour_gym.loop import simulate_axis
    from contour_gym.presets import get_preset
    from contour_gym.servo import AxisControllers

    preset = get_preset("xy_dc_servo")
    bank = AxisControllers("pid", preset.stage, preset.axis_gains)
    zeros = np.zeros((1, preset.stage.n_axes))
    bank.control(zeros, zeros, zeros, zeros)
    bank.step(zeros, zeros, zeros, zeros)
    simulate_axis(preset.stage.axes[0], np.zeros(3))
