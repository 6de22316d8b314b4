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


def _top_level_imports(path):
    """The top-level module names ``path`` imports (absolute imports only), with a line number each."""
    import ast

    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name.split(".")[0], node.lineno
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            yield node.module.split(".")[0], node.lineno


def test_every_package_imported_is_declared_in_pyproject():
    """Each module that the package, the tests, benchmarks, examples and scripts import is the standard library's,
    ours, or a distribution pyproject.toml declares (a runtime dependency or an extra): a fresh virtualenv
    installs only what is declared, so an undeclared import works here and fails for a new user."""
    from tests.conftest import ROOT, _requirement_module

    try:
        import tomllib
    except ImportError:  # Python 3.10
        import tomli as tomllib

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    requirements = project["dependencies"] + [r for reqs in project["optional-dependencies"].values() for r in reqs]
    declared = {_requirement_module(r) for r in requirements}
    # what a declared distribution itself requires: dask[distributed] → distributed, numba → llvmlite, imageio → PIL
    declared |= {"distributed", "llvmlite", "PIL"}
    ours = {"spikeref", "tests", "benchmarks", "conftest", "scene_doubles"}
    undeclared = []
    for folder in ("spikeref", "tests", "benchmarks", "examples", "scripts"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            local = {p.stem for p in path.parent.glob("*.py")} | {p.name for p in path.parent.iterdir() if p.is_dir()}
            for module, line in _top_level_imports(path):
                if module in sys.stdlib_module_names or module in ours | declared | local:
                    continue
                undeclared.append(f"{path.relative_to(ROOT)}:{line}: {module}")
    assert undeclared == [], "imports of packages pyproject.toml does not declare:\n" + "\n".join(undeclared)
    assert {"skimage", "pywt", "numpy", "torch", "bm3d"} <= declared  # import names, not distribution names


def test_a_test_may_skip_only_for_the_extras_ci_adds(monkeypatch):
    """README command 2 installs the test extra: a skip for one of its packages is a missing install step and fails
    (tests/conftest.py); torch (train) and bm3d (peers), which CI adds in its second phase, may skip, named."""
    from types import SimpleNamespace

    import tests.conftest as conftest

    def report(module):
        return SimpleNamespace(skipped=True, outcome="skipped",
                               longrepr=("t.py", 3, f"Skipped: could not import '{module}': No module named 'x'"))

    assert conftest.optional_outside_test() == conftest.CI_ADDS == {"torch": "train", "bm3d": "peers"}
    monkeypatch.setattr(conftest, "OPTIONAL", dict(conftest.CI_ADDS))  # README command 2's run (CI's first phase)
    monkeypatch.setattr(conftest, "REQUIRE_EXTRAS", False)
    for module in ("skimage.restoration", "pywt", "hypothesis", "matplotlib", "dask.distributed", "numba"):
        r = report(module)
        conftest._strict_skip(r)
        assert r.outcome == "failed" and "pip install -e" in r.longrepr, module
    r = report("torch")
    conftest._strict_skip(r)
    assert r.outcome == "skipped" and "the 'train' extra" in r.longrepr[2]
    plain = SimpleNamespace(skipped=True, outcome="skipped", longrepr=("t.py", 3, "Skipped: ../shared is not present"))
    conftest._strict_skip(plain)
    assert plain.outcome == "skipped"
    monkeypatch.setattr(conftest, "OPTIONAL", {})  # SPIKEREF_REQUIRE_EXTRAS=1: CI's second phase
    monkeypatch.setattr(conftest, "REQUIRE_EXTRAS", True)
    r = report("bm3d")
    conftest._strict_skip(r)
    assert r.outcome == "failed" and "SPIKEREF_REQUIRE_EXTRAS" in r.longrepr


def test_what_the_commands_write_by_default_is_ignored_by_git(tmp_path):
    """README command 1 run in the checkout leaves nothing for ``git status`` to show: every default output of the
    commands (a video, its EXR folder, the bench's folder, the tour's scratch folder) is ignored."""
    import shutil

    from tests.conftest import ROOT

    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    outputs = ["reconstruction.mp4", "reconstruction_exr/frame_000003.exr", "reconstruction_exr/spikeref_run.json",
               "denoised.mp4", "denoised_exr/frame_000000.exr", "spikeref-bench/results.md", "out/tour.md"]
    for method in ("tfp", "tfi", "tfstp"):
        outputs += [f"{method}.mp4", f"{method}_exr/frame_000000.exr"]
    out = subprocess.run(["git", "check-ignore", "--no-index", *outputs], cwd=ROOT, capture_output=True, text=True)
    left = sorted(set(outputs) - set(out.stdout.split()))
    assert left == [], f"not ignored by .gitignore: {left}"


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


def readme_commands() -> list[str]:
    """The shell commands of the README's first code block (its two numbered commands), comments left out."""
    import re

    from tests.conftest import ROOT

    block = re.search(r"```bash\n(.*?)```", (ROOT / "README.md").read_text(encoding="utf-8"), re.S).group(1)
    return [line.strip() for line in block.splitlines() if line.strip() and not line.lstrip().startswith("#")]


def test_the_readme_s_two_commands_install_the_same_way():
    """Both install the checkout editable: a `pip install .` then `pip install -e` moved the kernels' source paths,
    which key Numba's cache, and the first run after command 2 compiled for 40 s again."""
    first, second = readme_commands()
    assert first.startswith("pip install -e . && spikeref reconstruct"), first
    assert second.startswith('pip install -e ".[test]" && python -m pytest'), second


def _cache_files(folder):
    return {str(p.relative_to(folder)): p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}


@pytest.mark.slow
def test_readme_commands_in_a_fresh_virtualenv_leave_a_working_cli(tmp_path):
    """The README's two commands, in order, in a new virtualenv, then the CLI from another folder.

    The virtualenv is made from this interpreter's base Python, and sees this environment's packages through a
    ``.pth`` file, so nothing but the build backend is fetched: command 1's install (``pip install -e .``, no
    dependencies) and run of the main job on the embedded sample, then command 2's install. Its first run says it
    compiles, and after command 2 the same job is warm: it adds nothing to the per-user kernel cache and says nothing
    of compiling. Afterwards ``spikeref --version``, ``info`` and ``reconstruct`` run from an unrelated folder (the
    issue: Numba's cache written into the installed package once shadowed the checkout).
    """
    import importlib.util
    import os
    import site
    from pathlib import Path

    from tests.conftest import ROOT

    first, second = readme_commands()
    venv = tmp_path / "venv"
    base = Path(sys.base_prefix) / ("python.exe" if os.name == "nt" else "bin/python3")
    subprocess.run([str(base if base.exists() else sys.executable), "-m", "venv", "--without-pip", str(venv)],
                   check=True)
    bin_dir = venv / ("Scripts" if os.name == "nt" else "bin")
    python = bin_dir / ("python.exe" if os.name == "nt" else "python")
    venv_site = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                                    check=True, capture_output=True, text=True).stdout.strip())
    (venv_site / "_parent_environment.pth").write_text("\n".join(site.getsitepackages()) + "\n")
    cache = tmp_path / "cache"
    env = dict(os.environ, XDG_CACHE_HOME=str(cache), PYTHONPATH="", PIP_DISABLE_PIP_VERSION_CHECK="1")
    env.pop("NUMBA_CACHE_DIR", None)
    # the build backend from this environment when it can build the editable wheel, else pip fetches it as usual
    setuptools_major = int(__import__("setuptools").__version__.split(".")[0])
    backend = importlib.util.find_spec("wheel") is not None and setuptools_major >= 68
    pip = [str(python), "-m", "pip", "install", "--quiet", "--no-deps"] + (["--no-build-isolation"] if backend else [])

    def run(args, cwd):
        out = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
        assert out.returncode == 0, (args, out.stdout[-2000:], out.stderr[-2000:])
        return out

    def install(command):  # "pip install -e ARG && …" → this venv's pip, ARG's extras dropped (they are here)
        target = command.split("&&")[0].split()[-1].strip("\"'")
        return run(pip + ["-e", str(ROOT / target.split("[")[0])], cwd=work)

    work = tmp_path / "work"
    work.mkdir()
    install(first)  # command 1: pip install -e . …
    job = [str(bin_dir / "spikeref"), "reconstruct", "--frames", "3:4", "-o", "first.mp4", "--exr-dir", "exr"]
    cold = run(job, work)
    assert (work / "first.mp4").stat().st_size > 0
    assert "compiling kernels once, about 40 s" in cold.stderr, cold.stderr
    install(second)  # command 2: pip install -e ".[test]"
    compiled = _cache_files(cache)
    warm = run(job[:-4] + ["-o", "second.mp4"], work)
    assert "compiling" not in warm.stderr, warm.stderr
    assert _cache_files(cache) == compiled  # nothing compiled again: no cache file new or rewritten
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    version = run([str(bin_dir / "spikeref"), "--version"], elsewhere)
    assert sr.__version__ in version.stdout + version.stderr
    run([str(bin_dir / "spikeref"), "info"], elsewhere)
    run([str(bin_dir / "spikeref"), "reconstruct", "--frames", "3:4", "-o", "again.mp4", "--exr-dir", "exr"], elsewhere)
    assert (elsewhere / "again.mp4").stat().st_size > 0
