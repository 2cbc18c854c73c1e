"""Paper 003's tables 2 and 3 in kind: hand-tuned 2PID, hand-tuned ACC2PID, IABC-tuned ACC2PID.

Runs ``no_ccc`` (003's hand-tuned 2PID: the gantry envs' axes without compensators),
``acc2pid`` (the same plus 003's compensators) and ``iabc_acc2pid`` (protocol ``003``'s
parameters, ``agents/data/iabc_acc2pid.json``) with :func:`agents.evaluate.run_policy` (seed
0, one episode, the envs' full 10 s windows) on both gantry ids, rig and ideal, and prints
003's measures P_eps and P_e (eqs. 39-40, mm) as the env measures them (every servo tick) and
at 003's 10 Hz (``sample_period=0.1``, as :mod:`contour_gym.papers` does), then 003's claims:
IABC-tuned ACC2PID against hand-tuned 2PID, P_eps -65.5 % (circle) and -68.8 % (three-leaf).

    python benchmarks/tune_003.py
"""

from __future__ import annotations

from agents.claims import sampled_003
from agents.evaluate import run_policy
from agents.policies import make_policy

ENVS = {
    "circle": ("contour_gym/CCC-XYYGantry-Circle-v0", -0.655),
    "three-leaf": ("contour_gym/CCC-XYYGantry-ThreeLeaf-v0", -0.688),
}
POLICIES = ("no_ccc", "acc2pid", "iabc_acc2pid")
MM = 1e3


def main() -> None:
    print(f"{'path':<11}{'policy':<14}{'':6}{'P_eps tick':>11}{'P_e tick':>10}"
          f"{'P_eps 10Hz':>11}{'P_e 10Hz':>10}   (mm)")
    table: dict[tuple[str, str, bool], float] = {}
    for case, (env_id, _) in ENVS.items():
        for name in POLICIES:
            for ideal in (False, True):
                m = run_policy(env_id, make_policy(name), ideal=ideal)
                s = sampled_003(env_id, make_policy(name), ideal)
                table[case, name, ideal] = s["p_eps"]
                print(f"{case:<11}{name:<14}{'ideal' if ideal else 'rig':<6}"
                      f"{m['p_eps'] * MM:>11.4f}{m['p_e'] * MM:>10.4f}"
                      f"{s['p_eps'] * MM:>11.4f}{s['p_e'] * MM:>10.4f}")
    print("claims (P_eps at 10 Hz, iabc_acc2pid against no_ccc, i.e. hand-tuned 2PID):")
    for case, (_, claim) in ENVS.items():
        for ideal in (False, True):
            change = table[case, "iabc_acc2pid", ideal] / table[case, "no_ccc", ideal] - 1.0
            print(f"  {case:<11}{'ideal' if ideal else 'rig':<6}{change * 100:+7.1f} % "
                  f"(003: {claim * 100:+.1f} %)")


if __name__ == "__main__":
    main()
