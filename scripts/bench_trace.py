"""Cost of ``trace`` against a large registry, against one informed read of the right asset.

The registry holds the development meshes (two marked copies each) and ``--assets`` in all:
the others are made from the development meshes by random smooth deformations (an anisotropic
scale and a bend, from SHA-256 of their index), each with its own shape descriptor, reference
(the deformed reference points, anchors and their normals), probe and one copy: about a hundred
near-duplicates of each development mesh, some within a few per cent of it.  For each mesh, its
first copy is moved by a random similarity, then simplified to 50 % (``--received simplify``),
Loop-subdivided (``loop``), remeshed isotropically (``isotropic``: MeshLab, 3 iterations) or
cropped by 30 % (``crop``: the case the shape descriptor ranks worst; ``crop10`` and
``crop50``: 10 and 50 %); then (a) traced against a registry of its own asset alone (one
informed read: descriptor, pose, offsets, the copies' tests), (b) traced against the full
registry; median of ``--repeat`` runs each, whole ``Tracer(...).trace(...)`` calls.

    python scripts/bench_trace.py [--assets 1000] [--meshes spot igea ...] [--repeat 3]
        [--received simplify loop isotropic crop crop10 crop50] [--seeds 1 2 3] [--out FILE]
        [--reuse DIR]

``--reuse DIR``: the registry and marked copies ``scripts/null_informed.py`` or an earlier run
built (``DIR/registry.db``, ``DIR/<mesh>.npy``), instead of embedding again; the full
registry is kept as ``DIR/big-<assets>.db`` and, when there, copied instead of filled again
(delete it after a change to what embed records).
"""

from __future__ import annotations

import argparse
import hashlib
import multiprocessing
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from check_informed import KEY, MAX_FACES, embed_mesh  # type: ignore[import-not-found]
from check_keep import DEV, MESHES  # type: ignore[import-not-found]

from meshwm.apps.registry import AssetEntry, CopyEntry, Registry
from meshwm.attacks import apply_attack
from meshwm.mesh.io import read_mesh
from meshwm.readers.descriptor import CROP_REFERENCE, make_crops
from meshwm.readers.informed import REFERENCE_SIZE, Reference, seal_signature
from meshwm.readers.probe import PROBE, make_probe
from meshwm.readers.registration import shape_descriptor
from meshwm.watermark.trace import Tracer

#: What happens to the copy before it is traced: ``--received``.
RECEIVED: dict[str, list[tuple[str, dict]]] = {
    "simplify": [("similarity", {"seed": 11}), ("simplify", {"seed": 1, "keep_fraction": 0.5})],
    "loop": [("similarity", {"seed": 11}), ("subdivide_loop", {})],
    "isotropic": [("similarity", {"seed": 11}), ("remesh_isotropic", {"iterations": 3})],
    "crop": [("similarity", {"seed": 11}), ("crop", {"seed": 1, "fraction": 0.3})],
    "crop10": [("similarity", {"seed": 11}), ("crop", {"seed": 1, "fraction": 0.1})],
    "crop50": [("similarity", {"seed": 11}), ("crop", {"seed": 1, "fraction": 0.5})],
}


def _uniform(*parts: object, count: int) -> np.ndarray:
    digest = hashlib.sha256("/".join(map(str, parts)).encode()).digest()
    return np.frombuffer(digest[: 8 * count], dtype="<u8") / 2.0**64


def _deform(x: np.ndarray, k: int, centre: np.ndarray, size: float) -> np.ndarray:
    a = 0.6 + 0.8 * _uniform("scale", k, count=3)
    bend = (_uniform("bend", k, count=1)[0] - 0.5) * 0.6
    y = (x - centre) * a
    y[:, 2] += bend * (y[:, 0] / size) ** 2 * size
    return y + centre


