"""The package's public names: every one resolves, and the functions that share a name with
their module (``accumulate``, ``align``, ``noise_check``) stay callable in any import order
(a defect the stability suite found: importing the submodule replaced the function; ``simulate`` is a
subpackage whose function the README calls after ``sr.load_scene``); compiling a
kernel writes nothing inside the package (the Numba cache is per user, :mod:`spikeref._jit`)."""

import subprocess
import sys

import pytest

import spikeref as sr

CHILD = """
import numpy as np
import spikeref.accumulate, spikeref.align, spikeref.noise_check   # submodules first
import spikeref as sr
from spikeref.stream import SpikeStream
spikes = np.ones((20, 4, 4), np.uint8)
assert sr.accumulate(spikes, 10).shape == (2, 4, 4)
tex = np.random.default_rng(0).random((64, 64)).astype(np.float32)
assert sr.align(tex, tex).shape == (2, 64, 64)
r = sr.noise_check(SpikeStream.from_array(np.ones((400, 4, 4), np.uint8)), windows=(10, 20))
import spikeref.accumulate as m
assert callable(m.window_counts) and m.accumulate is not None
from spikeref.sample import SAMPLE_SCENE
scene = sr.load_scene(SAMPLE_SCENE)  # imports the subpackage spikeref.simulate, which Python binds to sr.simulate
assert sr.simulate(scene, seed=0, planes=20).spikes.shape == (20, 224, 256)
print("ok")
"""


def test_every_public_name_resolves():
    for name in sr.__all__:
        assert getattr(sr, name) is not None, name


def test_the_child_covers_every_public_function_named_like_a_submodule():
    """A public function that shares its name with a submodule is shadowed when that submodule is imported:
    each such name is exercised by CHILD (README's `sr.load_scene(...)` then `sr.simulate(...)` found one)."""
    import pkgutil

    submodules = {m.name for m in pkgutil.iter_modules(sr.__path__)}
    shared = sorted(name for name in sr.__all__ if name in submodules)
    assert shared == ["accumulate", "align", "noise_check", "simulate"]
    assert all(f"sr.{name}(" in CHILD for name in shared)


def test_functions_named_like_their_module_are_callable_whatever_was_imported_first():
    out = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "ok", out.stderr


# ------------------------------------------------------------------ the Numba cache lives outside the package
CACHE_CHILD = """
if {numba_first}:
    import numba  # a program that imported Numba before spikeref
import numpy as np
import spikeref as sr
from spikeref import _jit
assert sr.accumulate(np.ones((20, 4, 6), np.uint8), 10).shape == (2, 4, 6)
print(sr.__file__)
print(_jit.caching_enabled, getattr(_jit, "cache_dir", None))
"""


def _files(folder):
    return {p.relative_to(folder) for p in folder.rglob("*") if p.is_file()} if folder.exists() else set()


@pytest.mark.parametrize("case", ["default", "numba imported first", "NUMBA_CACHE_DIR", "no cache folder"])
def test_numba_cache_is_written_outside_the_package(tmp_path, case):
    """An installed copy of the package gains no file when its kernels compile (the cache is per user)."""
    import os
    import shutil
    from pathlib import Path

    site = tmp_path / "site"
    shutil.copytree(Path(sr.__file__).parent, site / "spikeref", ignore=shutil.ignore_patterns("__pycache__"))
    xdg, home, mine = tmp_path / "xdg", tmp_path / "home", tmp_path / "mine"
    home.mkdir()
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_DIR", "SPIKEREF_NUMBA_CACHE", "NUMBA_DISABLE_JIT", "PYTHONPATH")}
    env.update(HOME=str(home), XDG_CACHE_HOME=str(xdg), PYTHONPATH=str(site), PYTHONDONTWRITEBYTECODE="1")
    if case == "NUMBA_CACHE_DIR":
        env["NUMBA_CACHE_DIR"] = str(mine)
    if case == "no cache folder":
        (tmp_path / "a_file").write_text("")
        env["XDG_CACHE_HOME"] = str(tmp_path / "a_file" / "cache")  # cannot be created
    before = _files(site)
    out = subprocess.run([sys.executable, "-c", CACHE_CHILD.format(numba_first=case == "numba imported first")],
                         capture_output=True, text=True, env=env, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    location, caching = out.stdout.split("\n")[:2]
    assert Path(location).resolve().is_relative_to((site / "spikeref").resolve()), location
    assert _files(site) == before, sorted(map(str, _files(site) - before))
    expected = {"NUMBA_CACHE_DIR": mine, "no cache folder": None}.get(case, xdg / "spikeref" / "numba")
    for folder in (xdg, mine, home):
        cached = {p for p in _files(folder) if p.suffix in (".nbi", ".nbc")}
        if expected is not None and (folder == expected or folder in expected.parents):
            assert cached, f"no Numba cache files in {expected}: {caching}"
            assert caching == f"True {expected}"
        else:
            assert not cached, f"{case}: Numba cache files in {folder}"
    if expected is None:
        assert caching == "False None"


def test_the_test_extra_brings_the_light_extras():
    """``pip install -e ".[test]"`` installs what the plot and Dask tests need (torch stays CI's own install)."""
    import re
    from pathlib import Path

    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib

    pyproject = Path(__file__).resolve().parents[1] / "pyproject.toml"
    extras = tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]["optional-dependencies"]
    for extra in ("plot", "dask"):
        for requirement in extras[extra]:
            assert requirement in extras["test"], f"the test extra lacks {requirement!r} of the {extra} extra"
    names = {re.match(r"[A-Za-z0-9_.-]+", r).group().lower() for r in extras["test"]}
    assert "torch" not in names


