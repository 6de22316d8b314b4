import os
import re
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
REAL_DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "real"
if not REAL_DATA.is_dir():  # a clone elsewhere: look beside the repository root too
    REAL_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "real"

#: The import name of each distribution named in pyproject.toml whose import name differs from its own.
IMPORT_NAMES = {"scikit-image": "skimage", "pywavelets": "pywt", "pytest-benchmark": "pytest_benchmark",
                "opencv-python": "cv2"}


def _requirement_module(requirement: str) -> str:
    """The import name of a requirement of pyproject.toml (``"scikit-image>=0.22"`` → ``skimage``)."""
    name = re.match(r"[A-Za-z0-9_.\-]+", requirement.strip()).group(0)
    return IMPORT_NAMES.get(name.lower(), name.replace("-", "_"))


def optional_outside_test() -> dict[str, str]:
    """``{module: extra}`` of the packages a test may skip for: those of an extra that the ``test`` extra
    does not also bring (``torch`` of ``train``, ``bm3d`` of ``peers``), read from pyproject.toml.

    README command 2 installs the ``test`` extra, so a test skipped because a package of that extra (or a
    runtime dependency) cannot be imported is a missing install step, and fails (see
    :func:`pytest_runtest_makereport`); CI runs the same command in a fresh virtualenv, so a dependency
    missing from pyproject.toml turns CI red instead of quietly skipping its tests.
    """
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - Python 3.10
        import tomli as tomllib
    path = ROOT / "pyproject.toml"
    if not path.is_file():  # the tests run from an installed copy: the two extras CI adds
        return {"torch": "train", "bm3d": "peers"}
    project = tomllib.loads(path.read_text(encoding="utf-8"))["project"]
    extras = project.get("optional-dependencies", {})
    required = {_requirement_module(r) for r in project.get("dependencies", []) + extras.get("test", [])}
    return {_requirement_module(r): extra for extra, reqs in extras.items() for r in reqs
            if _requirement_module(r) not in required}


#: ``{module: extra}`` of the packages a test may skip for: the two that .ci/run's second phase adds to README
#: command 2's install.  Written out, not derived, so that a package dropped from the test extra fails here even
#: when another extra still names it (``test_package`` checks it against :func:`optional_outside_test`).
CI_ADDS = {"torch": "train", "bm3d": "peers"}
#: ``SPIKEREF_REQUIRE_EXTRAS=1`` (CI's second phase, after it installs them): no test may skip for any package.
REQUIRE_EXTRAS = os.environ.get("SPIKEREF_REQUIRE_EXTRAS", "0") not in ("", "0")
OPTIONAL = {} if REQUIRE_EXTRAS else dict(CI_ADDS)
_MISSING = re.compile(r"could not import '([\w.]+)'")


def _strict_skip(report) -> None:
    """A skip for a module the test extra brings becomes a failure; one for an optional extra names it."""
    if not report.skipped or not isinstance(report.longrepr, tuple):
        return
    path, line, message = report.longrepr
    found = _MISSING.search(message)
    if found is None:
        return
    module = found.group(1).split(".")[0]
    if module in OPTIONAL:
        extra = OPTIONAL[module]
        report.longrepr = (path, line, f"{message.rstrip('.')} (optional: the {extra!r} extra, which CI installs)")
        return
    report.outcome = "failed"
    why = ("SPIKEREF_REQUIRE_EXTRAS=1: every extra should be installed" if REQUIRE_EXTRAS else
           f"{module!r} is a runtime dependency or part of the 'test' extra, so this test may not skip: "
           f"pip install -e \".[test]\", or declare it in pyproject.toml")
    report.longrepr = f"{path}:{line}: {message}\n{why}"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    _strict_skip(outcome.get_result())


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    outcome = yield
    _strict_skip(outcome.get_result())


@pytest.fixture
def rng():
    return np.random.default_rng(20241001)


@pytest.fixture(scope="session")
def real_data() -> Path:
    if not REAL_DATA.is_dir():
        pytest.skip("../shared/data/real is not present")
    return REAL_DATA
