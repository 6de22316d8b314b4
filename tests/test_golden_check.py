"""``spikeref golden``: list the cases, check a port's outputs, export the inputs for a port without NumPy.

The check is held to what a port team does with it: a copy of ``golden/`` passes; the package's
own fast functions, run on the exported inputs like a port would be, pass; a deliberately wrong,
missing or misshapen output fails with a readable table and exit status 1; the export round-trips
(``.npy`` and raw ``.bin`` with a JSON header). The manifest may grow fields and a higher format
number without breaking any of it.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from spikeref import golden_check as gc
from spikeref.cli import main

GOLDEN = Path(__file__).resolve().parents[1] / "golden"
MANIFEST = json.loads((GOLDEN / "manifest.json").read_text())
N_CASES = len(MANIFEST["cases"])


def _run(argv, capsys):
    status = main(argv)
    out, err = capsys.readouterr()
    return status, out, err


def _rows(out: str, case: str) -> list[str]:
    return [line for line in out.splitlines() if line.startswith(case + " ")]


# ----------------------------------------------------------------------------- find and list
def test_the_golden_folder_is_the_repositorys():
    assert gc.find_golden() == GOLDEN
    assert gc.find_golden(GOLDEN) == GOLDEN


def test_an_installed_package_without_golden_says_what_to_do(tmp_path, monkeypatch, capsys):
    fake = tmp_path / "site-packages" / "spikeref" / "golden_check.py"
    fake.parent.mkdir(parents=True)
    monkeypatch.setattr(gc, "__file__", str(fake))
    with pytest.raises(FileNotFoundError, match="not installed with the package.*--golden"):
        gc.find_golden()
    status, out, err = _run(["golden", "list"], capsys)
    assert status == 2 and out == ""
    assert len(err.splitlines()) == 1 and "pip install -e ." in err
    # --golden still works
    status, out, _ = _run(["golden", "list", "--golden", str(GOLDEN)], capsys)
    assert status == 0 and "eq4_accumulate" in out


def test_list_prints_each_case_its_equation_and_tolerance(capsys):
    status, out, err = _run(["golden", "list"], capsys)
    assert status == 0, err
    assert f"{N_CASES} golden cases in {GOLDEN}" in out
    for case in MANIFEST["cases"]:
        (row,) = _rows(out, case["name"])
        assert case["equation"].split()[0] in row
        assert f"{case['tolerance']['rtol']:g}" in row and f"{case['tolerance']['atol']:g}" in row
    assert "note:" not in out  # the manifest and the registry agree
    status, verbose, _ = _run(["golden", "list", "-v"], capsys)
    assert status == 0 and "oracle: spikeref.oracles.accumulate" in verbose and "in_spikes 25×4×6 uint8" in verbose


def test_list_names_registry_cases_not_yet_frozen(tmp_path):
    golden = tmp_path / "golden"
    shutil.copytree(GOLDEN, golden)
    manifest = json.loads((golden / "manifest.json").read_text())
    manifest["cases"] = [c for c in manifest["cases"] if c["name"] != "tfi"]
    (golden / "manifest.json").write_text(json.dumps(manifest))
    rows = {r["name"]: r for r in gc.list_cases(golden)}
    assert rows["tfi"]["frozen"] is False
    assert "make_golden.py --only tfi" in gc.cases_table(list(rows.values()))


# ----------------------------------------------------------------------------- check
def test_a_copy_of_golden_passes(tmp_path, capsys):
    port = tmp_path / "port"
    shutil.copytree(GOLDEN, port)
    status, out, err = _run(["golden", "check", str(port)], capsys)
    assert status == 0, out + err
    assert out.rstrip().endswith(f"{N_CASES} of {N_CASES} cases pass")
    assert "FAIL" not in out and "MISSING" not in out


def test_the_packages_own_functions_pass_as_a_port(tmp_path, capsys):
    """The loop of golden/README.md with spikeref's fast functions as the port: export, compute, check."""
    from spikeref.oracles.golden_cases import CASES

    port = tmp_path / "port"
    assert _run(["golden", "export", str(port)], capsys)[0] == 0
    for case in CASES:
        folder = port / case.name
        inputs = {p.stem[3:]: np.load(p) for p in folder.glob("in_*.npy")}
        for key, value in case.run_function(inputs).items():
            np.save(folder / f"out_{key}.npy", np.asarray(value))
    status, out, err = _run(["golden", "check", str(port)], capsys)
    assert status == 0, out + err
    assert f"{N_CASES} of {N_CASES} cases pass" in out


