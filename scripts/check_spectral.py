"""How far MeshLab's Laplacian moves a mesh's connectivity-spectral coefficients.

A record for docs/keep.md ("What it does not survive"): could a carrier in another basis
read cow after MeshLab's Laplacian (3 steps), which the surface and radial carriers do not?
The basis is the one a blind reader re-derives exactly when the connectivity is kept: the
eigenvectors of the Kirchhoff matrix ``D - A`` (R. Ohbuchi, A. Mukaiyama and S. Takahashi, "A
frequency-domain approach to watermarking 3D shapes", Computer Graphics Forum 21(3), 2002).
Per band of modes it prints the median size of the xyz coefficient vector, the median
factor the attack scales it by, how far the attack moves it and turns it, and what a mark
could: the whole distortion budget (``--budget``, RMS vertex displacement over the
bounding-box diagonal, all of it spent here) spread over ``--slots`` coefficient vectors.

With ``--quantised`` it marks the mesh in that basis instead and reads it after the attack,
as generously as a reader could: spread-transform dither modulation (Chen and Wornell's
quantisation index modulation, each bit one keyed direction of the lowest ``K`` modes' 3K
coefficients, the whole budget spent there), then the attack, then each of the decoder's
inversions of MeshLab's steps (:func:`meshwm.mesh.unsmooth.cotangent_unsmoothed`) and the
attacked mesh as it is, the one with the fewest wrong bits kept (no reader knows which).  The
basis is exact for the reader (the connectivity is kept), the host's interference is
quantised away, and the bits are as few as ``--bits``: what is left is how far the
inversion lands from the marked mesh within those modes.

    python scripts/check_spectral.py [--meshes cow spot] [--modes 400] [--steps 3]
    python scripts/check_spectral.py --quantised [--bits 16 32 64] [--ks 10 20 40 80]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
import trimesh

from meshwm.attacks.smoothing import meshlab_laplacian
from meshwm.mesh.unsmooth import cotangent_unsmoothed

MESHES = Path(__file__).resolve().parents[1].parent / "shared" / "meshes"
BANDS = ((1, 10), (10, 50), (50, 100), (100, 200), (200, 300), (300, 400))


def kirchhoff_modes(n: int, faces: np.ndarray, count: int) -> np.ndarray:
    """The ``count + 1`` lowest eigenvectors (columns) of the mesh's Kirchhoff matrix."""
    e = np.sort(np.vstack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    e = np.unique(e, axis=0)
    a = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    a = (a + a.T).tocsr()
    lap = sp.diags(np.asarray(a.sum(axis=1)).ravel()) - a
    return sl.eigh(lap.toarray(), subset_by_index=[0, count])[1]


def report(path: Path, *, modes: int, steps: int, budget: float, slots: int) -> None:
    """Print the per-band figures of one mesh."""
    mesh = trimesh.load(path, process=False)
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    if not modes < len(v):
        raise ValueError(f"{modes} modes asked of a mesh of {len(v)} vertices")
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    u = kirchhoff_modes(len(v), f, modes)
    moved, _ = meshlab_laplacian(v, f, iterations=steps)
    c = u.T @ (v - v.mean(axis=0))
    ca = u.T @ (moved - moved.mean(axis=0))
    size, size_a = np.linalg.norm(c, axis=1), np.linalg.norm(ca, axis=1)
    turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", c, ca) / (size * size_a), -1, 1)))
    shift = np.linalg.norm(ca - c, axis=1) / diag
    mark = np.sqrt(len(v) / slots) * budget  # one coefficient vector's share, over diag
    rms = np.sqrt(((moved - v) ** 2).sum(axis=1).mean()) / diag
    print(f"{path.stem}: {len(v)} vertices, the attack moves them {rms:.2e} RMS; mark {mark:.2e}")
    print("| modes | size | scaled by | moved | moved / mark | turned ° | mark turns ° |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for lo, hi in BANDS:
        s = slice(lo, min(hi, modes + 1))
        if s.start >= s.stop:
            break
        med = float(np.median(shift[s]))
        print(
            f"| {lo}-{hi} | {np.median(size[s]) / diag:.2e} | {np.median(size_a[s] / size[s]):.3f}"
            f" | {med:.2e} | {med / mark:.1f} | {np.median(turn[s]):.2f}"
            f" | {np.degrees(np.median(mark * diag / size[s])):.2f} |"
        )


def _on_lattice(p: np.ndarray, bits: np.ndarray, dither: np.ndarray, step: float) -> np.ndarray:
    """``p`` moved to the nearest point of each bit's lattice ``(bit / 2 + dither + Z) step``."""
    offset = (bits / 2.0 + dither) * step
    out: np.ndarray = np.round((p - offset) / step) * step + offset
    return out


def _read_bits(p: np.ndarray, dither: np.ndarray, step: float) -> np.ndarray:
    """The bit whose lattice is nearer each projection."""
    return (np.cos(2.0 * np.pi * (p / step - dither)) < 0).astype(np.int64)


class _Carrier:
    """``count`` bits in the lowest modes ``u``: keyed directions, dithers and the payload."""

    def __init__(self, u: np.ndarray, count: int, rng: np.random.Generator) -> None:
        self.u = u
        self.spread = np.linalg.qr(rng.standard_normal((3 * u.shape[1], count)))[0]
        self.payload = rng.integers(0, 2, count)
        self.dither = rng.random(count)

    def projections(self, x: np.ndarray) -> np.ndarray:
        out: np.ndarray = self.spread.T @ (self.u.T @ (x - x.mean(axis=0))).ravel()
        return out

    def move(self, v: np.ndarray, step: float) -> np.ndarray:
        """The vertex move that puts each of ``v``'s projections on its bit's lattice."""
        p = self.projections(v)
        change = self.spread @ (_on_lattice(p, self.payload, self.dither, step) - p)
        out: np.ndarray = self.u @ change.reshape(self.u.shape[1], 3)
        return out

    def ber(self, x: np.ndarray, step: float) -> float:
        return float(np.mean(_read_bits(self.projections(x), self.dither, step) != self.payload))


def quantised(path: Path, *, modes: list[int], bits: list[int], steps: int, budget: float) -> None:
    """Print the quantised-carrier table of one mesh (see the module notes)."""
    mesh = trimesh.load(path, process=False)
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    if not max(modes) < len(v):
        raise ValueError(f"{max(modes)} modes asked of a mesh of {len(v)} vertices")
    diag = float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    u_all = kirchhoff_modes(len(v), f, max(modes))
    rng = np.random.default_rng(2026)  # a stand-in key: nothing here is secret
    print(f"{path.stem}: {len(v)} vertices, the whole budget ({budget:.1e} RMS) in the modes")
    print("| modes K | bits | dof a bit | step / diag | BER as marked | BER after | read by |")
    print("|---:|---:|---:|---:|---:|---:|---|")
    for k in modes:
        for count in bits:
            if count > 3 * k:
                continue
            carrier = _Carrier(u_all[:, 1 : k + 1], count, rng)
            step = 10.0 * budget * diag
            for _ in range(30):  # the step whose move is the budget (RMS over the vertices)
                rms = float(np.sqrt((carrier.move(v, step) ** 2).sum(axis=1).mean())) / diag
                step *= budget / rms
            marked = v + carrier.move(v, step)
            attacked, _ = meshlab_laplacian(marked, f, iterations=steps)
            found = [("as received", attacked), *cotangent_unsmoothed(attacked, f)]
            best, label = min((carrier.ber(x, step), label) for label, x in found)
            print(
                f"| {k} | {count} | {3 * k / count:.1f} | {step / diag:.2e}"
                f" | {carrier.ber(marked, step):.3f} | {best:.3f} | {label} |"
            )


def main() -> None:
    """Parse the options and print one table per mesh."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--meshes", nargs="+", default=["cow", "spot"])
    ap.add_argument("--modes", type=int, default=400)
    ap.add_argument("--steps", type=int, default=3, help="MeshLab stepsmoothnum")
    ap.add_argument("--budget", type=float, default=2e-4, help="RMS move / diagonal")
    ap.add_argument("--slots", type=int, default=256, help="coefficient vectors, one a bit")
    ap.add_argument("--dir", type=Path, default=MESHES)
    ap.add_argument("--quantised", action="store_true", help="mark in the modes and read back")
    ap.add_argument("--bits", type=int, nargs="+", default=[16, 32, 64], help="with --quantised")
    ap.add_argument("--ks", type=int, nargs="+", default=[10, 20, 40, 80], help="with --quantised")
    a = ap.parse_args()
    if min(a.modes, a.slots, *a.bits, *a.ks) < 1 or not 1 <= a.steps <= 1000:
        ap.error("--modes, --slots, --bits and --ks must be >= 1, --steps in 1..1000")
    if not (np.isfinite(a.budget) and a.budget > 0):
        ap.error(f"--budget must be a finite number > 0, got {a.budget}")
    unknown = [n for n in a.meshes if not (a.dir / f"{n}.ply").is_file()]
    if unknown:
        ap.error(f"no such mesh: {', '.join(unknown)} (not in {a.dir})")
    for name in a.meshes:
        try:
            if a.quantised:
                quantised(
                    a.dir / f"{name}.ply", modes=a.ks, bits=a.bits, steps=a.steps, budget=a.budget
                )
                continue
            report(
                a.dir / f"{name}.ply", modes=a.modes, steps=a.steps, budget=a.budget, slots=a.slots
            )
        except ValueError as exc:  # an unreadable file, or more modes than the mesh has
            ap.exit(2, f"{ap.prog}: error: {name}: {exc}\n")


if __name__ == "__main__":
    main()
