"""Regenerate ``golden/``: run every oracle in ``spikeref.oracles.golden_cases`` and freeze it.

Usage::

    python scripts/make_golden.py [--out golden]

Each case becomes ``golden/<name>.npz`` holding its inputs (``in_*``) and the
oracle's outputs (``out_*``); ``golden/manifest.json`` lists equation, function,
oracle, parameters and tolerances.  Inputs come from fixed seeds, so running
this again rewrites identical arrays.
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
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    manifest = {"format": 1, "cases": []}
    for case in CASES:
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