#: Where the docs and comments must speak of the product, not of the sittings that built it
#: (issue 24, item 6): the same paths and pattern as
#: ``grep -rniE "session [0-9]|this session|lent to|the lease" docs spikeref scripts examples README.md``.
HISTORY_PATHS = ("docs", "spikeref", "scripts", "examples", "README.md")
HISTORY_WORDS = r"session [0-9]|this session|\blent to\b|the lease"  # \b: not "equivalent to"


def _text_files(root, names):
    from pathlib import Path

    for name in names:
        path = Path(root) / name
        for f in sorted([path] if path.is_file() else path.rglob("*")):
            if not f.is_file() or "__pycache__" in f.parts:
                continue
            data = f.read_bytes()
            if b"\0" in data:  # binary, as grep -I skips it
                continue
            try:
                yield f, data.decode("utf-8")
            except UnicodeDecodeError:
                continue


def test_docs_and_comments_keep_no_diary():
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    pattern = re.compile(HISTORY_WORDS, re.IGNORECASE)
    hits = [
        f"{f.relative_to(root)}:{n}: {line.strip()[:100]}"
        for f, text in _text_files(root, HISTORY_PATHS)
        for n, line in enumerate(text.splitlines(), 1)
        if pattern.search(line)
    ]
    assert hits == [], "docs speak of their history (give the date, machine and command instead):\n" + "\n".join(hits)


@pytest.mark.slow
def test_readme_commands_in_a_fresh_virtualenv_leave_a_working_cli(tmp_path):
    """The README's two commands, in order, in a new virtualenv, then the CLI from another folder.

    The virtualenv sees this interpreter's packages (``--system-site-packages``), so nothing is
    downloaded: command 1 installs the package itself (``pip install .``, no build isolation, no
    dependencies), runs the main job on the embedded sample, and command 2 reinstalls it editable.
    Afterwards ``spikeref --version``, ``info`` and ``reconstruct`` must run from an unrelated folder
    (the issue: Numba's cache written into the installed package once shadowed the checkout).
    """
    import os
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    venv = tmp_path / "venv"
    # without its own pip: the venv uses this interpreter's pip and setuptools (an old bundled setuptools
    # cannot build a wheel without the wheel package)
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", "--without-pip", str(venv)], check=True)
    bin_dir = venv / ("Scripts" if os.name == "nt" else "bin")
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "cache"), PYTHONPATH="")
    pip = [str(bin_dir / "python"), "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation"]

    def run(args, cwd):
        out = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, (args, out.stdout[-2000:], out.stderr[-2000:])
        return out

    work = tmp_path / "work"
    work.mkdir()
    run(pip + [str(root)], cwd=work)  # command 1: pip install . …
    run([str(bin_dir / "spikeref"), "reconstruct", "--frames", "3:4", "-o", "first.mp4", "--exr-dir", "exr"], work)
    assert (work / "first.mp4").stat().st_size > 0
    run(pip + ["-e", str(root)], cwd=work)  # command 2: pip install -e ".[test]" (the extras are already here)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    version = run([str(bin_dir / "spikeref"), "--version"], elsewhere)
    assert sr.__version__ in version.stdout + version.stderr
    run([str(bin_dir / "spikeref"), "info"], elsewhere)
    run([str(bin_dir / "spikeref"), "reconstruct", "--frames", "3:4", "-o", "again.mp4", "--exr-dir", "exr"], elsewhere)
    assert (elsewhere / "again.mp4").stat().st_size > 0
