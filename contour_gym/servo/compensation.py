"""Friction compensation of paper 002 section 3, added to any axis controller's output.

``u_comp = F_predicted / force_constant`` with the LuGre model of
:mod:`contour_gym.plant.friction.lugre` (the same kernels the plant uses):

* ``feedforward`` (002 section 3.1, figs. 5-7): the LuGre model driven by the command velocity
  ``r'``, so the compensation is ready before the motion it serves; its bristle state is
  advanced each tick;
* ``feedback``, the traditional scheme 002 compares against (its equations are not given; the
  text only says it is driven by velocity feedback and lags a cycle): the same model driven by
  the measured velocity (the backward difference of ``y``);
* ``feedback_static``: the steady-state friction of 002 eq. 3 at the measured velocity, the
  classic Coulomb/Stribeck compensation without bristle dynamics.

Select with the controller options ``friction=`` and ``friction_model=`` (the identified
:class:`~contour_gym.plant.friction.LuGreFriction`, e.g. from
:func:`agents.identify.identify_friction`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numba
import numpy as np

from contour_gym._schema import Schema, state_schema
from contour_gym._validate import choice
from contour_gym.jit import Family
from contour_gym.jit.slots import no_compensation
from contour_gym.plant.friction.lugre import (
    LuGreFriction,
    lugre_advance,
    lugre_force,
    lugre_rate,
    static_friction,
)
from contour_gym.servo.base import measured_velocity

if TYPE_CHECKING:
    from contour_gym.plant.stage import Stage

NONE, FEEDFORWARD, FEEDBACK, FEEDBACK_STATIC = 0, 1, 2, 3
MODES = {"none": NONE, "feedforward": FEEDFORWARD, "feedback": FEEDBACK,
         "feedback_static": FEEDBACK_STATIC}
OPTIONS = ("friction", "friction_model")

PARAMS = Schema(
    "compensation", mode=0.0, inv_k=0.0, sigma0=1.0, sigma1=0.0, sigma2=0.0, fc=1.0, fs=1.0,
    vs=1.0,
)
STATE = state_schema("compensation state", "z", "n", "y_prev")
C, S = PARAMS.col, STATE.col


@numba.njit(cache=True, inline="always")
def _velocity(p, s, i, r_dot, y, ts):
    # feed-forward predicts from the command, feedback from the last measured motion
    if p[i, C.mode] == FEEDFORWARD:
        return r_dot
    return measured_velocity(s[i, S.n], s[i, S.y_prev], y, ts)


@numba.njit(cache=True, inline="always")
def output(p, s, i, r_dot, y, ts):
    """Compensation of this tick, control units (0 when off)."""
    mode = p[i, C.mode]
    if mode == NONE:
        return 0.0
    v = _velocity(p, s, i, r_dot, y, ts)
    if mode == FEEDBACK_STATIC:
        force = static_friction(p[i, C.sigma2], p[i, C.fc], p[i, C.fs], p[i, C.vs], v)
    else:
        a = lugre_rate(p[i, C.sigma0], p[i, C.fc], p[i, C.fs], p[i, C.vs], v)
        force = lugre_force(p[i, C.sigma0], p[i, C.sigma1], p[i, C.sigma2], a, s[i, S.z], v)
    return force * p[i, C.inv_k]


@numba.njit(cache=True, inline="always")
def commit(p, s, i, r_dot, y, ts):
    """Advance the model's bristle state; remember the measurement."""
    mode = p[i, C.mode]
    if mode == NONE:
        return
    if mode != FEEDBACK_STATIC:
        v = _velocity(p, s, i, r_dot, y, ts)
        a = lugre_rate(p[i, C.sigma0], p[i, C.fc], p[i, C.fs], p[i, C.vs], v)
        s[i, S.z] = lugre_advance(a, s[i, S.z], v, ts)
    s[i, S.y_prev] = y
    s[i, S.n] += 1.0


# the kernels' slots of the compensation (contour_gym.jit.slots): off (code 0) or on (code 1)
COMPENSATION_FAMILY = Family(
    "compensation",
    {
        "COMP_OUTPUT": lambda on: output if on else no_compensation,
        "COMP_COMMIT": lambda on: commit if on else no_compensation,
    },
    lambda: (False, True),
)


def compensation_rows(
    stage: Stage,
    batch: int,
    friction: str | None = None,
    friction_model: LuGreFriction | Sequence[LuGreFriction | None] | None = None,
) -> np.ndarray:
    """(batch, n_axes, PARAMS.size) rows of the compensation.

    Args:
        stage: The machine (force constants; default models).
        batch: Batch size.
        friction: ``None``/``"none"``, ``"feedforward"``, ``"feedback"`` or
            ``"feedback_static"`` (module docstring).
        friction_model: The (identified) LuGre parameters: one for every axis, one per axis
            (``None`` = no compensation on that axis), or ``None`` for each axis' own LuGre
            friction.

    Raises:
        ValueError: for an unknown mode, or no model for an axis without LuGre friction.
    """
    n = stage.n_axes
    out = np.zeros((batch, n, PARAMS.size))
    mode = MODES[choice("none" if friction is None else friction, "friction", MODES)]
    if mode == NONE:
        return out
    models = _models(stage, friction_model)
    for i, fm in enumerate(models):
        if fm is None:
            continue
        out[:, i] = PARAMS.row(
            mode=mode, inv_k=1.0 / stage.axes[i].force_constant, sigma0=fm.sigma0,
            sigma1=fm.sigma1, sigma2=fm.sigma2, fc=fm.fc, fs=fm.fs, vs=fm.vs,
        )
    return out


def _models(
    stage: Stage, friction_model: LuGreFriction | Sequence[LuGreFriction | None] | None
) -> list[LuGreFriction | None]:
    n = stage.n_axes
    if friction_model is None:
        models: list[object] = [a.friction for a in stage.axes]
        for a, fm in zip(stage.axes, models, strict=True):
            if not isinstance(fm, LuGreFriction):
                raise ValueError(f"axis {a.name!r} has no LuGre friction; pass friction_model")
    elif isinstance(friction_model, LuGreFriction):
        models = [friction_model] * n
    else:
        models = list(friction_model)
        if len(models) != n:
            raise ValueError(f"friction_model needs {n} entries, got {len(models)}")
    for fm in models:
        if fm is not None and not isinstance(fm, LuGreFriction):
            raise ValueError(f"friction_model entries must be LuGreFriction or None, got {fm!r}")
    return models  # type: ignore[return-value]
