"""``spikeref golden``: list the golden cases, check a port's outputs against them, export their inputs."""

from __future__ import annotations

import argparse
from pathlib import Path

from spikeref.cli.arguments import comma_list
from spikeref.cli.errors import output_phase
from spikeref.cli.outputs import check_output_dir

__all__ = ["cmd_golden", "add_parser"]


def cmd_golden(args) -> int:
    from spikeref import golden_check as gc

    action = getattr(args, "golden_command", None)
    if action is None:
        args.golden_parser.print_help()
        return 2
    golden = gc.find_golden(args.golden)
    if action == "list":
        rows = gc.list_cases(golden)
        fmt = gc.load_manifest(golden).get("format", 1)
        print(f"{sum(r['frozen'] for r in rows)} golden cases in {golden} (manifest format {fmt}). A port passes "
              "a case when every out_* array is within |got - expected| <= atol + rtol*|expected|.")
        print(gc.cases_table(rows, verbose=args.verbose))
        return 0
    if action == "check":
        cases = comma_list(args.cases) if args.cases is not None else None
        results = gc.check_port(args.dir, golden, cases=cases)
        print(f"golden check of {args.dir} against {golden}")
        print(gc.results_table(results))
        return 0 if all(r.passed for r in results) else 1
    # export
    check_output_dir(args.dir, "DIR")
    gc.load_manifest(golden)  # a malformed manifest is refused before anything is written
    with output_phase():
        written = gc.export_cases(args.dir, args.format, golden, outputs=args.with_outputs)
    folders = len({p.parent for p in written if p.name == "case.json"})
    what = "inputs and expected outputs" if args.with_outputs else "inputs"
    print(f"wrote the {what} of {folders} cases as .{args.format} ({len(written)} files) under {args.dir}; "
          f"the description of each case is in <case>/case.json, the manifest in {args.dir / 'manifest.json'}")
    return 0


def add_parser(sub) -> list[argparse.ArgumentParser]:
    """Add ``spikeref golden`` and its options to ``sub``, the commands' sub-parsers; return the parsers
    made (:func:`spikeref.cli.parser.build_parser` gives each ``--debug``)."""
    p = sub.add_parser("golden", help="list the golden cases, check a port's outputs against them, export "
                                      "their inputs for a port without Python",
                       description="The golden vectors (golden/ in the repository: one .npz per equation with its "
                                   "inputs in_* and the oracle's outputs out_*, and manifest.json) are the acceptance "
                                   "test of a port. A port passes a case when every out_* array it computes from the "
                                   "in_* arrays is within |got - expected| <= atol + rtol*|expected| (the case's "
                                   "tolerance, in the arrays' own units). See golden/README.md.")
    p.set_defaults(func=cmd_golden, golden_parser=p)
    gsub = p.add_subparsers(dest="golden_command", metavar="ACTION")
    golden_help = ("the golden folder (default: golden/ beside the installed package's source, i.e. the "
                   "repository's; needed when the package was installed with pip install .)")
    g = gsub.add_parser("list", help="each case, its equation and its tolerance",
                        description="Print each golden case: its name, the paper's equation, its tolerance (rtol "
                                    "relative, atol absolute, in the arrays' units) and the out_* arrays a port "
                                    "must produce, from golden/manifest.json and the registry "
                                    "spikeref/oracles/golden_cases.py (a disagreement between them is noted).")
    g.add_argument("--golden", type=Path, default=None, metavar="DIR", help=golden_help)
    g.add_argument("-v", "--verbose", action="store_true",
                   help="also each case's inputs and outputs (shape and dtype), Python function, oracle, "
                        "description and specification")
    g = gsub.add_parser("check", help="compare a port's outputs with the golden ones; exit 1 on any failure",
                        description="Compare a port's outputs with the stored ones and print a pass/fail table with "
                                    "the worst error of every array: max |got - expected|, and where the element "
                                    "furthest outside atol + rtol*|expected| is, with both values. DIR holds, per "
                                    "case, either NAME.npz (the case's file name in manifest.json) with the out_* "
                                    "arrays under the same keys, or a folder NAME/ with out_KEY.npy, or out_KEY.bin "
                                    "(raw little-endian, C order) with its header out_KEY.json "
                                    '({"dtype": "float32", "shape": [2, 64, 64, 3]}). A copy of golden/ passes. '
                                    "Exit status 0 when every case passes, 1 when one fails or is missing, 2 when the "
                                    "command is refused.")
    g.add_argument("dir", type=Path, metavar="DIR", help="folder of the port's outputs")
    g.add_argument("--golden", type=Path, default=None, metavar="DIR", help=golden_help)
    g.add_argument("--cases", default=None,
                   help="comma-separated case names to check (default: every case; a case with no output fails)")
    g = gsub.add_parser("export", help="write every case's inputs as .npy or raw .bin files for a port",
                        description="Write every golden case's inputs into DIR/NAME/ (NAME: the case's file name "
                                    "without .npz) as in_KEY.npy (--format npy), or as raw little-endian C-order "
                                    "in_KEY.bin each with a JSON header in_KEY.json giving dtype (uint8, int64, "
                                    "float32, float64…) and shape (--format bin; for ports in C, CUDA or on an FPGA "
                                    "that have no NumPy). Also DIR/manifest.json (a copy) and DIR/NAME/case.json (the "
                                    "case's parameters, tolerance and the list of its array files). A port that writes "
                                    "its outputs beside them as out_KEY.npy or out_KEY.bin + out_KEY.json is checked "
                                    "with spikeref golden check DIR. Files of the same names are replaced.")
    g.add_argument("dir", type=Path, metavar="DIR", help="folder to write (made if missing)")
    g.add_argument("--format", choices=["npy", "bin"], default="npy",
                   help="npy (default): NumPy .npy files; bin: raw little-endian bytes with a JSON header each")
    g.add_argument("--with-outputs", action="store_true",
                   help="also write the expected out_* arrays (for a port whose own test compares them)")
    g.add_argument("--golden", type=Path, default=None, metavar="DIR", help=golden_help)
    return [p, *gsub.choices.values()]
