"""Null study of issue #5: how often does ``meshwm verify`` say "present" when it should not?

``verify`` decides "present" when the binomial p-value of the bit agreement is below
``fpr / hypotheses`` (Bonferroni over every grid seed, orientation, N, gain and decoder
candidate tried; :func:`meshwm.detect.decide`).  That is a false-positive rate of at
most ``fpr`` only if, on a mesh that does not carry the mark, the agreement counts really are
Binomial(n, 1/2).  This script measures it on the development meshes, with the same decoder
``verify`` runs (:class:`meshwm.watermark.Decoder`):

- **raw**: every development mesh as it is (not a meshwm grid), with random keys;
- **remeshed**: every development mesh remeshed to an unmarked N = 256 geometry image (the
  same remesh ``embed`` does, without the mark), with ``--keys`` random keys each, checked for
  the default 32×32 logo (1024 bits) and for a random 8-byte id (256 code bits), and for any
  id at all (``--any-id``: a Reed-Solomon decode whose CRC-32 matches);
- **right key on unmarked meshes**: the key the marked copies use, on the unmarked remeshed
  meshes as they are and after noise, Laplacian smoothing, quantisation, a crop, a
  similarity and a re-ordering;
- **wrong key on marked meshes**: each mesh marked with the logo and with an id, then read
  with ``--wrong-keys`` other keys.

The grid is read and the key-independent part of the decoder is prepared once per mesh
(``Decoder``); each key then runs the whole keyed decoder (gain search, every unsmoothing
candidate), exactly as ``verify`` would.  Prints the tables, writes ``null.png`` (empirical
agreement counts next to the binomial, and the p-values against the uniform), ``null.json``
and ``null.md`` to ``--out``.  Exit 1 if anything is detected.

    python scripts/null_study.py                      # 10 meshes x 1000 keys, ~25 min
    python scripts/null_study.py --keys 20 --wrong-keys 5 --out /tmp/null   # a quick look
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_MESHES = REPO_ROOT.parent / "shared" / "meshes"

try:
    import meshwm  # noqa: F401
except ImportError:
    sys.path.insert(0, str(REPO_ROOT))

from _machine import machine_info  # noqa: E402

from meshwm.attacks import smoothing, transforms  # noqa: E402
from meshwm.detect import decide, detection_p_value  # noqa: E402
from meshwm.errors import GridError  # noqa: E402
from meshwm.gim.remesh import mesh_to_geometry_image  # noqa: E402
from meshwm.gim.to_mesh import geometry_image_to_mesh  # noqa: E402
from meshwm.mesh.io import read_mesh  # noqa: E402
from meshwm.message.mark import default_mark  # noqa: E402
from meshwm.message.payload import PAYLOAD_BITS  # noqa: E402
from meshwm.watermark import Decoder, embed  # noqa: E402

RIGHT_KEY = "meshwm-null-study-right-key"
#: Hypotheses of a complete unmarked grid read with every decoder candidate (192 grid seeds x
#: orientations x sizes, 234 gains, 13 candidates): for --restat of a run that did not store it.
HYPOTHESES_UNMARKED = 192 * 234 * 13
MARK_BITS = 32 * 32


def study_key(seed: str, *parts: object) -> str:
    """A random-looking key, derived (hashlib) so the study is reproducible."""
    text = "/".join(str(p) for p in (seed, *parts))
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def study_id(seed: str, *parts: object) -> bytes:
    return hashlib.sha256(("id/" + "/".join(str(p) for p in (seed, *parts))).encode()).digest()[:8]


def _agree(report: dict[str, Any], bits: int) -> int:
    return round((1.0 - report["ber"]) * bits)


def _check_mark(reader: Decoder, key: str, logo: np.ndarray, fpr: float) -> dict[str, Any]:
    r = reader.extract(key=key, mark_size=logo.shape[0], expected=logo).report
    return {
        "agree": _agree(r, MARK_BITS),
        "p": r["p_value"],
        "hyp": r["hypotheses"],
        "detected": decide(r, fpr=fpr).detected,
    }


def _check_id(reader: Decoder, key: str, ident: bytes, fpr: float) -> dict[str, Any]:
    got = reader.extract_id(key=key, expected=ident)
    r = got.report
    return {
        "agree": _agree(r, PAYLOAD_BITS),
        "p": r["p_value"],
        "hyp": r["hypotheses"],
        "detected": decide(r, fpr=fpr, found_id=got.id, expected_id=ident.hex()).detected,
        "any_id": got.id is not None,
    }


def _geometry_image(path: Path, size: int, cache: Path | None):
    v, f = read_mesh(path)
    if cache is not None:
        cache.mkdir(parents=True, exist_ok=True)
        stored = cache / f"{path.stem}-n{size}.npz"
        if stored.exists():
            with np.load(stored) as z:
                from meshwm.gim.remesh import GeometryImage

                return v, f, GeometryImage(z["gim"], z["weld"], z["ov"], z["of"], {})
    gi = mesh_to_geometry_image(v, f, size=size)
    if cache is not None:
        tmp = cache / f"{path.stem}-n{size}.tmp.npz"
        np.savez(tmp, gim=gi.gim, weld=gi.weld, ov=gi.other_vertices, of=gi.other_faces)
        tmp.replace(stored)
    return v, f, gi


def _variants(v: np.ndarray, f: np.ndarray) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Unmarked meshes as a pipeline might hand them over."""
    out = [("as written", v, f)]
    for name, fn, kw in (
        ("noise 0.1 %", transforms.noise, {"amplitude": 0.001}),
        ("Laplacian x10", smoothing.laplacian, {"iterations": 10}),
        ("quantise 10 bits", transforms.quantize, {"bits": 10}),
        ("crop 10 %", transforms.crop, {"fraction": 0.1}),
        ("similarity", transforms.similarity, {}),
        ("reorder", transforms.reorder, {}),
    ):
        m = fn(v, f, seed=1, **kw)
        out.append((name, m[0], m[1]))
    return out


