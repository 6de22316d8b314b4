"""The package's import graph: layers in one direction, no circles, no private names across modules.

Layers, lowest first (``docs/architecture.md``): the Numba set-up; ``io`` (bytes); the core (the
stream, the CFA and Bayer planes, Eq. 4 and the window charge, metrics); the algorithms (baselines,
denoiser, alignment, warping, demosaic, simulator); the pipeline; the application (CLI, output
sink and resume, Dask, benchmark, sample, the golden registry and port checker).  A module imports
from its own layer or below.  The literal oracles import no fast code at all: only NumPy, SciPy and
one another, so a wrong kernel cannot make its oracle wrong too.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import spikeref

ROOT = Path(spikeref.__file__).parent

#: Layer of each module, by longest matching prefix.
LAYERS = {
    "spikeref._jit": 0,
    "spikeref._callable": 0,
    "spikeref._checks": 0,
    "spikeref.io": 1,
    "spikeref.stream": 2,
    "spikeref.bayer": 2,
    "spikeref.accumulate": 2,
    "spikeref._accumulate_kernels": 2,
    "spikeref.charge": 2,
    "spikeref.noise_level": 2,
    "spikeref.cfa_detect": 2,
    "spikeref.hot_pixels": 2,
    "spikeref.dark_level": 2,
    "spikeref.metrics": 2,
    "spikeref.tonemap": 2,
    "spikeref.baselines": 3,
    "spikeref.baseline_stream": 3,
    "spikeref._baselines_kernels": 3,
    "spikeref.denoise": 3,
    "spikeref.align": 3,
    "spikeref._align_kernels": 3,
    "spikeref.align_noise": 3,
    "spikeref.align_params": 3,
    "spikeref.pyramid": 3,
    "spikeref.warp": 3,
    "spikeref._warp_kernels": 3,
    "spikeref.compose": 3,
    "spikeref.merge": 3,
    "spikeref._merge_kernels": 3,
    "spikeref.multiframe_demosaic": 3,
    "spikeref.demosaic": 3,
    "spikeref.directional_demosaic": 3,
    "spikeref.simulate": 3,
    "spikeref.noise_check": 3,
    "spikeref.pipeline": 4,
    "spikeref.pipeline_params": 4,
    "spikeref.pipeline_rings": 4,
    "spikeref.render": 5,
    "spikeref.sample": 5,
    "spikeref.distributed": 5,
    "spikeref.bench": 5,
    "spikeref.cli": 5,
    "spikeref.golden_check": 5,
    "spikeref.oracles.golden_cases": 5,
    "spikeref.oracles.audit_map": 5,
    "spikeref": 5,  # the package's lazy exports (PEP 562) reach every layer
}
#: The registries beside the oracles: they name the fast functions, so they sit in the application layer.
APPLICATION_ORACLES = ("spikeref.oracles.golden_cases", "spikeref.oracles.audit_map")
NAMES = {0: "Numba set-up", 1: "io", 2: "core", 3: "algorithms", 4: "pipeline", 5: "application"}

# Application modules (layer 5) keep the imports of their commands inside the functions that run
# them, so that ``spikeref --help`` and a command's argument errors answer without loading Numba's
# kernels; the library (layers 0–4) imports at the top, except for optional extras.


def _modules():
    for path in sorted(ROOT.rglob("*.py")):
        parts = path.relative_to(ROOT.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        yield name, path


def _layer(module: str):
    if module.startswith("spikeref.oracles") and module not in APPLICATION_ORACLES:
        return "oracle"
    if module == "spikeref":
        return LAYERS["spikeref"]
    # longest listed prefix; the package itself is no prefix: a module nobody listed has no layer
    best = max((p for p in LAYERS if p != "spikeref" and (module == p or module.startswith(p + "."))), key=len,
               default=None)
    return None if best is None else LAYERS[best]


def _import_nodes(path: Path):
    """``(node, deferred)`` for every ``import`` / ``from … import`` of a file; deferred: inside a function."""
    tree = ast.parse(path.read_text())
    deferred_nodes = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            deferred_nodes.update(id(n) for n in ast.walk(node))
    for node in ast.walk(tree):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node, id(node) in deferred_nodes


def _imports(path: Path, module: str):
    """``(target module, names, line, deferred)`` for every import of a spikeref module."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for node, deferred in _import_nodes(path):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                target = f"{base}.{node.module}" if node.module else base
            else:
                target = node.module or ""
            if target == "spikeref" or target.startswith("spikeref."):
                # ``from spikeref.denoise import blindspot`` imports the module spikeref.denoise.blindspot;
                # ``from spikeref import _EXPORTS`` a name of the package itself
                names = []
                for a in node.names:
                    if f"{target}.{a.name}" in MODULES:
                        yield f"{target}.{a.name}", [], node.lineno, deferred
                    else:
                        names.append(a.name)
                if names:
                    yield target, names, node.lineno, deferred
        else:
            for a in node.names:
                if a.name == "spikeref" or a.name.startswith("spikeref."):
                    yield a.name, [], node.lineno, deferred


MODULES = dict(_modules())


