"""Counts of ema_rig's imports by kind and the layer test's violations (issue 21).

Usage: ``python benchmarks/import_counts.py [-v] [--json OUT]`` from the repository root. The
checks are those of ``tests/test_layers.py`` (one definition); ``-v`` lists every violation and
the remaining imports inside functions by target with the reason each is there.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import test_layers as tl  # noqa: E402  (the layer test is the one definition of the checks)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-v", action="store_true", help="list every violation and every remaining lazy import")
    ap.add_argument("--json", help="write the counts to this file")
    args = ap.parse_args()
    imps = tl.collect_imports()
    counts = tl.counts(imps)
    for k, v in counts.items():
        print(f"{k:40s} {v}")
    if args.json:
        Path(args.json).write_text(json.dumps(counts, indent=1) + "\n", encoding="utf-8")
    if not args.v:
        return
    for fn in (tl.upward_imports, tl.unjustified_function_level_imports, tl.private_imports,
               tl.private_module_imports):
        print(f"\n# {fn.__name__}")
        print("\n".join(fn(imps)))
    print("\n# import_cycles")
    print("\n".join(" <-> ".join(c) for c in tl.import_cycles(imps)))
    print("\n# imports inside functions (statements), by target, with the reason")
    stmts = {(i.importer, i.line, i.target.split(".")[0]): i for i in imps if i.in_function}.values()
    by = Counter("ema_rig" if i.target.startswith("ema_rig") else i.target.split(".")[0] for i in stmts)
    for t, n in by.most_common():
        why = ("a module that imports a heavy package, from a module that must stay light (cold start)"
               if t == "ema_rig" else tl.LAZY_EXTERNAL.get(t, "NO REASON: move it to the top"))
        print(f"{n:4d} {t:14s} {why}")


if __name__ == "__main__":
    main()