def run_mesh(task: dict[str, Any]) -> dict[str, Any]:
    """Every trial on one development mesh (runs in a worker process)."""
    path, keys, wrong, seed, fpr = (
        Path(task["path"]),
        task["keys"],
        task["wrong"],
        task["seed"],
        task["fpr"],
    )
    cache = Path(task["cache"]) if task["cache"] else None
    name = path.stem
    logo = default_mark()
    t0 = time.perf_counter()
    out: dict[str, Any] = {"mesh": name}
    v, f, gi = _geometry_image(path, task["size"], cache)

    # Raw: not a grid.  The grid is read before the key is used, so one read decides for
    # every key: the raw meshes are read once each and reported apart from the keyed trials.
    raw: dict[str, Any] = {"grid": False, "detected": 0, "reason": None}
    try:
        reader = Decoder(v, f)
        raw["grid"] = True
        for i in range(task["raw_keys"]):
            c = _check_mark(reader, study_key(seed, "raw", name, i), logo, fpr)
            raw["detected"] += int(c["detected"])
    except GridError as exc:
        raw["reason"] = str(exc).split(" (")[0]
    out["raw"] = raw

    uv, uf = geometry_image_to_mesh(
        gi.gim, gi.weld, other_vertices=gi.other_vertices, other_faces=gi.other_faces
    )
    reader = Decoder(uv, uf)
    marks, ids = [], []
    for i in range(keys):
        # Separate keys for the two checks: with one key their layouts share the dither, so
        # the two decodes would not be independent trials.
        marks.append(_check_mark(reader, study_key(seed, "random", name, i), logo, fpr))
        key = study_key(seed, "random-id", name, i)
        ids.append(_check_id(reader, key, study_id(seed, name, i), fpr))
    out["random_mark"] = marks
    out["random_id"] = ids

    right = []
    for label, vv, ff in _variants(uv, uf):
        try:
            r = Decoder(vv, ff)
        except GridError:
            right.append({"variant": label, "grid": False})
            continue
        right.append(
            {
                "variant": label,
                "grid": True,
                "mark": _check_mark(r, RIGHT_KEY, logo, fpr),
                "id": _check_id(r, RIGHT_KEY, study_id(seed, "right", name), fpr),
            }
        )
    out["right_key"] = right

    # Marked copies read with other keys (the right key must find them, as a sanity check).
    ident = study_id(seed, "marked", name)
    marked = embed(v, f, key=RIGHT_KEY, geometry_image=gi, distances=False, grid=True)
    marked_id = embed(
        v, f, key=RIGHT_KEY, geometry_image=gi, distances=False, ident=ident, grid=True
    )
    rm = Decoder(marked.vertices, marked.faces)
    ri = Decoder(marked_id.vertices, marked_id.faces)
    out["right_key_on_marked"] = {
        "mark": _check_mark(rm, RIGHT_KEY, logo, fpr),
        "id": _check_id(ri, RIGHT_KEY, ident, fpr),
    }
    wm, wi = [], []
    for j in range(wrong):
        key = study_key(seed, "wrong", name, j)
        wm.append(_check_mark(rm, key, logo, fpr))
        wi.append(_check_id(ri, key, ident, fpr))
    out["wrong_mark"] = wm
    out["wrong_id"] = wi
    out["seconds"] = time.perf_counter() - t0
    return out


