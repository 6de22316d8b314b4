"""Every golden case is specified for a port: its manifest entry names a section of ``docs/spec/``
that exists, holds a procedure and names every array of the case; the manifest is the registry's.
"""

import json
import re
from pathlib import Path

import pytest

from spikeref.oracles.golden_cases import CASES, MANIFEST_FORMAT, build_manifest

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "golden"
SPEC = ROOT / "docs" / "spec"
MANIFEST = json.loads((GOLDEN / "manifest.json").read_text(encoding="utf-8"))

#: What every case section must say, each as a bold label.
LABELS = ("**Inputs**", "**Procedure**", "**Outputs**")


def slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces to hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def headings(text: str) -> list[tuple[int, int, str]]:
    """``(line index, level, text)`` of every ATX heading outside fenced code blocks."""
    out, fenced = [], False
    for n, line in enumerate(text.splitlines()):
        if line.lstrip().startswith("```"):
            fenced = not fenced
            continue
        m = re.match(r"(#{1,6}) (.+?)\s*#*\s*$", line)
        if m and not fenced:
            out.append((n, len(m.group(1)), m.group(2)))
    return out


def section(path: Path, anchor: str) -> str:
    """The text under the heading whose anchor is ``anchor``, up to the next heading of its level or above."""
    text = path.read_text(encoding="utf-8")
    lines = text.splitlines()
    found = headings(text)
    for i, (n, level, title) in enumerate(found):
        if slug(title) == anchor:
            end = next((m for m, lv, _ in found[i + 1:] if lv <= level), len(lines))
            return "\n".join(lines[n + 1:end])
    raise AssertionError(f"{path.relative_to(ROOT)} has no heading with the anchor #{anchor}")


def test_manifest_is_the_registry_s():
    """golden/manifest.json is what scripts/make_golden.py writes from the registry and the files."""
    assert MANIFEST["format"] == MANIFEST_FORMAT >= 2
    assert MANIFEST == json.loads(json.dumps(build_manifest(GOLDEN), ensure_ascii=False))


@pytest.mark.parametrize("case", MANIFEST["cases"], ids=lambda c: c["name"])
def test_case_has_a_specification(case):
    spec = case.get("spec")
    assert isinstance(spec, str) and spec, f"{case['name']}: no 'spec' field in the manifest"
    m = re.fullmatch(r"(docs/spec/[\w\-]+\.md)#([\w\-]+)", spec)
    assert m, f"{case['name']}: spec {spec!r} is not docs/spec/<page>.md#<anchor>"
    path = ROOT / m.group(1)
    assert path.is_file(), f"{case['name']}: {m.group(1)} does not exist"
    body = section(path, m.group(2))
    words = re.sub(r"\s+", " ", body)
    assert len(words) > 300, f"{spec}: the section is (nearly) empty"
    for label in LABELS:
        assert label in body, f"{spec}: the section has no {label}"
    procedure = body.split("**Procedure**", 1)[1]
    assert len(procedure.split("**Outputs**", 1)[0].strip()) > 40, f"{spec}: the procedure is empty"
    for key in list(case["inputs"]) + list(case["outputs"]):
        name = "in_param_" if key.startswith("in_param_") else key
        assert f"`{name}" in body, f"{spec}: the section does not describe {key}"


def test_registry_cases_all_have_a_spec():
    assert [c.name for c in CASES if not c.spec] == []


def test_spec_pages_have_unique_anchors_and_links_resolve():
    """Every relative link of docs/spec/ (and golden/README.md's into it) reaches a file and heading."""
    pages = sorted(SPEC.glob("*.md")) + [GOLDEN / "README.md", ROOT / "docs" / "equations.md"]
    for page in pages:
        text = page.read_text(encoding="utf-8")
        anchors = [slug(t) for _, _, t in headings(text)]
        if page.parent == SPEC:
            assert len(anchors) == len(set(anchors)), f"{page.name}: two headings share an anchor"
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"[a-z]+:", target):
                continue
            file, _, anchor = target.partition("#")
            dest = (page.parent / file).resolve() if file else page
            if page.parent != SPEC and "spec" not in dest.parts:
                continue  # outside docs/spec only the links into it are checked here
            assert dest.is_file(), f"{page.relative_to(ROOT)}: link {target} reaches no file"
            if anchor and dest.suffix == ".md":
                section(dest, anchor)


def test_golden_readme_points_to_the_specification():
    text = (GOLDEN / "README.md").read_text(encoding="utf-8")
    assert "../docs/spec/README.md" in text


def test_no_document_cites_the_design_notes():
    """The design notes are not part of the repository: neither a port's documents nor the code's docstrings
    may send a reader there."""
    for path in [*GOLDEN.glob("*.md"), GOLDEN / "manifest.json", *(ROOT / "docs").rglob("*.md"),
                 *(ROOT / "spikeref").rglob("*.py")]:
        assert "DESIGN §" not in path.read_text(encoding="utf-8"), (
            f"{path.relative_to(ROOT)} cites the design notes (DESIGN §…), which are not in the repository: "
            "cite docs/equations.md or docs/spec/ instead")


# ----------------------------------------------------------------------------- the audit map agrees with the registry
def _audit_table() -> list[list[str]]:
    """The rows of docs/equations.md's table (equation → function → oracle → tests → golden)."""
    lines = (ROOT / "docs" / "equations.md").read_text(encoding="utf-8").splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("| eq. |"))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append(line)
    return rows


