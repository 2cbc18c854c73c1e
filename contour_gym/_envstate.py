"""The env kernel's arrays and configuration columns, by name (shared by the tasks' kernels).

The env blob (:data:`ENV_FLOATS`, viewed as :class:`EnvArrays` by :func:`env_arrays`) holds each
member's action, observation, reward and bookkeeping; :data:`ENV_CONFIG` is the float row of the
env's constants (tolerance, limits, the task's and reward's codes, ...), read by column name
(``ec[EC.tol]``). :func:`put` writes one clipped observation column.
"""

from __future__ import annotations

from collections import namedtuple

import numba

from contour_gym._blob import view1, view2
from contour_gym._schema import Schema

# reward, terminated, truncated, failure: consecutive (ContourTask.member_result reads them so)
ENV_FLOATS = (
    "action", "skip", "g_max", "g_log", "lookahead", "eps_prev", "s_before", "obs", "ref",
    "vel", "raw", "reward", "terminated", "truncated", "failure", "comp", "weights", "steps",
    "ret", "track", "feedrate", "nominal", "f_nom", "n_max", "peak", "windows", "prior",
)
# nominal: each member's progress scale (its nominal feedrate x decision time, m); f_nom: its
# nominal feedrate (reference velocity scale, m/s); n_max: its step limit (members run their
# own paths); peak: the episode's peak true contour error so far, m (the ``record`` component);
# windows: the edges of the v1 observation's curvature windows, m (one 0: none); prior: each
# member's curvature-limited override at its last observation (EnvConfig.feedrate_limit)
ENV_AT = namedtuple("E", ENV_FLOATS)(*range(len(ENV_FLOATS)))
EnvArrays = namedtuple("EnvArrays", ENV_FLOATS)  # type: ignore[misc]
ENV_CONFIG = Schema(
    "env config", task=0.0, dovr=0.1, ovr_lo=0.2, ovr_hi=2.0, tol=1e-5, hard=1e-3,
    penalty=100.0, r_lo=-1.0, r_hi=0.0, python_reward=0.0, dim=2.0, reward=0.0,
    observation=1.0, f_max=1.0, horizon=0.02, progress_obs=0.0, target=0.0, t_lo=0.2,
    t_mid=1.0, t_hi=2.0, lim_a=0.0, lim_reach=0.0, lim_vend=0.0, lim_rend=0.0,
    lim_span=0.0,
)
OBSERVATIONS = ("v0", "v1")  # ENV_CONFIG.observation is the index: v0 0, v1 1
OBSERVATION_V0 = 0.0
EC = ENV_CONFIG.col

OBS_LIMIT = 1e4  # every scaled observation is clipped to +-OBS_LIMIT
CURVATURE_SCALE = 0.01  # m: curvature is observed as kappa x 1 cm (public: contour_gym.envs)


@numba.njit(cache=True, inline="always")
def env_arrays(env_floats, env_layout):
    """The env blob as a named tuple of views."""
    return EnvArrays(
        view2(env_floats, env_layout, ENV_AT.action),
        view1(env_floats, env_layout, ENV_AT.skip),
        view1(env_floats, env_layout, ENV_AT.g_max),
        view1(env_floats, env_layout, ENV_AT.g_log),
        view1(env_floats, env_layout, ENV_AT.lookahead),
        view2(env_floats, env_layout, ENV_AT.eps_prev),
        view1(env_floats, env_layout, ENV_AT.s_before),
        view2(env_floats, env_layout, ENV_AT.obs),
        view2(env_floats, env_layout, ENV_AT.ref),
        view2(env_floats, env_layout, ENV_AT.vel),
        view1(env_floats, env_layout, ENV_AT.raw),
        view1(env_floats, env_layout, ENV_AT.reward),
        view1(env_floats, env_layout, ENV_AT.terminated),
        view1(env_floats, env_layout, ENV_AT.truncated),
        view1(env_floats, env_layout, ENV_AT.failure),
        view2(env_floats, env_layout, ENV_AT.comp),
        view1(env_floats, env_layout, ENV_AT.weights),
        view1(env_floats, env_layout, ENV_AT.steps),
        view1(env_floats, env_layout, ENV_AT.ret),
        view2(env_floats, env_layout, ENV_AT.track),
        view1(env_floats, env_layout, ENV_AT.feedrate),
        view1(env_floats, env_layout, ENV_AT.nominal),
        view1(env_floats, env_layout, ENV_AT.f_nom),
        view1(env_floats, env_layout, ENV_AT.n_max),
        view1(env_floats, env_layout, ENV_AT.peak),
        view1(env_floats, env_layout, ENV_AT.windows),
        view1(env_floats, env_layout, ENV_AT.prior),
    )


@numba.njit(cache=True, inline="always")
def put(obs, b, col, value):
    """Write ``value``, clipped to +-OBS_LIMIT, in member ``b``'s column ``col``; next column."""
    obs[b, col] = min(max(value, -OBS_LIMIT), OBS_LIMIT)
    return col + 1