# --------------------------------------------------------------------------------------------
# statistics and output


def binomial_pmf(n: int) -> np.ndarray:
    k = np.arange(n + 1)
    logs = np.array(
        [math.lgamma(n + 1) - math.lgamma(i + 1) - math.lgamma(n - i + 1) for i in k]
    ) - n * math.log(2.0)
    return np.exp(logs)


def chi_square(agree: np.ndarray, n: int, bins: int = 12) -> tuple[float, int, float]:
    """Chi-square goodness of fit of agreement counts to Binomial(n, 1/2), equiprobable bins."""
    from scipy import stats

    pmf = binomial_pmf(n)
    cdf = np.cumsum(pmf)
    edges = [int(np.searchsorted(cdf, q)) for q in np.linspace(0, 1, bins + 1)[1:-1]]
    edges = sorted(set(edges))
    idx = np.searchsorted(edges, agree, side="left")  # bin k holds edges[k-1]+1 .. edges[k]
    observed = np.bincount(idx, minlength=len(edges) + 1)
    probs = np.array(
        [
            pmf[lo:hi].sum()
            for lo, hi in zip(
                [0, *[e + 1 for e in edges]], [*[e + 1 for e in edges], n + 1], strict=True
            )
        ]
    )
    expected = probs * len(agree)
    stat = float(np.sum((observed - expected) ** 2 / expected))
    dof = len(expected) - 1
    return stat, dof, float(stats.chi2.sf(stat, dof))


