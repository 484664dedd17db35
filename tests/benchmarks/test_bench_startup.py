"""The start-up benchmark (``benchmarks/bench_startup.py``): its statistics, ratios and 5 %
verdicts, and a short run that compares this working tree with itself (no git worktree, no
kernel compilation)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from benchmark_helpers import load_benchmark

load_benchmark("_meta")
bench_startup = load_benchmark("bench_startup")


def test_summarise_gives_tails_only_with_enough_samples() -> None:
    few = bench_startup.summarise([3.0, 1.0, 2.0])
    assert few["n"] == 3 and few["median"] == 2.0 and few["min"] == 1.0 and few["max"] == 3.0
    assert few["p90"] is None and few["p99"] is None
    ten = bench_startup.summarise(np.arange(1.0, 11.0))
    assert ten["p90"] == pytest.approx(np.percentile(np.arange(1.0, 11.0), 90))
    assert ten["p99"] is None
    many = bench_startup.summarise(np.arange(100.0))
    assert many["p99"] == pytest.approx(98.01)
    empty = bench_startup.summarise([])
    assert empty["n"] == 0 and empty["median"] is None


def test_ratio_and_the_five_percent_verdict() -> None:
    assert bench_startup.ratio(1.05, 1.0) == pytest.approx(1.05)
    assert bench_startup.ratio(1.0, None) is None
    assert bench_startup.ratio(1.0, 0.0) is None
    assert bench_startup.verdict(1.05) == "pass"    # at the limit: within 5 %
    assert bench_startup.verdict(1.0501) == "fail"
    assert bench_startup.verdict(0.5) == "pass"
    assert bench_startup.verdict(None) == "n/a"
    assert bench_startup.verdict(1.08, tolerance=0.10) == "pass"


def test_paired_ratios_and_the_bootstrap_interval() -> None:
    assert bench_startup.paired_ratios([1.0, 2.0], [1.5, 2.0]) == [1.5, 1.0]
    with pytest.raises(ValueError, match="paired"):
        bench_startup.paired_ratios([1.0], [1.0, 2.0])
    rng = np.random.default_rng(0)
    base = rng.normal(1.0, 0.02, size=50)
    cur = 1.2 * rng.normal(1.0, 0.02, size=50)
    lo, hi = bench_startup.bootstrap_ratio_interval(base, cur, seed=3)
    assert lo < 1.2 < hi and hi - lo < 0.1
    assert bench_startup.bootstrap_ratio_interval(base, cur, seed=3) == (lo, hi)  # seeded
    assert bench_startup.bootstrap_ratio_interval([1.0], cur, seed=3) is None
    with pytest.raises(ValueError, match="statistic"):
        bench_startup.bootstrap_ratio_interval(base, cur, seed=3, statistic="mean")


def test_compare_judges_the_ratio_of_medians_and_the_tail() -> None:
    base = [1.0, 1.0, 1.0, 1.0, 1.0]
    got = bench_startup.compare(base, [1.1, 1.1, 1.1, 1.1, 1.1], seed=0, paired=True)
    assert got["ratio_of_medians"] == pytest.approx(1.1)
    assert got["paired_ratio_median"] == pytest.approx(1.1)
    assert got["verdict"] == "fail"
    assert "ratio_of_p99" not in got
    fast = bench_startup.compare(base, [0.9] * 5, seed=0)
    assert fast["verdict"] == "pass" and fast["paired_ratio_median"] is None
    tail = bench_startup.compare(list(np.ones(100)), [1.0] * 98 + [5.0, 5.0], seed=0, tail="p99")
    assert tail["verdict"] == "pass"                    # the medians agree ...
    assert tail["ratio_of_p99"] > 1.05 and tail["verdict_p99"] == "fail"   # ... the tail not
    short = bench_startup.compare(base, base, seed=0, tail="p99")
    assert short["ratio_of_p99"] is None and short["verdict_p99"] == "n/a"


def test_rounds_alternate_which_tree_goes_first() -> None:
    assert bench_startup.round_order(0) == ("baseline", "current")
    assert bench_startup.round_order(1) == ("current", "baseline")
    assert bench_startup.round_order(2) == ("baseline", "current")


def test_model_file_differences_name_the_members(tmp_path: Path) -> None:
    a, b, c = tmp_path / "a.npz", tmp_path / "b.npz", tmp_path / "c.npz"
    np.savez(a, x=np.arange(3), meta=np.array("v1"))
    np.savez(b, x=np.arange(3), meta=np.array("v2"))
    np.savez(c, x=np.arange(3), meta=np.array("v1"), y=np.zeros(2))
    assert bench_startup.model_file_differences(a, a) == []
    assert bench_startup.model_file_differences(a, b) == ["meta"]
    assert bench_startup.model_file_differences(a, c) == ["y"]
    assert bench_startup.model_file_differences(a, tmp_path / "missing.npz") is None


def test_table_has_a_row_per_figure() -> None:
    fig = bench_startup.compare([0.2, 0.21, 0.2], [0.2, 0.2, 0.19], seed=0, paired=True)
    fig["what"] = "photomodel --help"
    result = {"figures": {"help": fig},
              "baseline": {"rev": "abc", "sha": "0123456789abcdef"},
              "current": {"head": "fedcba9876543210", "dirty_files": []},
              "load": {"before": [0.1, 0.2, 0.3], "after": [0.2, 0.2, 0.3]}}
    lines = bench_startup.render_table(result).splitlines()
    assert lines[0].startswith("figure") and set(lines[1]) <= {"-", " "}
    assert lines[2].startswith("photomodel --help") and lines[2].split()[-1] == "pass"
    assert "0123456789ab" in lines[-1] and "fedcba987654" in lines[-1]


def test_a_short_run_against_the_working_tree_itself(tmp_path: Path) -> None:
    out = tmp_path / "startup.json"
    result = bench_startup.main(["--quick", "--baseline", "WORKTREE", "--kinds", "help",
                                 "--no-warmup", "--out", str(out)])
    assert json.loads(out.read_text())["figures"]["help"]["verdict"] in ("pass", "fail")
    help_fig = result["figures"]["help"]
    assert help_fig["baseline"]["n"] == help_fig["current"]["n"] == 2
    assert 0.0 < help_fig["baseline"]["median"] < 30.0
    assert help_fig["ratio_of_medians"] > 0
    assert result["baseline"]["sha"] is None and result["baseline"]["worktree"] is None
    src = str(Path(bench_startup.__file__).resolve().parents[1] / "src")
    assert result["baseline"]["photomodel_file"].startswith(src)
    assert result["current"]["photomodel_file"].startswith(src)
    assert result["meta"]["benchmark"] == "startup" and "commit" in result["meta"]
    assert len(result["load"]["per_round"]) == 2


@pytest.mark.slow
def test_a_quick_run_of_every_figure(tmp_path: Path) -> None:
    result = bench_startup.main(["--quick", "--baseline", "WORKTREE", "--no-warmup",
                                 "--out", str(tmp_path / "startup.json")])
    figs = result["figures"]
    assert set(figs) == set(bench_startup.FIGURES)
    assert figs["pair"]["baseline"]["n"] == figs["pair"]["current"]["n"] == 2 * 2
    assert figs["error"]["current"]["median"] < figs["locate"]["current"]["median"]
    assert result["results"]["in_process_position_difference_max_mm"] == pytest.approx(0.0,
                                                                                        abs=1e-6)
    assert all(c["found"] for c in result["results"]["found"]["current"]["calls"])


def test_a_paired_bootstrap_keeps_a_mix_of_two_sizes_balanced() -> None:
    # two models alternating (small, large), the current 2 % slower on each: resampling the
    # pairs together keeps the ratio near 1.02, resampling each group alone mixes the sizes
    base = np.tile([0.2, 0.5], 7)
    cur = 1.02 * base
    lo, hi = bench_startup.bootstrap_ratio_interval(base, cur, seed=0, paired=True)
    assert lo == pytest.approx(1.02) and hi == pytest.approx(1.02)
    lo, hi = bench_startup.bootstrap_ratio_interval(base, cur, seed=0)
    assert lo < 0.9 and hi > 1.5
    with pytest.raises(ValueError, match="paired"):
        bench_startup.bootstrap_ratio_interval(base, cur[:-1], seed=0, paired=True)
