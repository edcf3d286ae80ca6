"""Does the mark fit whatever the key: one payload under several keys on each mesh (issue 13).

``check_keep.py`` marks each mesh under one fixed key; whether a mesh near the edge of its
capacity carries a payload can depend on the key (the slots' layout and dither are keyed).
This marks every mesh under ``--keys`` keys (``"check-keys-0"``, ...; the id of each is the
first 8 bytes of the key's SHA-256, fixed and public), with the input's mesh kept, and prints a
row per mesh: how many keys it carries the payload under, how many of those needed the weak
bits reinforced, the largest read-back error, MRMS and Hausdorff against the input (MeshLab,
over the input's bounding-box diagonal), whether ``verify`` detects every one at FPR 1e-6 and
a wrong key none, and the refusals' read-back errors.

    python scripts/check_keys.py [--logo] [--keys 6] [--meshes spot ...] [--synthetic]
        [--jobs 2] [--out F]
"""

from __future__ import annotations

import argparse
import hashlib
import re
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from check_keep import add_run_options, load, run_names

from meshwm.errors import CapacityError
from meshwm.message.mark import default_mark
from meshwm.watermark import embed, verify


def _one(name: str, key: str, logo: bool) -> dict[str, Any]:
    """Mark ``name`` under ``key``; what the report and ``verify`` say."""
    v, f = load(name)
    ident = None if logo else hashlib.sha256(key.encode()).digest()[:8]
    mark = default_mark(32) if logo else None
    try:
        out = embed(v, f, mark, key=key, ident=ident)
    except CapacityError as exc:
        found = re.search(r"(\d+(?:\.\d+)?)% wrong", str(exc))
        return {"carried": False, "ber": float(found.group(1)) / 100 if found else None}
    r = out.report
    return {
        "carried": True,
        "reinforced": bool(r.get("reinforced")),
        "ber": float(r["read_ber"]),
        "mrms": float(r["mrms_rel"]),
        "hausdorff": float(r["hausdorff_rel"]),
        "detected": verify(out.vertices, f, key=key, ident=ident, mark=mark).detected,
        "wrong_key": verify(out.vertices, f, key=key + " (wrong)", ident=ident, mark=mark).detected,
    }


def _row(name: str, results: list[dict[str, Any]]) -> str:
    good = [r for r in results if r["carried"]]
    refused = [
        f"{r['ber']:.1%}" if r["ber"] is not None else "?" for r in results if not r["carried"]
    ]
    cells = [name, f"{len(good)}/{len(results)}"]
    if good:
        cells += [
            str(sum(r["reinforced"] for r in good)),
            f"{max(r['ber'] for r in good):.1%}",
            f"{max(r['mrms'] for r in good):.4%}",
            f"{max(r['hausdorff'] for r in good):.3%}",
            f"{sum(r['detected'] for r in good)}/{len(good)}",
            str(sum(r["wrong_key"] for r in good)),
        ]
    else:
        cells += ["", "", "", "", "", ""]
    cells.append(", ".join(refused))
    return "| " + " | ".join(cells) + " |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_run_options(parser)
    parser.add_argument("--logo", action="store_true", help="the 32×32 logo instead of an id")
    parser.add_argument("--keys", type=int, default=6, help="keys per mesh (6)")
    args = parser.parse_args()
    names = run_names(parser, args)
    if not 1 <= args.keys <= 1000:
        parser.error(f"--keys must be 1..1000, got {args.keys}")
    keys = [f"check-keys-{i}" for i in range(args.keys)]
    jobs = [(name, key) for name in names for key in keys]
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.jobs) as pool:
        done = list(
            pool.map(_one, [n for n, _ in jobs], [k for _, k in jobs], [args.logo] * len(jobs))
        )
    lines = [
        "| mesh | carried | reinforced | largest read-back error | MRMS ≤ | Hausdorff ≤ "
        "| verify detects | wrong key detects | refused (read-back error) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for i, name in enumerate(names):
        lines.append(_row(name, done[i * len(keys) : (i + 1) * len(keys)]))
    payload = "the 32×32 logo" if args.logo else "a 64-bit id (each key's own)"
    text = "\n".join(lines) + (
        f"\n\n({time.perf_counter() - t0:.0f} s, {payload}, {len(keys)} keys a mesh, FPR 1e-6)\n"
    )
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