def agreements(results: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    """Agreement counts of every trial, per field, from the per-mesh results."""
    fields = ("random_mark", "random_id", "wrong_mark", "wrong_id")
    return {f: np.array([t["agree"] for r in results for t in r[f]]) for f in fields}


def statistics_lines(agree: dict[str, np.ndarray]) -> tuple[list[str], list[dict[str, Any]]]:
    lines, rows = [], []
    for field, n in (
        ("random_mark", MARK_BITS),
        ("random_id", PAYLOAD_BITS),
        ("wrong_mark", MARK_BITS),
        ("wrong_id", PAYLOAD_BITS),
    ):
        a = agree[field]
        stat, dof, p = chi_square(a, n)
        rows.append(
            {
                "field": field,
                "trials": len(a),
                "mean": float(a.mean()),
                "var": float(a.var()),
                "chi2": stat,
                "dof": dof,
                "p": p,
            }
        )
        lines.append(
            f"- {field}: {len(a)} trials, agreement mean {a.mean():.2f} (binomial {n / 2:.0f}), "
            f"variance {a.var():.1f} (binomial {n / 4:.0f}), chi-square {stat:.1f} on {dof} dof "
            f"(12 equiprobable bins of the binomial), p = {p:.3f}"
        )
    return lines, rows


def plot(agree: dict[str, np.ndarray], hypotheses: int, fpr: float, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    panels = [
        ("random_mark", "wrong_mark", MARK_BITS, "unmarked, random keys: 32×32 logo"),
        ("random_id", "wrong_id", PAYLOAD_BITS, "unmarked, random keys: 8-byte id"),
    ]
    for ax, (field, wrong_field, n, title) in zip(axes[:2], panels, strict=True):
        a, wrong = agree[field], agree[wrong_field]
        lo, hi = int(n / 2 - 5 * math.sqrt(n) / 2), int(n / 2 + 5 * math.sqrt(n) / 2)
        bins = np.arange(lo, hi + 2) - 0.5
        ax.hist(a, bins=bins, density=True, alpha=0.55, label=f"unmarked ({len(a)})")
        ax.hist(
            wrong,
            bins=bins,
            density=True,
            histtype="step",
            lw=1.5,
            label=f"marked, wrong key ({len(wrong)})",
        )
        k = np.arange(lo, hi + 1)
        ax.plot(k, binomial_pmf(n)[k], "k-", lw=1.2, label=f"Binomial({n}, 1/2)")
        ax.set_title(title)
        ax.set_xlabel("bits agreeing with the expected payload")
        ax.set_ylabel("probability")
        ax.legend(fontsize=8)
    ax = axes[2]
    for field, n, label in (("random_mark", MARK_BITS, "logo"), ("random_id", PAYLOAD_BITS, "id")):
        p = np.sort([detection_p_value(int(x), n) for x in agree[field]])
        u = (np.arange(1, len(p) + 1) - 0.5) / len(p)
        ax.loglog(u, p, ".", ms=2, label=f"{label} p-values ({len(p)})")
    ax.loglog([1e-5, 1], [1e-5, 1], "k-", lw=0.8, label="uniform")
    ax.axhline(
        fpr / hypotheses,
        color="r",
        lw=0.8,
        ls="--",
        label=f"verify's threshold {fpr:g}/{hypotheses}",
    )
    ax.set_xlabel("expected quantile (uniform)")
    ax.set_ylabel("empirical p-value (binomial tail)")
    ax.set_title("p-values on unmarked meshes")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def restat(path: Path) -> int:
    """Recompute the statistics lines of ``null.md`` and redraw ``null.png`` from a saved
    ``null.json`` (its agreement histograms hold every trial's score)."""
    data = json.loads(path.read_text(encoding="utf-8"))
    agree = {
        field: np.concatenate(
            [
                np.repeat(np.arange(len(h)), h)
                for h in (m[field]["agree_histogram"] for m in data["meshes"])
            ]
        )
        for field in ("random_mark", "random_id", "wrong_mark", "wrong_id")
    }
    lines, rows = statistics_lines(agree)
    md = path.with_name("null.md")
    text = md.read_text(encoding="utf-8").splitlines()
    fields = tuple(f"- {r['field']}:" for r in rows)
    text = [ln for ln in text if not ln.startswith(fields)]
    at = next(i for i, ln in enumerate(text) if ln.startswith("**Unmarked:"))
    text[at:at] = [*lines, ""]
    md.write_text("\n".join(text) + "\n", encoding="utf-8")
    data["statistics"] = rows
    path.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    plot(
        agree,
        data.get("hypotheses_min", HYPOTHESES_UNMARKED),
        data.get("fpr", 1e-6),
        path.with_name("null.png"),
    )
    print("\n".join(lines))
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("meshes", nargs="*", help="mesh files (default: every file in --folder)")
    ap.add_argument("--folder", type=Path, default=DEFAULT_MESHES)
    ap.add_argument("--keys", type=int, default=1000, help="random keys per remeshed mesh")
    ap.add_argument("--raw-keys", type=int, default=100, help="random keys per raw mesh")
    ap.add_argument("--wrong-keys", type=int, default=100, help="wrong keys per marked mesh")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--fpr", type=float, default=1e-6)
    ap.add_argument("--seed", default="meshwm-null-study-v1")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument(
        "--cache",
        type=Path,
        default=Path("/tmp/meshwm-null-study"),
        help="geometry images are kept here between runs ('' for none)",
    )
    ap.add_argument("--out", type=Path, default=REPO_ROOT / "docs" / "null")
    ap.add_argument(
        "--restat",
        type=Path,
        metavar="NULL_JSON",
        help="only recompute the statistics and the plot of a saved run",
    )
    args = ap.parse_args(argv)
    if args.restat is not None:
        return restat(args.restat)
    paths = [Path(p) for p in args.meshes] or sorted(args.folder.glob("*.ply"))
    tasks = [
        {
            "path": str(p),
            "keys": args.keys,
            "raw_keys": args.raw_keys,
            "wrong": args.wrong_keys,
            "seed": args.seed,
            "fpr": args.fpr,
            "size": args.size,
            "cache": str(args.cache) if str(args.cache) else "",
        }
        for p in paths
    ]
    t0 = time.perf_counter()
    if args.jobs > 1:
        with ProcessPoolExecutor(max_workers=args.jobs) as pool:
            results = list(pool.map(run_mesh, tasks))
    else:
        results = [run_mesh(t) for t in tasks]
    wall = time.perf_counter() - t0

    lines = []
    say = lines.append
    say(f"# Null study ({len(paths)} meshes, N = {args.size}, fpr {args.fpr:g})\n")
    say(
        "| mesh | raw mesh | random keys | logo detected | id detected | any id | "
        "min p (logo) | min p (id) | wrong keys | wrong detected | wrong any id | right key "
        "on marked | seconds |"
    )
    say("|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|---|--:|")
    totals = {
        "raw": 0,
        "raw_det": 0,
        "rand": 0,
        "rand_det": 0,
        "any": 0,
        "wrong": 0,
        "wrong_det": 0,
        "wrong_any": 0,
        "right": 0,
        "right_det": 0,
    }
    for r in results:
        rm, ri = r["random_mark"], r["random_id"]
        wm, wi = r["wrong_mark"], r["wrong_id"]
        det_m = sum(t["detected"] for t in rm)
        det_i = sum(t["detected"] for t in ri)
        anyid = sum(t["any_id"] for t in ri)
        wdet = sum(t["detected"] for t in wm) + sum(t["detected"] for t in wi)
        wany = sum(t["any_id"] for t in wi)
        ok = r["right_key_on_marked"]
        sanity = "logo+id" if ok["mark"]["detected"] and ok["id"]["detected"] else "MISSED"
        rawcell = "no grid" if not r["raw"]["grid"] else f"grid, {r['raw']['detected']} det."
        say(
            f"| {r['mesh']} | {rawcell} | {len(rm)} | "
            f"{det_m} | {det_i} | {anyid} | {min(t['p'] for t in rm):.3g} | "
            f"{min(t['p'] for t in ri):.3g} | {len(wm)} | {wdet} | {wany} | {sanity} | "
            f"{r['seconds']:.0f} |"
        )
        totals["raw"] += 1
        totals["raw_det"] += r["raw"]["detected"] + int(r["raw"]["grid"])
        totals["wrong_any"] += wany
        totals["rand"] += len(rm) + len(ri)
        totals["rand_det"] += det_m + det_i
        totals["any"] += anyid
        totals["wrong"] += len(wm) + len(wi)
        totals["wrong_det"] += wdet
        for v in r["right_key"]:
            if v["grid"]:
                totals["right"] += 2
                totals["right_det"] += int(v["mark"]["detected"]) + int(v["id"]["detected"])
    say("")
    say("Right key on unmarked meshes (logo p / id p; every variant of every mesh):\n")
    say("| mesh | " + " | ".join(v["variant"] for v in results[0]["right_key"]) + " |")
    say("|---|" + "---|" * len(results[0]["right_key"]))
    for r in results:
        cells = [
            f"{v['mark']['p']:.2g} / {v['id']['p']:.2g}"
            + (" DETECTED" if v["mark"]["detected"] or v["id"]["detected"] else "")
            if v["grid"]
            else "no grid"
            for v in r["right_key"]
        ]
        say(f"| {r['mesh']} | " + " | ".join(cells) + " |")
    say("")
    agree = agreements(results)
    stat_lines, stats_rows = statistics_lines(agree)
    lines += stat_lines
    trials = totals["rand"] + totals["right"]
    detections = totals["rand_det"] + totals["right_det"]
    say("")
    say(
        f"**Unmarked: {detections} detections in {trials} keyed trials** (remeshed with "
        f"random keys: {totals['rand']}, logo and id checks; right key: {totals['right']}); "
        f"any-id decodes: {totals['any']}.  Raw meshes: {totals['raw']} read, "
        f"{totals['raw_det']} with a grid or a detection (the grid is read before any key "
        f"is used, so each raw read stands for every key).  **Wrong key on marked: "
        f"{totals['wrong_det']} detections in {totals['wrong']} trials** (any-id decodes: "
        f"{totals['wrong_any']}).  Wall time {wall:.0f} s with {args.jobs} jobs."
    )
    text = "\n".join(lines)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "null.md").write_text(text + "\n", encoding="utf-8")
    hyp_min = min(t["hyp"] for r in results for t in r["random_mark"])
    plot(agree, hyp_min, args.fpr, args.out / "null.png")
    summary = {
        "command": " ".join(sys.argv),
        "machine": machine_info("numpy", "scipy", "trimesh", "PyWavelets", "reedsolo"),
        "totals": totals,
        "statistics": stats_rows,
        "fpr": args.fpr,
        "hypotheses_min": hyp_min,
        "wall_seconds": wall,
        "meshes": [
            {
                "mesh": r["mesh"],
                "seconds": r["seconds"],
                "raw": r["raw"],
                "right_key": r["right_key"],
                "right_key_on_marked": r["right_key_on_marked"],
                **{
                    field: {
                        "trials": len(r[field]),
                        "detected": int(sum(t["detected"] for t in r[field])),
                        "min_p": float(min(t["p"] for t in r[field])),
                        "agree_histogram": np.bincount([t["agree"] for t in r[field]]).tolist(),
                    }
                    for field in ("random_mark", "random_id", "wrong_mark", "wrong_id")
                },
            }
            for r in results
        ],
    }
    (args.out / "null.json").write_text(json.dumps(summary, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {args.out / 'null.md'}, null.png, null.json")
    bad = detections + totals["raw_det"] + totals["wrong_det"] + totals["any"]
    return 1 if bad + totals["wrong_any"] else 0


if __name__ == "__main__":
    sys.exit(main())
