"""RL algorithms by name: stable-baselines3's, sb3-contrib's when installed, and your own.

An :class:`Algorithm` names the class that trains and loads an agent (imported on first use,
so a missing optional package costs nothing until its algorithm is asked for) and whether it
learns off-policy (a replay buffer; rl-zoo's ``noise_type`` applies). ``contour-gym train
--algo NAME`` and saved agents' ``meta.yaml`` use these names, rl-baselines3-zoo's where it
has one (``ppo_lstm`` is sb3-contrib's RecurrentPPO).

Register another with :func:`register_algorithm`, e.g. a subclass of an SB3 algorithm in your
own package::

    register_algorithm(Algorithm("my_ppo", "my_package.rl", "MyPPO", off_policy=False))

Each algorithm's hyperparameters come from ``configs/rl/<name>.yml`` (or ``--config FILE``).
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

from contour_gym.registry import Registry


@dataclass(frozen=True)
class Algorithm:
    """One RL algorithm.

    Attributes:
        name: Registry name (rl-zoo's spelling where it has one).
        module: The module holding the class (``stable_baselines3``, ``sb3_contrib``, yours).
        class_name: The class in ``module`` (an SB3 ``BaseAlgorithm``).
        off_policy: Learns from a replay buffer (rl-zoo's action ``noise_type`` applies).
        recurrent: Its policy keeps a state between steps (``predict(obs, state,
            episode_start)``), as sb3-contrib's RecurrentPPO does.
        install: How to install ``module`` (for the error when it is missing).
    """

    name: str
    module: str
    class_name: str
    off_policy: bool
    recurrent: bool = False
    install: str = 'pip install ".[rl]"'

    def load_class(self) -> Any:
        """The algorithm's class.

        Raises:
            ValueError: when its module is not installed, saying how to install it.
        """
        try:
            module = importlib.import_module(self.module)
        except ImportError as exc:
            raise ValueError(f"RL algorithm {self.name!r} needs {self.module} ({exc}); "
                             f"install it with: {self.install}") from exc
        return getattr(module, self.class_name)


ALGORITHMS: Registry[Algorithm] = Registry("RL algorithm")


def register_algorithm(algorithm: Algorithm, *, replace: bool = False) -> Algorithm:
    """Register an RL algorithm; returns it."""
    return ALGORITHMS.register(algorithm, replace=replace)


def algorithm(name: str) -> Algorithm:
    """The registered algorithm ``name``.

    Raises:
        ValueError: for an unknown name, listing the accepted ones.
    """
    return ALGORITHMS.get(name)


_SB3, _CONTRIB = "stable_baselines3", "sb3_contrib"
_CONTRIB_INSTALL = "pip install sb3-contrib"
for _algo in (
    Algorithm("ppo", _SB3, "PPO", off_policy=False),
    Algorithm("a2c", _SB3, "A2C", off_policy=False),
    Algorithm("sac", _SB3, "SAC", off_policy=True),
    Algorithm("td3", _SB3, "TD3", off_policy=True),
    Algorithm("ddpg", _SB3, "DDPG", off_policy=True),
    Algorithm("tqc", _CONTRIB, "TQC", off_policy=True, install=_CONTRIB_INSTALL),
    Algorithm("trpo", _CONTRIB, "TRPO", off_policy=False, install=_CONTRIB_INSTALL),
    Algorithm("crossq", _CONTRIB, "CrossQ", off_policy=True, install=_CONTRIB_INSTALL),
    Algorithm("ppo_lstm", _CONTRIB, "RecurrentPPO", off_policy=False, recurrent=True,
              install=_CONTRIB_INSTALL),
):
    register_algorithm(_algo)
