"""Regenerate ``golden/``: run every oracle in ``spikeref.oracles.golden_cases`` and freeze it.

Usage::

    python scripts/make_golden.py [--out golden] [--only NAME ...]

Each case becomes ``golden/<name>.npz`` holding its inputs (``in_*``) and the
oracle's outputs (``out_*``); ``golden/manifest.json`` lists equation, function,
oracle, parameters and tolerances.  Inputs come from fixed seeds, so running
this again rewrites identical arrays.  ``--only`` regenerates the named cases and keeps the
other files and manifest entries as they are (the pipeline oracles take minutes each).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from spikeref.oracles.golden_cases import CASES


def _spec(a: np.ndarray) -> dict:
    return {"dtype": str(a.dtype), "shape": list(a.shape)}


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "golden")
    parser.add_argument("--only", nargs="+", default=None, metavar="NAME", help="regenerate only these cases")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    names = [c.name for c in CASES]
    unknown = [n for n in args.only or () if n not in names]
    if unknown:
        parser.error(f"unknown case {', '.join(unknown)}; cases: {', '.join(names)}")
    old = {}
    if args.only and (args.out / "manifest.json").is_file():
        old = {c["name"]: c for c in json.loads((args.out / "manifest.json").read_text())["cases"]}
    manifest = {"format": 1, "cases": []}
    for case in CASES:
        if args.only and case.name not in args.only:
            if case.name in old:
                manifest["cases"].append(old[case.name])
            continue
        inputs = case.make_inputs()
        outputs = case.run_oracle(inputs)
        arrays = {f"in_{k}": np.asarray(v) for k, v in inputs.items()}
        arrays.update({f"out_{k}": np.asarray(v) for k, v in outputs.items()})
        np.savez_compressed(args.out / f"{case.name}.npz", **arrays)
        manifest["cases"].append({
            "name": case.name,
            "file": f"{case.name}.npz",
            "equation": case.equation,
            "function": case.function,
            "oracle": case.oracle,
            "description": case.description,
            "params": case.params,
            "inputs": {k: _spec(a) for k, a in arrays.items() if k.startswith("in_")},
            "outputs": {k: _spec(a) for k, a in arrays.items() if k.startswith("out_")},
            "tolerance": {"rtol": case.rtol, "atol": case.atol},
        })
        print(f"{case.name:16s} {', '.join(arrays)}")
    (args.out / "manifest.json").write_text(json.dumps(manifest, indent=2, ensure_ascii=False) + "\n")


if __name__ == "__main__":
    main()