def test_a_wrong_missing_or_misshapen_output_fails_with_a_readable_table(tmp_path, capsys):
    port = tmp_path / "port"
    shutil.copytree(GOLDEN, port)
    with np.load(port / "eq4_accumulate.npz") as f:
        arrays = dict(f)
    arrays["out_frames"][1, 2, 3] += 0.25  # one element off by a quarter spike per readout
    np.savez(port / "eq4_accumulate.npz", **arrays)
    (port / "tfi.npz").unlink()
    with np.load(port / "tfp.npz") as f:
        arrays = dict(f)
    np.savez(port / "tfp.npz", out_frames=arrays["out_frames"][:1])
    status, out, err = _run(["golden", "check", str(port)], capsys)
    assert status == 1, err
    header = out.splitlines()[1]
    for column in ("case", "array", "shape", "max |Δ|", "worst at", "got", "expected", "allowed", "result"):
        assert column in header
    (row,) = _rows(out, "eq4_accumulate")
    assert row.split()[1:] == ["out_frames", "4×4×6", "0.25", "(1,", "2,", "3)", "0.25", "0", "1e-07", "FAIL", "(1",
                               "of", "96)"]
    (row,) = _rows(out, "tfp")
    assert row.split()[-1] == "SHAPE"
    (row,) = _rows(out, "tfi")
    assert row.split()[-1] == "MISSING"
    assert "tfp: out_frames: shape (1, 2, 3) where (314, 2, 3) is expected" in out
    assert f"tfi: no tfi.npz and no folder tfi/ in {port}" in out
    assert out.rstrip().endswith(f"{N_CASES - 3} of {N_CASES} cases pass; failing: eq4_accumulate, tfp, tfi")
    # only the cases asked for
    status, out, _ = _run(["golden", "check", str(port), "--cases", "eq3_cfa,psi_rggb"], capsys)
    assert status == 0 and "2 of 2 cases pass" in out


def test_a_folder_of_npy_or_bin_files_per_case(tmp_path):
    port = tmp_path / "port"
    _, expected = gc.load_case(GOLDEN, MANIFEST["cases"][0])
    case = MANIFEST["cases"][0]
    folder = port / case["file"][:-4]
    folder.mkdir(parents=True)
    keys = sorted(expected)
    np.save(folder / f"{keys[0]}.npy", expected[keys[0]])
    for key in keys[1:]:
        gc.write_bin(folder / f"{key}.bin", expected[key])
    (res,) = gc.check_port(port, cases=[case["name"]])
    assert res.passed and res.source == str(folder)
    (folder / f"{keys[-1]}.json").unlink()  # a .bin without its header cannot be read
    (res,) = gc.check_port(port, cases=[case["name"]])
    assert not res.passed and res.arrays[-1].status == "unreadable" and "no header" in res.arrays[-1].detail


def test_compare_array_follows_assert_allclose():
    exp = np.array([1.0, np.nan, np.inf, -2.0, 0.0])
    ok = gc.compare_array("out_x", exp + np.array([1e-6, 0, 0, 0, 0]), exp, rtol=1e-5, atol=0.0)
    assert ok.passed and ok.worst_index == (0,)
    np.testing.assert_allclose(exp + np.array([1e-6, 0, 0, 0, 0]), exp, rtol=1e-5, atol=0.0)
    bad = gc.compare_array("out_x", np.array([1.0, 0.0, np.inf, -2.0, 0.0]), exp, rtol=1e-5, atol=0.0)
    assert bad.status == "fail" and bad.outside == 1 and bad.worst_index == (1,)
    inf = gc.compare_array("out_x", np.array([1.0, np.nan, -np.inf, -2.0, 0.0]), exp, rtol=1e-5, atol=0.0)
    assert inf.status == "fail" and inf.worst_index == (2,)
    assert gc.compare_array("out_x", np.zeros(()), np.zeros(()), 0.0, 0.0).passed
    assert gc.compare_array("out_x", np.zeros(3), np.zeros((1, 3)), 0.0, 0.0).status == "shape"
    exact = gc.compare_array("out_x", np.arange(3), np.arange(3, dtype=np.uint8), 0.0, 0.0)
    assert exact.passed and exact.worst_index is None and exact.max_abs == 0.0


# ----------------------------------------------------------------------------- manifest tolerance
def test_extra_manifest_fields_and_a_higher_format_are_read(tmp_path, capsys):
    golden = tmp_path / "golden"
    shutil.copytree(GOLDEN, golden)
    manifest = json.loads((golden / "manifest.json").read_text())
    manifest["format"] = 7
    manifest["specifications"] = "see README"
    for case in manifest["cases"]:
        case["spec"] = f"docs/spec/{case['name']}.md"
        case["something_new"] = {"nested": [1, 2]}
    (golden / "manifest.json").write_text(json.dumps(manifest))
    status, out, err = _run(["golden", "list", "-v", "--golden", str(golden)], capsys)
    assert status == 0, err
    assert "manifest format 7" in out and "spec: docs/spec/eq4_accumulate.md" in out
    status, out, err = _run(["golden", "check", str(golden), "--golden", str(golden)], capsys)
    assert status == 0, out + err
    status, _, err = _run(["golden", "export", str(tmp_path / "x"), "--golden", str(golden)], capsys)
    assert status == 0, err
    entry = json.loads((tmp_path / "x" / "eq4_accumulate" / "case.json").read_text())
    assert entry["something_new"] == {"nested": [1, 2]} and entry["spec"] == "docs/spec/eq4_accumulate.md"


