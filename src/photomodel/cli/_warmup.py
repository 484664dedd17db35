"""``photomodel warmup``: compile every numba kernel into the cache, with progress."""

from __future__ import annotations

import argparse


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "warmup", help="compile the numba kernels into the cache (once after an install)",
        description="Compile every numba kernel that locate and identify use into numba's "
                    "cache, in parallel processes, so that the first locate does not compile "
                    "them one after the other. Progress on stderr; a second run finds them "
                    "cached and finishes in seconds. The cache: NUMBA_CACHE_DIR when set, "
                    "else the __pycache__ folders beside the sources, else "
                    "$XDG_CACHE_HOME/photomodel/numba.")
    p.add_argument("--all", action="store_true",
                   help="also the simulator's kernels (simulate, demo, experiment)")
    p.add_argument("--workers", type=int, default=None,
                   help="processes side by side (default: the CPUs available)")
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    import sys

    from photomodel._jit import CACHE
    from photomodel._warmup import warmup
    from photomodel.errors import InputError

    if args.workers is not None and args.workers < 1:
        raise InputError("--workers", f"expected >= 1, got {args.workers}")
    if not CACHE.enabled:
        tried = ", ".join(str(path) for path in CACHE.tried)
        print(f"photomodel: error: no writable cache directory for the kernels (tried "
              f"{tried}); set NUMBA_CACHE_DIR", file=sys.stderr)
        return 2

    def say(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    warmup(say, workers=args.workers, simulator=args.all)
    return 0
