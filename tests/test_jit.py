"""The kernels' cache: which directory ``photomodel._jit`` chooses, and that a kernel still
runs, after one warning, where no directory can be written."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from photomodel._jit import CACHE, CacheChoice, choose_cache, user_cache_dir


def _fake_writable(ok: set[Path]):
    tried: list[Path] = []

    def writable(path: Path) -> bool:
        tried.append(path)
        return path in ok

    return writable, tried


def test_choose_cache_prefers_numba_cache_dir() -> None:
    writable, tried = _fake_writable({Path("/nbc"), Path("/pkg/__pycache__"), Path("/user")})
    choice = choose_cache("/nbc", Path("/pkg"), Path("/user"), writable)
    assert choice.kind == "NUMBA_CACHE_DIR" and choice.root == Path("/nbc").resolve()
    assert tried == [Path("/nbc")]


def test_choose_cache_in_tree_when_numba_cache_dir_unset_or_unwritable() -> None:
    writable, tried = _fake_writable({Path("/pkg/__pycache__"), Path("/user")})
    assert choose_cache("", Path("/pkg"), Path("/user"), writable) == CacheChoice(
        "in-tree", None, (Path("/pkg/__pycache__"),))
    choice = choose_cache("/nbc", Path("/pkg"), Path("/user"), writable)
    assert choice.kind == "in-tree"
    assert choice.tried == (Path("/nbc"), Path("/pkg/__pycache__"))


def test_choose_cache_user_dir_when_the_tree_is_read_only() -> None:
    writable, _ = _fake_writable({Path("/user")})
    choice = choose_cache("", Path("/pkg"), Path("/user"), writable)
    assert choice.kind == "user" and choice.root == Path("/user").resolve()
    assert choice.enabled


def test_choose_cache_none_when_nothing_is_writable() -> None:
    writable, _ = _fake_writable(set())
    choice = choose_cache("/nbc", Path("/pkg"), Path("/user"), writable)
    assert choice == CacheChoice("none", None,
                                 (Path("/nbc"), Path("/pkg/__pycache__"), Path("/user")))
    assert not choice.enabled
    assert "/nbc" in choice.describe() and "/user" in choice.describe()
    assert choose_cache("", Path("/pkg"), None, writable).tried == (Path("/pkg/__pycache__"),)


def test_user_cache_dir() -> None:
    assert user_cache_dir({"XDG_CACHE_HOME": "/x", "HOME": "/h"}) == Path("/x/photomodel/numba")
    assert user_cache_dir({"XDG_CACHE_HOME": "rel", "HOME": "/h"}) == Path(
        "/h/.cache/photomodel/numba")
    assert user_cache_dir({"HOME": "/h"}) == Path("/h/.cache/photomodel/numba")


def test_choose_cache_real_directories(tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    choice = choose_cache(str(blocker / "cache"), pkg, tmp_path / "user")
    assert choice.kind == "in-tree" and (pkg / "__pycache__").is_dir()


def test_this_process_caches() -> None:
    assert CACHE.enabled, CACHE.describe()


_KERNEL = textwrap.dedent("""
    import warnings
    warnings.simplefilter("default")
    import numpy as np
    from photomodel._jit import CACHE, njit

    @njit(fastmath=True)
    def total(x):
        s = 0.0
        for v in x:
            s += v
        return s

    print(CACHE.kind, total(np.arange(4.0)))
""")


def _run(code: str, env: dict[str, str], cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-c", code], env=env, cwd=cwd, capture_output=True,
                          text=True, timeout=300, check=False)


def test_unwritable_everywhere_runs_uncached_with_one_warning(tmp_path: Path) -> None:
    """NUMBA_CACHE_DIR and the user cache under a regular file (unwritable even for root),
    the package tree made unwritable the same way: the kernel runs, one warning says so."""
    blocker = tmp_path / "file"
    blocker.write_text("")
    # A copy of _jit.py in a package whose __pycache__ is a regular file: an unwritable tree.
    pkg = tmp_path / "tree" / "photomodel_ro"
    pkg.mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "__pycache__").write_text("")
    source = (Path(__file__).parents[1] / "src" / "photomodel" / "_jit.py").read_text()
    (pkg / "_jit.py").write_text(source)
    env = dict(os.environ, NUMBA_CACHE_DIR=str(blocker / "numba"), HOME=str(blocker / "home"),
               XDG_CACHE_HOME=str(blocker / "xdg"), PYTHONDONTWRITEBYTECODE="1")
    env["PYTHONPATH"] = os.pathsep.join([str(pkg.parent), env.get("PYTHONPATH", "")])
    code = _KERNEL.replace("photomodel._jit", "photomodel_ro._jit")
    result = _run(code, env, tmp_path)
    assert result.returncode == 0, result.stderr
    assert result.stdout.split() == ["none", "6.0"]
    assert result.stderr.count("JitCacheWarning") == 1, result.stderr
    assert "no writable cache directory" in result.stderr
    assert str(blocker / "numba") in result.stderr and str(blocker / "xdg") in result.stderr


def test_numba_cache_dir_is_used_and_then_loaded(tmp_path: Path) -> None:
    cache = tmp_path / "nbc"
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    # The kernel in a file (numba caches functions of source files only).
    module = tmp_path / "kernel_mod.py"
    module.write_text(_KERNEL)
    code = "import kernel_mod"
    env["PYTHONPATH"] = os.pathsep.join([str(tmp_path), env.get("PYTHONPATH", "")])
    first = _run(code, env, tmp_path)
    assert first.returncode == 0, first.stderr
    assert first.stdout.split() == ["NUMBA_CACHE_DIR", "6.0"]
    assert "JitCacheWarning" not in first.stderr
    assert list(cache.rglob("kernel_mod.total-*.nbi"))
    env["NUMBA_DEBUG_CACHE"] = "1"
    second = _run(code, env, tmp_path)
    assert "data loaded" in second.stdout and "data saved" not in second.stdout


@pytest.mark.parametrize("decorator", ["@njit", "@njit()", "@njit(cache=True, nogil=True)"])
def test_njit_forms(decorator: str) -> None:
    namespace: dict[str, object] = {}
    exec(textwrap.dedent(f"""
        from photomodel._jit import njit
        {decorator}
        def twice(x):
            return 2 * x
    """), namespace)
    assert namespace["twice"](3) == 6  # type: ignore[operator]