@pytest.mark.parametrize("edit, message", [
    (lambda m: m.pop("cases"), "a 'cases' list"),
    (lambda m: m.update(format=0), "'format' must be a whole number"),
    (lambda m: m["cases"][0].pop("tolerance"), "'tolerance' must be an object"),
    (lambda m: m["cases"][0]["tolerance"].update(rtol=-1), "tolerance.rtol must be a finite number"),
    (lambda m: m["cases"][0].update(file="../x.npz"), "'file' must be a file name ending in .npz"),
    (lambda m: m["cases"].append(dict(m["cases"][0])), "listed twice"),
])
def test_a_malformed_manifest_is_refused_naming_the_field(tmp_path, edit, message):
    manifest = json.loads((GOLDEN / "manifest.json").read_text())
    edit(manifest)
    (tmp_path / "manifest.json").write_text(json.dumps(manifest))
    with pytest.raises(ValueError, match=message):
        gc.load_manifest(tmp_path)


# ----------------------------------------------------------------------------- export
def test_export_npy_round_trips(tmp_path, capsys):
    status, out, err = _run(["golden", "export", str(tmp_path / "x")], capsys)
    assert status == 0, err
    assert f"of {N_CASES} cases as .npy" in out
    assert json.loads((tmp_path / "x" / "manifest.json").read_text()) == MANIFEST
    for case in MANIFEST["cases"]:
        inputs, _ = gc.load_case(GOLDEN, case)
        folder = tmp_path / "x" / case["file"][:-4]
        assert sorted(p.stem for p in folder.glob("*.npy")) == sorted(inputs)
        listing = json.loads((folder / "case.json").read_text())["arrays"]
        for key, value in inputs.items():
            got = np.load(folder / f"{key}.npy")
            assert got.dtype == value.dtype and got.shape == value.shape
            np.testing.assert_array_equal(got, value)
            assert listing[key] == {"file": f"{key}.npy", "dtype": value.dtype.name, "shape": list(value.shape)}


def test_export_bin_round_trips_and_its_outputs_pass_the_check(tmp_path, capsys):
    out_dir = tmp_path / "x"
    status, _, err = _run(["golden", "export", str(out_dir), "--format", "bin", "--with-outputs"], capsys)
    assert status == 0, err
    for case in MANIFEST["cases"]:
        inputs, outputs = gc.load_case(GOLDEN, case)
        folder = out_dir / case["file"][:-4]
        for key, value in {**inputs, **outputs}.items():
            raw = folder / f"{key}.bin"
            header = json.loads(raw.with_suffix(".json").read_text())
            assert header == {"dtype": value.dtype.name, "shape": list(value.shape), "byteorder": "little",
                              "order": "C"}
            assert raw.stat().st_size == value.size * value.dtype.itemsize  # nothing but the bytes
            # read as a port without NumPy's .npy reader would: the raw bytes in the header's dtype and shape
            got = np.frombuffer(raw.read_bytes(), dtype=np.dtype(header["dtype"]).newbyteorder("<"))
            np.testing.assert_array_equal(got.reshape(header["shape"]), value)
            np.testing.assert_array_equal(gc.read_bin(raw), value)
    status, out, err = _run(["golden", "check", str(out_dir)], capsys)
    assert status == 0, out + err


def test_bin_files_are_little_endian_and_checked(tmp_path):
    path, meta = gc.write_bin(tmp_path / "a.bin", np.array([1, 256], dtype=np.uint16))
    assert path.read_bytes() == b"\x01\x00\x00\x01"
    header = json.loads(meta.read_text())
    meta.write_text(json.dumps(dict(header, byteorder="big")))
    np.testing.assert_array_equal(gc.read_bin(path), [256, 1])
    meta.write_text(json.dumps(dict(header, shape=[3])))
    with pytest.raises(ValueError, match="4 bytes, but dtype uint16 and shape \\[3\\] need 6"):
        gc.read_bin(path)
    meta.write_text(json.dumps(dict(header, dtype="complex128")))
    with pytest.raises(ValueError, match="dtype must be one of"):
        gc.read_bin(path)
    with pytest.raises(TypeError, match="array: a .bin file holds one of"):
        gc.write_bin(tmp_path / "c.bin", np.zeros(2, complex))
    with pytest.raises(ValueError, match="must end in .bin"):
        gc.write_bin(tmp_path / "c.raw", np.zeros(2))


def test_bad_arguments_name_themselves(tmp_path):
    with pytest.raises(ValueError, match="format must be one of npy, bin"):
        gc.export_cases(tmp_path / "x", "csv")
    with pytest.raises(ValueError, match="cases: unknown case nope"):
        gc.check_port(GOLDEN, cases=["nope"])
    with pytest.raises(TypeError, match="cases must be a list"):
        gc.check_port(GOLDEN, cases="tfi")
    with pytest.raises(FileNotFoundError, match="no such folder"):
        gc.check_port(tmp_path / "nope")
    with pytest.raises(FileNotFoundError, match="no manifest.json there"):
        gc.find_golden(tmp_path)
    assert not (tmp_path / "x").exists()