def _deform_normals(
    x: np.ndarray, normals: np.ndarray, k: int, centre: np.ndarray, size: float
) -> np.ndarray:
    """The normals of :func:`_deform`'s surface at the deformed ``x``: the inverse transpose
    of its Jacobian applied to ``normals``, unit length."""
    a = 0.6 + 0.8 * _uniform("scale", k, count=3)
    bend = (_uniform("bend", k, count=1)[0] - 0.5) * 0.6
    jac = np.zeros((len(x), 3, 3))
    jac[:, 0, 0], jac[:, 1, 1], jac[:, 2, 2] = a
    jac[:, 2, 0] = 2 * bend * a[0] ** 2 * (x[:, 0] - centre[0]) / size
    out = np.einsum("pji,pj->pi", np.linalg.inv(jac), normals)
    return out / np.maximum(np.linalg.norm(out, axis=1, keepdims=True), 1e-300)


def _decoy(task: tuple[int, np.ndarray, np.ndarray, Reference]) -> tuple[AssetEntry, CopyEntry]:
    """Decoy ``k``: the mesh and reference deformed, as an asset with one random copy."""
    k, v, f, ref = task
    centre, size = v.mean(axis=0), float(np.ptp(v, axis=0).max())
    moved = ref._replace(
        points=_deform(ref.points, k, centre, size),
        anchors=_deform(ref.anchors, k, centre, size),
        anchor_normals=_deform_normals(ref.anchors, ref.anchor_normals, k, centre, size),
    )
    sig = np.sin(np.arange(len(ref.cells)) * (k + 1) * 0.37)
    asset = AssetEntry(
        name=f"decoy-{k}",
        input_sha256=hashlib.sha256(f"decoy/{k}".encode()).hexdigest(),
        vertices=len(v),
        faces=len(f),
        descriptor=shape_descriptor(_deform(v, k, centre, size), f),
        references={
            REFERENCE_SIZE: moved.to_bytes(),
            PROBE: make_probe(moved.anchors),
            CROP_REFERENCE: make_crops(moved.anchors, moved.anchor_normals),
        },
    )
    copy = CopyEntry(
        payload=f"{k:016x}",
        recipient=None,
        output_name=f"decoy-{k}.ply",
        output_sha256="0" * 64,
        n=128,
        signature=seal_signature(sig, moved, key=KEY),
    )
    return asset, copy


def decoys(registry: Registry, count: int) -> None:
    """``count`` deformed development meshes as assets, one random copy each (made in two
    processes, recorded in order)."""
    meshes = []
    for m in DEV:  # a coarse copy is enough for a decoy's descriptor, and quicker
        v, f = read_mesh(MESHES / f"{m}.ply")
        if len(f) > 6000:
            v, f = apply_attack("simplify", v, f, keep_fraction=6000 / len(f))
        meshes.append((v, f))
    refs = {a.name: a.id for a in registry.assets()}
    bases = [Reference.from_bytes(registry.references(refs[m])[REFERENCE_SIZE]) for m in DEV]
    tasks = [(k, *meshes[k % len(DEV)], bases[k % len(DEV)]) for k in range(count)]
    with multiprocessing.Pool(2) as pool:
        for asset, copy in pool.imap(_decoy, tasks, chunksize=8):
            registry.record_embed(asset, copy)