def _defined_in_source(module: str, attrs: list[str]) -> bool:
    """Whether ``module``'s source defines ``attrs`` (a top-level name, then names in its class body), read
    without importing it: for a module that needs an optional extra not installed here (torch for
    ``denoise.train``), so that a fresh install of the test extra alone checks its names too."""
    import ast
    import importlib.util

    try:
        spec = importlib.util.find_spec(module)
    except ImportError:   # a parent package that does not import
        return False
    if spec is None or not spec.origin or not spec.origin.endswith(".py"):
        return False
    body = ast.parse(Path(spec.origin).read_text(encoding="utf-8")).body
    for attr in attrs:
        names = {}
        for node in body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names[node.name] = node
            elif isinstance(node, (ast.Assign, ast.AnnAssign)):
                for target in (node.targets if isinstance(node, ast.Assign) else [node.target]):
                    if isinstance(target, ast.Name):
                        names[target.id] = node
        if attr not in names:
            return False
        body = getattr(names[attr], "body", [])
    return True


def _resolves(name: str) -> bool:
    """``name`` (``spikeref.x.y``, or short: ``oracles.x.y``, ``effects.f`` …) is an attribute of a module.

    A module that cannot be imported for want of a package outside spikeref (an optional extra) is read
    from its source instead (:func:`_defined_in_source`).
    """
    import importlib

    for prefix in ("spikeref.", "spikeref.simulate.", "spikeref.denoise."):
        full = name if name.startswith("spikeref.") else prefix + name
        parts = full.split(".")
        for i in range(len(parts), 1, -1):
            module = ".".join(parts[:i])
            try:
                obj = importlib.import_module(module)
            except ModuleNotFoundError as exc:
                if exc.name and not exc.name.startswith("spikeref") and _defined_in_source(module, parts[i:]):
                    return True
                continue
            except ImportError:
                continue
            try:
                for attr in parts[i:]:
                    obj = getattr(obj, attr)
                return True
            except AttributeError:
                break
    return False


def test_audit_map_is_the_registry_s():
    """docs/equations.md's table is what scripts/make_golden.py writes from spikeref/oracles/audit_map.py."""
    from spikeref.oracles.audit_map import AUDIT_MAP, render_golden, with_audit_table

    text = (ROOT / "docs" / "equations.md").read_text(encoding="utf-8")
    assert with_audit_table(text) == text, ("docs/equations.md differs from the audit map: "
                                            "python scripts/make_golden.py --manifest-only")
    assert len(AUDIT_MAP) == len(_audit_table())
    with pytest.raises(KeyError, match="not_a_case"):
        render_golden("{not_a_case}")


def test_audit_map_names_every_golden_file_and_no_other():
    named = set(re.findall(r"`([\w]+)\.npz`", "\n".join(_audit_table())))
    assert named == {c.name for c in CASES}


DOTTED = r"`((?:spikeref|oracles|simulate|effects|denoise|align|warp|bayer|pipeline)\.[A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*)"


def test_audit_map_and_registry_name_only_what_exists():
    """Every dotted function or oracle named in docs/equations.md's table and in the golden registry is there."""
    names = set(re.findall(DOTTED, "\n".join(_audit_table())))
    for case in CASES:
        names |= set(re.findall(r"(spikeref\.[A-Za-z_]\w*(?:\.[A-Za-z_]\w*)+)", case.function + " " + case.oracle))
    assert len(names) > 60  # the table names about sixty; a broken pattern would find none
    assert sorted(n for n in names if not _resolves(n)) == []


def test_the_name_check_sees_a_stale_name():
    assert _resolves("spikeref.align.align_tiles") and _resolves("effects.noise_fraction")
    assert _resolves("oracles.align.align_tiles_oracle")
    assert not _resolves("spikeref.align._noise_correlation_gone") and not _resolves("spikeref.io.dat.read_dat")


def test_the_name_check_reads_a_module_it_cannot_import(monkeypatch):
    """Without torch (the train extra) the training module's names are read from its source, stale ones still fail."""
    import sys

    for mod in [m for m in sys.modules if m == "torch" or m.startswith("torch.") or m == "spikeref.denoise.train"
                or m == "spikeref.denoise.torch_unet"]:
        monkeypatch.delitem(sys.modules, mod)
    monkeypatch.setitem(sys.modules, "torch", None)
    assert _resolves("spikeref.denoise.train.CropSampler.sample_pairs") and _resolves("denoise.torch_unet.TorchUNet")
    assert _resolves("spikeref.denoise.train.train")
    assert not _resolves("spikeref.denoise.train.CropSampler.gone") and not _resolves("spikeref.denoise.train.gone")


def test_each_golden_file_s_row_names_the_registry_s_function_and_oracle():
    """The three copies of the audit map agree: the row of docs/equations.md that lists a golden file names
    the function and the oracle the registry (and so golden/manifest.json) gives for that case."""
    rows = _audit_table()
    wrong = []
    for case in CASES:
        mine = [r for r in rows if f"`{case.name}.npz`" in r]
        text = " ".join(mine).replace("`spikeref.", "`")
        for field in (case.function, case.oracle):
            first = re.match(r"spikeref\.([\w.]+)", field).group(1)
            module, _, name = first.rpartition(".")
            short = [first, f"{module.rpartition('.')[2]}.{name}", name]
            if not any(f"`{s}" in text or f" {s}" in text or f"({s}" in text for s in short):
                wrong.append(f"{case.name}: its row names no {first}")
    assert not wrong, "\n".join(wrong)