def test_every_module_has_a_layer():
    assert not [m for m in MODULES if _layer(m) is None]


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_go_down_the_layers(module):
    mine = _layer(module)
    wrong = []
    for target, _, line, _ in _imports(MODULES[module], module):
        theirs = _layer(target)
        if mine == "oracle":
            if theirs != "oracle":
                wrong.append(f"line {line}: the oracle {module} imports {target} (fast code)")
        elif theirs == "oracle":
            if mine != 5:
                wrong.append(f"line {line}: the library module {module} imports the oracle {target}")
        elif theirs > mine:
            wrong.append(f"line {line}: {module} ({NAMES[mine]}) imports {target} ({NAMES[theirs]})")
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_private_name_is_imported_from_another_module(module):
    wrong = [f"line {line}: {module} imports {n} from {target}"
             for target, names, line, _ in _imports(MODULES[module], module) if target != module
             for n in names if n.startswith("_") and not n.startswith("__")]
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize("module", sorted(m for m in MODULES if _layer(m) != 5))
def test_library_modules_import_the_package_at_the_top(module):
    deferred = [f"line {line}: {module} imports {target} inside a function"
                for target, _, line, inner in _imports(MODULES[module], module) if inner]
    assert not deferred, "\n".join(deferred)


def _circles(graph: dict) -> list[str]:
    """Every circle a depth-first walk of ``graph`` (module → modules it imports) meets."""
    state, circles = {}, []

    def visit(node, trail):
        state[node] = "open"
        for t in sorted(graph[node]):
            if state.get(t) == "open":
                circles.append(" -> ".join(trail[trail.index(t):] + [t]))
            elif t not in state:
                visit(t, trail + [t])
        state[node] = "done"

    for m in sorted(graph):
        if m not in state:
            visit(m, [m])
    return circles


def test_no_import_circle_among_top_level_imports():
    graph = {m: {t for t, _, _, inner in _imports(p, m) if not inner and t in MODULES and t != m}
             for m, p in MODULES.items()}
    # a package's __init__ importing its own submodules is how a package is built, not a circle
    for m in graph:
        graph[m] = {t for t in graph[m] if not (MODULES[t].name == "__init__.py" and m.startswith(t + "."))}
    circles = _circles(graph)
    assert not circles, "\n".join(circles)


def test_the_layer_test_sees_a_wrong_import(tmp_path):
    # The walk must find an upward import, a private name and a deferred import in a module it is shown.
    bad = tmp_path / "bad.py"
    bad.write_text("from spikeref.pipeline import reconstruct\nfrom spikeref.bayer import _secret\n"
                   "def f():\n    from spikeref.align import align\n")
    found = list(_imports(bad, "spikeref.bayer"))
    assert ("spikeref.pipeline", ["reconstruct"], 1, False) in found
    assert ("spikeref.bayer", ["_secret"], 2, False) in found
    assert ("spikeref.align", ["align"], 4, True) in found
    assert _layer("spikeref.pipeline") > _layer("spikeref.bayer")
    assert _layer("spikeref.oracles.align") == "oracle" and _layer("spikeref.oracles.golden_cases") == 5
    assert _layer("spikeref.new_algorithm") is None and _layer("spikeref") == 5  # an unlisted module has none
    bad.write_text("from spikeref import _EXPORTS, baselines\nfrom spikeref.denoise import blindspot\n")
    found = list(_imports(bad, "spikeref.render"))
    assert ("spikeref", ["_EXPORTS"], 1, False) in found and ("spikeref.baselines", [], 1, False) in found
    assert ("spikeref.denoise.blindspot", [], 2, False) in found
    assert _circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a -> b -> c -> a"]
    assert _circles({"a": {"b"}, "b": set()}) == []


#: The optional extras (``pyproject.toml``): the only imports a library module may defer into a function.
OPTIONAL_EXTRAS = ("torch", "dask", "distributed", "bm3d", "skimage", "pywt", "matplotlib")


def _deferred_imports(path: Path):
    """``(top-level package, line)`` of every import made inside a function, other than the package's own."""
    for node, deferred in _import_nodes(path):
        if not deferred or (isinstance(node, ast.ImportFrom) and node.level):
            continue
        names = [node.module or ""] if isinstance(node, ast.ImportFrom) else [a.name for a in node.names]
        for name in names:
            top = name.split(".")[0]
            if top != "spikeref":
                yield top, node.lineno


@pytest.mark.parametrize("module", sorted(m for m in MODULES if _layer(m) not in (5, "oracle")))
def test_library_modules_defer_only_optional_extras(module):
    # A runtime dependency (NumPy, SciPy, Numba, imageio, OpenEXR, tqdm) is imported at the top, so that a
    # missing one fails on import and the module's dependencies are read in one place.
    wrong = sorted({f"line {line}: {module} imports {top} inside a function"
                    for top, line in _deferred_imports(MODULES[module]) if top not in OPTIONAL_EXTRAS})
    assert not wrong, "\n".join(wrong)


def test_the_deferred_import_walk_sees_one(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("import numpy\ndef f():\n    from scipy.ndimage import gaussian_filter\n    import torch.nn\n")
    assert sorted(_deferred_imports(bad)) == [("scipy", 3), ("torch", 4)]