def copy_asset(source: Registry, target: Registry, name: str) -> None:
    """The asset called ``name`` with its references and copies, into ``target``."""
    (asset,) = [a for a in source.assets() if a.name == name]
    ids, table = source.descriptors()
    descriptor = table[int(np.flatnonzero(ids == asset.id)[0])]
    references = dict(source.references(asset.id))
    if PROBE not in references or CROP_REFERENCE not in references:
        # recorded by an earlier meshwm: what embed records now
        ref = Reference.from_bytes(references[REFERENCE_SIZE])
        references.setdefault(PROBE, make_probe(ref.anchors))
        references.setdefault(CROP_REFERENCE, make_crops(ref.anchors, ref.anchor_normals))
    entry = AssetEntry(
        name=asset.name,
        input_sha256=asset.input_sha256,
        vertices=asset.vertices,
        faces=asset.faces,
        descriptor=descriptor,
        references=references,
    )
    for c in source.copies(asset.id):
        target.record_embed(
            entry,
            CopyEntry(
                payload=c.payload,
                recipient=c.recipient,
                output_name=c.output_name,
                output_sha256=c.output_sha256,
                n=c.n,
                params=c.params,
                signature=c.signature,
            ),
        )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--assets", type=int, default=1000)
    parser.add_argument("--meshes", nargs="+", default=["spot", "fandisk", "kitten", "igea"])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--received", nargs="+", choices=sorted(RECEIVED), default=list(RECEIVED))
    parser.add_argument(
        "--seeds",
        nargs="+",
        type=int,
        default=[1],
        help="seeds of the simplification, crop plane (the step after the similarity)",
    )
    parser.add_argument("--out", type=Path)
    parser.add_argument("--reuse", type=Path, help="a folder an earlier run built")
    args = parser.parse_args()
    lines = [
        "| mesh | received | one informed read s | trace, "
        f"{args.assets} assets s | ratio | found | candidates tried | looks |",
        "|---|---|---:|---:|---:|---|---:|---:|",
    ]
    with tempfile.TemporaryDirectory() as scratch:
        big = os.path.join(scratch, "big.db")
        if args.reuse:
            with Registry.open(args.reuse / "registry.db", create=False) as source:
                with Registry.open(big) as target:
                    for m in DEV:
                        copy_asset(source, target, m)
            for m in DEV:
                shutil.copy(args.reuse / f"{m}.npy", Path(scratch) / f"{m}.npy")
        else:
            for m in DEV:
                embed_mesh((m, big, scratch))
        t0 = time.perf_counter()
        kept = args.reuse / f"big-{args.assets}.db" if args.reuse else None
        if kept is not None and kept.exists():
            shutil.copy(kept, big)
            fill_note = f"copied from {kept.name}, filled by an earlier run"
        else:
            with Registry.open(big) as registry:
                decoys(registry, args.assets - len(DEV))
            fill_note = f"filled in {time.perf_counter() - t0:.0f} s"
            if kept is not None:
                shutil.copy(big, kept)
        with Registry.open(big, create=False) as registry:
            held = len(registry.assets())
        for m in args.meshes:
            one = os.path.join(scratch, f"one-{m}.db")
            with Registry.open(big, create=False) as source, Registry.open(one) as target:
                copy_asset(source, target, m)
            _, faces = read_mesh(MESHES / f"{m}.ply")
            marked = np.load(Path(scratch) / f"{m}.npy")
            # The seeds of the second step where it takes one (Loop subdivision and remeshing
            # take none: run once, seed None).
            cases = [
                (received, seed)
                for received in args.received
                for seed in (args.seeds if "seed" in RECEIVED[received][1][1] else [None])
            ]
            for received, seed in cases:
                v, f = marked, faces
                for step, (name, options) in enumerate(RECEIVED[received]):
                    if step == 1 and seed is not None:
                        options = {**options, "seed": seed}
                    v, f = apply_attack(name, v, f, **options)
                times: dict[str, list[float]] = {"one": [], "big": []}
                found = None
                for _ in range(args.repeat):
                    for label, db in (("one", one), ("big", big)):
                        with Registry.open(db, create=False) as registry:
                            t = time.perf_counter()
                            traced = Tracer(v, f, registry, max_faces=MAX_FACES).trace(key=KEY)
                            times[label].append(time.perf_counter() - t)
                        if label == "big":
                            found = traced
                a, b = float(np.median(times["one"])), float(np.median(times["big"]))
                assert found is not None
                ok = found.detected and found.report.get("asset") == m
                looks = found.report["candidates"]
                label = received
                if seed is not None and len(args.seeds) > 1:
                    label = f"{received} {seed}"
                lines.append(
                    f"| {m} | {label} | {a:.2f} | {b:.2f} | {b / a:.2f} | "
                    f"{'yes' if ok else 'NO'} | {len({c['asset_id'] for c in looks})} | "
                    f"{len(looks)} |"
                )
    lines.append("")
    for received in args.received:
        steps = ", then ".join(f"{n} {o}" for n, o in RECEIVED[received])
        lines.append(f"received {received}: {steps}")
    if len(args.seeds) > 1:
        lines.append(f"the second step's seed: {' '.join(map(str, args.seeds))} (after the name)")
    lines.append(f"median of {args.repeat} runs each")
    lines.append(f"registry: {held} assets, {fill_note}")
    text = "\n".join(lines)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
