"""The Markdown table of ``bench_locate.py``'s JSON, printed or written into the README.

One row per condition (and an overall row): for each method (paper, default, peer) the success
rate, the standard deviation of the x, y, z and theta errors over the successful trials, and the
median time per stereo pair; then the time ratio peer / default. Times come from the 2-thread
timing pass where it ran, else from the one-thread pool (marked ``*``).

Run: ``.venv/bin/python benchmarks/locate_table.py [benchmarks/results/locate.json]
[--readme README.md]``; with ``--readme`` the block between ``<!-- locate-benchmark:start -->``
and ``<!-- locate-benchmark:end -->`` is replaced and nothing else in the file changes.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

START = "<!-- locate-benchmark:start -->"
END = "<!-- locate-benchmark:end -->"
METHODS = ("paper", "default", "peer")
DASH = "–"


def _pct(x: float | None) -> str:
    return DASH if x is None else f"{100 * x:.1f}"


def _std(stats: dict[str, Any]) -> str:
    std = stats.get("std_success") or {}
    vals = [std.get(k) for k in ("x_mm", "y_mm", "z_mm")]
    theta = std.get("theta_deg")
    if all(v is None for v in [*vals, theta]):
        return DASH
    parts = [DASH if v is None else f"{v:.2f}" for v in vals]
    parts.append(DASH if theta is None else f"{theta:.3f}")
    return " / ".join(parts)


def _seconds(stats: dict[str, Any]) -> tuple[float | None, bool]:
    """(median seconds, from the pool?)"""
    t2 = stats.get("seconds_2threads")
    if t2:
        return t2["median"], False
    pool = stats.get("seconds_pool")
    if pool:
        return pool["median"], True
    return stats.get("seconds_median"), True


def _ms(stats: dict[str, Any]) -> str:
    t, pool = _seconds(stats)
    if t is None:
        return DASH
    return f"{1e3 * t:.0f}{'*' if pool else ''}"


def _ratio(ratios: dict[str, Any]) -> str:
    r = ratios.get("time_peer_over_default")
    star = ""
    if r is None:
        r, star = ratios.get("time_peer_over_default_pool"), "*"
    return DASH if r is None else f"{r:.3g}{star}"


def render_table(result: dict[str, Any]) -> str:
    """The Markdown table (with a one-line legend under it) of a ``bench_locate`` JSON."""
    conditions: dict[str, dict[str, Any]] = result["conditions"]
    methods = [m for m in METHODS
               if any(m in s for s in conditions.values()) or m in result.get("overall", {})]
    header = ["condition"]
    for m in methods:
        header += [f"{m} success %", f"{m} std x / y / z mm / θ deg", f"{m} median ms"]
    header.append("time peer / default")
    lines = ["| " + " | ".join(header) + " |",
             "|" + "|".join([":---"] + ["---:"] * (len(header) - 1)) + "|"]
    for cond, stats in conditions.items():
        cells = [cond]
        for m in methods:
            s = stats.get(m)
            cells += [DASH, DASH, DASH] if s is None else [
                _pct(s.get("success_rate")), _std(s), _ms(s)]
        cells.append(_ratio(stats.get("ratios", {})))
        lines.append("| " + " | ".join(cells) + " |")
    overall = result.get("overall", {})
    if overall:
        cells = ["**all**"]
        for m in methods:
            s = overall.get(m)
            cells += [DASH, DASH, DASH] if s is None else [
                _pct(s.get("success_rate")), DASH, _ms(s)]
        cells.append(_ratio(overall.get("ratios", {})))
        lines.append("| " + " | ".join(cells) + " |")
    settings = result.get("settings", {})
    meta = result.get("meta", {})
    legend = (f"\nSuccess: found, 3-D position error < "
              f"{settings.get('success', {}).get('position_error_3d_mm_below', 10):g} mm and "
              f"3-D rotation error < "
              f"{settings.get('success', {}).get('rotation_error_3d_deg_below', 5):g} deg. "
              "Std over the successful trials of all garments. Times per stereo pair, median "
              "of the 2-thread timing pass (`*`: one-thread pool workers). "
              f"Trials per garment and condition: {settings.get('trials', '?')} "
              f"(paper method: {settings.get('paper_trials', '?')}), "
              f"{len(settings.get('garments', []))} garments, seed {meta.get('seed', '?')}, "
              f"commit `{str(meta.get('commit', '?'))[:10]}`. "
              "Source: `benchmarks/bench_locate.py`.")
    first = settings.get("default_model_preparation", {}).get("first_pair_seconds_median")
    if first is not None:
        legend += (" Each model met its rig once before the timing pass, as the peer's model "
                   "features are computed outside it: that first stereo pair builds the "
                   "model's per-level samples and scan kernels and took "
                   f"{1000 * first:.0f} ms (median).")
    return "\n".join(lines) + "\n" + legend + "\n"


def replace_block(text: str, block: str) -> str:
    """``text`` with the part between the markers replaced by ``block``.

    Raises
    ------
    ValueError
        A marker is missing, or the end marker comes before the start marker.
    """
    i, j = text.find(START), text.find(END)
    if i < 0 or j < 0:
        missing = " and ".join(m for m, k in ((START, i), (END, j)) if k < 0)
        raise ValueError(f"marker {missing} not found; add the two lines {START} and {END} "
                         "where the table should go")
    if j < i:
        raise ValueError(f"{END} comes before {START}")
    return text[: i + len(START)] + "\n" + block.strip("\n") + "\n" + text[j:]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("json", nargs="?", type=Path,
                        default=Path("benchmarks/results/locate.json"))
    parser.add_argument("--readme", type=Path,
                        help="replace the locate-benchmark block of this Markdown file")
    args = parser.parse_args(argv)
    try:
        result = json.loads(args.json.read_text())
        table = render_table(result)
    except (OSError, ValueError, KeyError, TypeError) as exc:
        print(f"{args.json}: cannot read a bench_locate result: {exc}", file=sys.stderr)
        return 2
    if args.readme is None:
        print(table, end="")
        return 0
    try:
        text = args.readme.read_text()
        new = replace_block(text, table)
    except OSError as exc:
        print(f"{args.readme}: cannot read: {exc}", file=sys.stderr)
        return 2
    except ValueError as exc:
        print(f"{args.readme}: {exc}", file=sys.stderr)
        return 2
    tmp = args.readme.with_name(args.readme.name + ".tmp")
    tmp.write_text(new)
    os.replace(tmp, args.readme)
    print(f"{args.readme}: locate-benchmark table updated", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
