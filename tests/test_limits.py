"""Sizes a user asks for are checked before they are started (issue 63, item 2)."""

from __future__ import annotations

from pathlib import Path

import pytest
from matplotlib.figure import Figure

from agents._files import save_figure
from agents.parallel import WORKERS_PER_CPU, available_cpus, resolve_workers
from contour_gym.limits import available_bytes, check_size, gigabytes


def test_sizes_in_words() -> None:
    assert gigabytes(3.4e9) == "3.4 GB" and gigabytes(1.2e8) == "120 MB"


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
