"""Sizes a user asks for are checked before they are started (issue 63, item 2)."""

from __future__ import annotations

import re
import resource
from pathlib import Path

import gymnasium as gym
import pytest
from matplotlib.figure import Figure

import agents.evaluate as ev
import contour_gym  # noqa: F401  (registers the ids)
from agents._files import save_figure
from agents.cli import main
from agents.parallel import WORKERS_PER_CPU, available_cpus, resolve_workers
from contour_gym.limits import available_bytes, check_size, gigabytes


def test_sizes_in_words() -> None:
    assert gigabytes(3.4e9) == "3.4 GB" and gigabytes(1.2e8) == "120 MB"
    assert gigabytes(1.98e12) == "1.98 TB" and gigabytes(7760) == "7.76 kB"


def test_workers_are_at_most_two_per_cpu() -> None:
    cpus = available_cpus()
    assert resolve_workers(WORKERS_PER_CPU * cpus) == WORKERS_PER_CPU * cpus
    with pytest.raises(ValueError, match=rf"workers 1000 is more than {WORKERS_PER_CPU} per CPU "
                                         rf".*at most {WORKERS_PER_CPU * cpus}\): lower --workers"):
        resolve_workers(1000)


def test_a_plot_too_large_is_refused_before_it_is_drawn(tmp_path: Path) -> None:
    fig = Figure(figsize=(6.0, 4.0))
    with pytest.raises(ValueError, match="120000 x 80000 pixel plot .* on a side: lower --dpi"):
        save_figure(fig, tmp_path / "big.png", dpi=20000)
    with pytest.raises(ValueError, match=r"30000 x 20000 pixel plot \(dpi 5000\) would need "
                                         r"2.4 GB, more than the limit of 1 GB: lower --dpi"):
        save_figure(fig, tmp_path / "big.png", dpi=5000)
    assert not list(tmp_path.iterdir())
    save_figure(fig, tmp_path / "ok.png", dpi=50)
    assert (tmp_path / "ok.png").stat().st_size > 0


def test_the_check_names_what_it_needs_and_the_machine_has() -> None:
    need = 2.0 * available_bytes()
    with pytest.raises(ValueError, match=r"a thing would need [\d.]+ [GM]B, more than "
                                         r"[\d.]+ [GM]B of this machine's available memory: "
                                         r"lower it"):
        check_size(need, "a thing", "it")
    check_size(1e6, "a small thing", "it")


def test_a_loop_too_large_for_the_memory_is_refused_before_it_is_made() -> None:
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with pytest.raises(ValueError, match=r"a loop of 10000000 members \(.* each\) would need "
                                         r".* GB, more than .*: lower the number of members"):
        gym.make_vec("contour_gym/CCC-v1", num_envs=10**7)
    grown_mb = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1e3
    assert grown_mb < 500  # refused before its arrays were made (they would be ~60 GB)


def test_recording_members_are_checked_for_the_record_of_an_episode() -> None:
    with pytest.raises(ValueError, match=r"20000 members recording episodes of up to \d+ steps: "
                                         r"recording it needs .* GiB, more than 2 GiB; render "
                                         r"fewer members \(num_envs\)"):
        gym.make_vec("contour_gym/CCC-v1", num_envs=20000, render_mode="rgb_array")


def test_evaluate_refuses_results_past_the_memory_and_runs_in_rounds(monkeypatch) -> None:
    with pytest.raises(ValueError, match=r"the results of 1000000000 episodes would need 256 GB"
                                         r".*: lower n_episodes"):
        ev.evaluate("pid_ccc", "contour_gym/CCC-v1", n_episodes=10**9)
    env = {"id": "contour_gym/CCC-v1", "path": "random", "decision_ticks": 50}
    whole = ev.evaluate("pid_ccc", env, n_episodes=3, seed=5)
    monkeypatch.setattr(ev, "EVAL_ROUND", 2)  # rounds of 2 members, then 1
    rounds = ev.evaluate("pid_ccc", env, n_episodes=3, seed=5)
    assert rounds["episodes"] == whole["episodes"] and len(rounds["episodes"]) == 3
    assert rounds["max_contour_error"] == whole["max_contour_error"]
    assert rounds["episodes"][-1] == rounds["episodes"][2] and rounds["episodes"][:1] == [
        whole["episodes"][0]]


def test_simulate_refuses_a_plot_too_large_before_it_runs(capsys) -> None:
    assert main(["simulate", "--dpi", "20000", "--out", "never.png"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["contour-gym: error: a 220000 x 92000 pixel plot (dpi 20000) is more than "
                   "65536 pixels on a side: lower --dpi"]


@pytest.mark.parametrize(("algo", "key", "said"), [
    ("sac", "buffer_size=1000000000", r"a replay buffer of 1000000000 transitions would need "
                                      r".* GB, .*: lower buffer_size"),
    ("ppo", "n_steps=100000000", r"a rollout of 1600000000 transitions would need .* GB, .*: "
                                 r"lower n_steps or n_envs"),
])
def test_a_buffer_too_large_is_refused_before_the_model_and_its_folder(
    tmp_path: Path, capsys, algo: str, key: str, said: str
) -> None:
    args = ["train", "contour_gym/CCC-v1", "--algo", algo, "--sweep", key, "--timesteps",
            str(10**10), "--out", str(tmp_path / "runs"), "--quiet"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert re.search(said, err[-1]) and not (tmp_path / "runs").exists()


def test_a_tuning_population_past_the_memory_is_refused_before_its_folder(
    tmp_path: Path, capsys
) -> None:
    args = ["tune", "000", "--population", str(10**8), "--out", str(tmp_path / "run"), "--quiet"]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert re.fullmatch(r"contour-gym: error: a population of 100000000 candidates \(3 "
                        r"scenario\(s\) each\) would need .* TB, more than .*: lower "
                        r"--population", err[-1])
    assert not (tmp_path / "run").exists()
