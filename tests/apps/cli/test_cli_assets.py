"""The commands on studio files (issue 15): whole files, every mesh, keys, ids and messages.

Run in-process through ``main(argv)``.  The marked files are built once per module from small
generated meshes that carry a 64-bit id in a second or two (bumpy spheres of 2562 vertices, a
quad box of 1178) and the bundled spot at N = 128 on the grid for the logo; every other test
only reads them.
"""

from __future__ import annotations

import io
import itertools
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from meshwm.apps.cli import EXIT_PIPE, main
from meshwm.mesh.asset import read_asset
from meshwm.mesh.io import read_mesh, write_mesh
from meshwm.watermark import Decoder

ROOT = Path(__file__).parents[3]
SPOT = ROOT / "assets" / "spot.ply"
KEY = "a studio secret: k3y-91"
KEY_BYTES = KEY.encode()


def bumpy(seed: int) -> trimesh.Trimesh:
    """An icosphere (2562 vertices) with smooth random bumps: nothing symmetric to tie the cut."""
    sphere = trimesh.creation.icosphere(4)
    v = np.array(sphere.vertices)
    k = np.random.default_rng(seed).normal(size=(6, 3))
    v *= (1 + 0.15 * np.sin(v @ k.T).sum(axis=1))[:, None]
    return trimesh.Trimesh(v * [1.3, 0.8, 1.0], sphere.faces, process=False)


def quad_obj(path: Path, k: int = 14) -> None:
    """A closed box of k×k quads per side, on a bumpy blob; UVs, normals, material, groups."""
    grid = np.linspace(-1, 1, k + 1)
    index: dict[tuple[float, float, float], int] = {}
    quads = []
    for axis in range(3):
        others = [c for c in range(3) if c != axis]
        for sign in (-1.0, 1.0):
            ids = np.empty((k + 1, k + 1), dtype=int)
            for i, a in enumerate(grid):
                for j, b in enumerate(grid):
                    p = [0.0, 0.0, 0.0]
                    p[axis], p[others[0]], p[others[1]] = sign, a, b
                    ids[i, j] = index.setdefault((p[0], p[1], p[2]), len(index))
            quads += [
                [ids[i, j], ids[i + 1, j], ids[i + 1, j + 1], ids[i, j + 1]]
                for i in range(k)
                for j in range(k)
            ]
    v = np.array(list(index))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    r = np.random.default_rng(3).normal(size=(5, 3))
    v *= (1 + 0.12 * np.sin(1.5 * v @ r.T).sum(axis=1))[:, None] * [[1.0, 0.7, 1.4]]
    faces = np.array(quads)
    normal = np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]])
    outward = (normal * v[faces].mean(axis=1)).sum(axis=1) > 0
    quads = [q if out else q[::-1] for q, out in zip(quads, outward, strict=True)]
    lines = ["# Blender 4.1", "mtllib prop.mtl", "o prop"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in v]
    lines += [f"vt {x / 2 + 0.5:.4f} {y / 2 + 0.5:.4f}" for x, y, _ in v]
    lines += ["vn 0 0 1", "g shell", "usemtl paint", "s off"]
    lines += ["f " + " ".join(f"{i + 1}/{i + 1}/1" for i in q) for q in quads]
    path.write_text("\n".join(lines) + "\n")
    (path.parent / "prop.mtl").write_text("newmtl paint\nKd 0.8 0.2 0.1\n")


def kit_glb(path: Path) -> None:
    """Three props: two that carry an id, a screw far too small to."""
    scene = trimesh.Scene()
    rock, crate, screw = bumpy(1), bumpy(3), trimesh.creation.box()
    crate.visual.material = trimesh.visual.material.PBRMaterial(name="wood", roughnessFactor=0.8)
    move = trimesh.transformations.translation_matrix
    scene.add_geometry(rock, node_name="Rock", transform=move([3, 0, 0]))
    scene.add_geometry(crate, node_name="Crate", transform=move([-3, 0, 1]))
    scene.add_geometry(screw, node_name="Screw", transform=move([0, 2, 0]))
    path.write_bytes(scene.export(file_type="glb"))


def run(argv: list[str], capsys: pytest.CaptureFixture) -> tuple[int, str, str]:
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def made(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """Inputs, marked outputs and the JSON reports; key from a file."""
    d = tmp_path_factory.mktemp("assets")
    (d / "out").mkdir()
    key_file = d / "key.txt"
    key_file.write_text(KEY + "\n")
    quad_obj(d / "prop.obj")
    kit_glb(d / "kit.glb")
    outputs = {}
    reports = {}
    streams = []
    jobs = {
        "prop.obj": ["--id", "VENDOR_B"],
        "kit.glb": ["--id", "kit-all", "--mesh-id", "Crate=crate-42", "--no-distance"],
    }
    for name, extra in jobs.items():
        out = d / "out" / name
        stdout, stderr = io.StringIO(), io.StringIO()
        sys_out, sys_err = sys.stdout, sys.stderr
        sys.stdout, sys.stderr = stdout, stderr
        try:
            code = main(["embed", str(d / name), "-o", str(out), "--key-file", str(key_file),
                         "--json", *extra])  # fmt: skip
        finally:
            sys.stdout, sys.stderr = sys_out, sys_err
        assert code == 0, stderr.getvalue()
        outputs[name] = out
        reports[name] = json.loads(stdout.getvalue())
        streams += [stdout.getvalue(), stderr.getvalue()]
    logo = d / "out" / "logo.ply"
    assert main(["embed", str(SPOT), "-o", str(logo), "--key", KEY, "--grid", "--size", "128",
                 "--no-distance"]) == 0  # fmt: skip
    outputs["logo.ply"] = logo
    return {"dir": d, "key_file": key_file, "out": outputs, "json": reports, "streams": streams}


# --- the file kept whole, every mesh marked ------------------------------------------------


def test_a_quad_obj_comes_out_whole(made):
    d, out = made["dir"], made["out"]["prop.obj"]
    before, after = (d / "prop.obj").read_bytes().split(b"\n"), out.read_bytes().split(b"\n")
    assert len(before) == len(after)
    changed = [k for k, (a, b) in enumerate(zip(before, after, strict=True)) if a != b]
    assert changed and all(before[k].startswith(b"v ") for k in changed)
    report = made["json"]["prop.obj"]
    assert report["kept"]["changes"] == []
    kept = report["kept"]["after"]
    assert (kept["polygons"], kept["uvs"], kept["normals"], kept["materials"]) == (1176, 1178, 1, 1)
    assert report["meshes"][0]["id_text"] == "VENDOR_B" and report["meshes"][0]["marked"]
    assert 0 < report["mrms_rel"] < 5e-4  # a one-mesh file: its figures at the top as well
    assert report["notes"] == [f"{out} refers to prop.mtl, next to the input but not next to "
                               "the output: copy them along"]  # fmt: skip


def test_every_mesh_of_a_kit_is_marked_or_reported(made, capsys):
    rows = {row["name"]: row for row in made["json"]["kit.glb"]["meshes"]}
    assert rows["Rock"]["marked"] and rows["Rock"]["id_text"] == "kit-all"
    assert rows["Crate"]["marked"] and rows["Crate"]["id_text"] == "crate-42"
    assert not rows["Screw"]["marked"]
    assert rows["Screw"]["reason"].startswith("too small for the 256-bit payload: 8 vertices")
    code, out, _ = run(["verify", str(made["out"]["kit.glb"]), "--any-id", "--key", KEY], capsys)
    assert code == 0
    kit = made["out"]["kit.glb"]
    assert out.splitlines() == [
        f"{kit}: an id present in 2 of 3 meshes",
        f'  {kit} [Rock]: id "kit-all" (0x6b69742d616c6c00) present',
        f'  {kit} [Crate]: id "crate-42" (0x63726174652d3432) present',
        f"  {kit} [Screw]: an id absent (too small to carry a 256-bit payload: 8 vertices)",
    ]


def test_a_prop_split_out_of_the_kit_still_verifies(made, tmp_path, capsys):
    kit = read_asset(made["out"]["kit.glb"])
    k = kit.mesh_index("Crate")
    turned = trimesh.transformations.rotation_matrix(1.1, [0.3, 0.5, 0.8])[:3, :3]
    alone = tmp_path / "crate.ply"
    write_mesh(alone, kit.vertices(k) @ turned.T * 2.5 + 7.0, kit.meshes[k].faces)
    code, out, _ = run(["verify", str(alone), "--id", "crate-42", "--key", KEY], capsys)
    assert code == 0 and out.startswith(f'{alone}: id "crate-42" (0x63726174652d3432) present')


def test_per_mesh_ids_name_meshes_that_exist(made, tmp_path, capsys):
    argv = ["embed", str(made["dir"] / "kit.glb"), "-o", str(tmp_path / "x.glb"), "--key", KEY]
    code, _, err = run([*argv, "--mesh-id", "Table=t1"], capsys)
    assert code == 2 and "no mesh named 'Table'; the meshes are 'Rock', 'Crate', 'Screw'" in err
    assert not (tmp_path / "x.glb").exists()


def test_a_file_where_no_mesh_can_be_marked_is_an_error(tmp_path, capsys):
    small = tmp_path / "box.obj"
    small.write_text(
        "o box\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
    )
    code, _, err = run(["embed", str(small), "-o", str(tmp_path / "o.obj"), "--key", KEY,
                        "--id", "x"], capsys)  # fmt: skip
    assert code == 2
    assert err == ("meshwm: error: no mesh could be marked (box: too small for the 256-bit "
                   "payload: 4 vertices, at least 1024 needed)\n")  # fmt: skip
    assert sorted(p.name for p in tmp_path.iterdir()) == ["box.obj"]


def test_no_output_names_the_tool_or_holds_the_key(made):
    for path in made["out"].values():
        data = path.read_bytes()
        assert b"meshwm" not in data, path
        assert KEY_BYTES not in data, path
    for text in made["streams"]:  # the JSON reports and stderr of the embeds
        assert KEY not in text


# --- keys -----------------------------------------------------------------------------------


def _verify_prop(made, *extra: str) -> list[str]:
    return ["verify", str(made["out"]["prop.obj"]), "--id", "VENDOR_B", *extra]


def test_the_key_from_the_environment(made, capsys, monkeypatch):
    monkeypatch.setenv("MESHWM_KEY", KEY)
    code, out, _ = run(_verify_prop(made), capsys)
    assert code == 0 and "present" in out


@pytest.mark.parametrize(
    "extra, env, message",
    [
        ([], None, "no key: give --key-file PATH, set MESHWM_KEY, or give --key KEY"),
        (["--key", KEY], KEY, "the key is given twice, by --key and by $MESHWM_KEY"),
        (["--key-file", "KEYFILE"], KEY, "given twice, by --key-file and by $MESHWM_KEY"),
        (["--key-file", "missing.txt"], None, "--key-file missing.txt: cannot read it"),
        (["--key-file", "EMPTY"], None, ": the file is empty"),
        (["--key", KEY, "--key-file", "KEYFILE"], None, "not allowed with argument"),
    ],
)
def test_exactly_one_key_source(made, tmp_path, capsys, monkeypatch, extra, env, message):
    monkeypatch.delenv("MESHWM_KEY", raising=False)
    if env is not None:
        monkeypatch.setenv("MESHWM_KEY", env)
    (tmp_path / "empty.txt").write_text("\n")
    names = {"KEYFILE": str(made["key_file"]), "EMPTY": str(tmp_path / "empty.txt")}
    monkeypatch.chdir(tmp_path)
    code, out, err = run(_verify_prop(made, *(names.get(e, e) for e in extra)), capsys)
    assert code == 2 and out == ""
    assert err.startswith("meshwm: error: ") and err.count("\n") == 1 and message in err
    assert KEY not in err


def test_the_key_shows_in_no_output_stream_or_error(made, tmp_path, capsys, monkeypatch):
    """Every command and its failures: the key's bytes nowhere in stdout, stderr, files."""
    monkeypatch.setenv("MESHWM_KEY", KEY)
    prop = str(made["out"]["prop.obj"])
    runs = [
        ["verify", prop, "--json"],
        ["verify", prop, "--id", "VENDOR_B", "--json"],
        ["verify", prop, str(tmp_path), "--any-id", "--jsonl"],
        ["extract", prop, "--json", "-o", str(tmp_path / "m.png")],
        ["extract", str(made["out"]["logo.ply"]), "-o", str(tmp_path / "logo.png")],
        ["verify", str(tmp_path / "missing.obj")],
        ["embed", prop, "-o", str(tmp_path / "x.fbx")],
        ["embed", str(tmp_path / "missing.obj"), "-o", str(tmp_path / "x.obj")],
    ]
    for argv in runs:
        _, out, err = run(argv, capsys)
        assert KEY not in out and KEY not in err, argv
    for path in tmp_path.rglob("*"):
        assert KEY_BYTES not in path.read_bytes(), path


# --- ids ------------------------------------------------------------------------------------


def test_a_text_id_is_shown_as_text_and_hex(made, capsys):
    code, out, _ = run(["extract", str(made["out"]["prop.obj"]), "--key", KEY], capsys)
    assert code == 0 and out.endswith(': id "VENDOR_B" (0x56454e444f525f42)\n')


@pytest.mark.parametrize("command", ["embed", "verify"])
def test_0x_with_non_hex_digits_is_refused(command, made, tmp_path, capsys):
    argv = [command, str(made["dir"] / "prop.obj"), "--key", KEY, "--id", "0xZZ"]
    if command == "embed":
        argv += ["-o", str(tmp_path / "o.obj")]
    code, out, err = run(argv, capsys)
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "'0xZZ' starts with 0x but 'ZZ' is not 1 to 16 hex digits" in err
    assert not (tmp_path / "o.obj").exists()


def test_a_hex_id_typed_without_0x_is_pointed_out(tmp_path, capsys):
    """Before the one rule, --id C0FFEE42 meant the number; such a file says so."""
    marked = tmp_path / "hex.ply"
    mesh = bumpy(2)
    write_mesh(tmp_path / "in.ply", mesh.vertices, mesh.faces)
    argv = ["embed", str(tmp_path / "in.ply"), "-o", str(marked), "--key", KEY, "--no-distance"]
    assert main([*argv, "--id", "0xC0FFEE42"]) == 0
    capsys.readouterr()
    code, out, _ = run(["verify", str(marked), "--key", KEY, "--id", "C0FFEE42"], capsys)
    assert code == 1
    assert out.rstrip().endswith(
        ": this mesh carries the id 0x00000000c0ffee42; an id without 0x is text: did you "
        "mean --id 0xC0FFEE42?"
    )


# --- a kit joined into one mesh ---------------------------------------------------------------


def _boulder() -> tuple[np.ndarray, np.ndarray]:
    """An unmarked bumpy sphere with more vertices (3698) than a prop of the kit (2562)."""
    sphere = trimesh.creation.uv_sphere(count=[44, 44])
    v = np.array(sphere.vertices)
    k = np.random.default_rng(11).normal(size=(6, 3))
    v *= (1 + 0.15 * np.sin(v @ k.T).sum(axis=1))[:, None]
    return v * [2.0, 1.6, 1.8], np.array(sphere.faces)


def _joined_kit(made, path: Path, seed: int | None = None) -> Path:
    """The marked kit's crate and screw joined with a larger unmarked boulder into one mesh, as
    a modeller's join does (each moved to its place), in one PLY; with ``seed``, then a random
    similarity and a random vertex and face order."""
    kit = read_asset(made["out"]["kit.glb"])
    parts = [_boulder()]
    for name, shift in (("Crate", [-5, 0, 1]), ("Screw", [0, 3, 0])):
        k = kit.mesh_index(name)
        parts.append((kit.vertices(k) + shift, kit.meshes[k].faces))
    starts = np.cumsum([0] + [len(v) for v, _ in parts])
    v = np.concatenate([v for v, _ in parts])
    f = np.concatenate([f + s for (_, f), s in zip(parts, starts, strict=False)])
    if seed is not None:
        rng = np.random.default_rng(seed)
        turn = trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3]
        v = v @ turn.T * 10 ** rng.uniform(-2, 2) + rng.uniform(-100, 100, 3)
        order = rng.permutation(len(v))
        v, f = v[order], np.argsort(order)[f][rng.permutation(len(f))]
    write_mesh(path, v, f)
    return path


def test_a_prop_joined_with_others_into_one_mesh_is_read_alone(made, tmp_path, capsys):
    joined = _joined_kit(made, tmp_path / "joined.ply")
    argv = ["verify", str(joined), "--key", KEY, "--id", "crate-42"]
    code, out, _ = run([*argv, "--json"], capsys)
    crate = json.loads(out)
    # The whole mesh's readers map its largest piece (the boulder) and read the radial carrier
    # over every piece: the crate reads only alone (the screw is too small to be read).
    assert code == 0 and crate["detected"] and crate["id_text"] == "crate-42"
    assert crate["piece"] == {"index": 2, "of": 2, "vertices": 2562}
    # Every reading's hypotheses count, not only the one that read: more than the whole's.
    whole = Decoder(*read_mesh(joined)).hypotheses
    assert crate["hypotheses"] > whole
    code, out, _ = run(argv, capsys)
    assert out == (
        f'{joined}: id "crate-42" (0x63726174652d3432) present (BER 0.0000, p-value '
        f"{crate['p_value']:.3g}; read in piece 2 of 2 (2562 vertices) alone)\n"
    )


def test_a_prop_separated_into_meshes_is_read_as_one(made, tmp_path, capsys):
    """The marked crate separated into three glTF meshes (one node each, as an exporter writes
    an object per material: the border vertices written once per part, float32)."""
    kit = read_asset(made["out"]["kit.glb"])
    k = kit.mesh_index("Crate")
    v, f = kit.vertices(k), kit.meshes[k].faces
    part = np.digitize(v[f].mean(axis=1)[:, 2], np.quantile(v[:, 2], [0.3, 0.6]))
    scene = trimesh.Scene()
    for p in range(3):
        piece = trimesh.Trimesh(v, f[part == p], process=False)
        piece.remove_unreferenced_vertices()
        scene.add_geometry(piece, node_name=f"crate_{p}", geom_name=f"crate_{p}")
    separated = tmp_path / "separated.glb"
    separated.write_bytes(scene.export(file_type="glb"))
    parts = read_asset(separated).meshes
    assert [m.name for m in parts] == ["crate_0", "crate_1", "crate_2"]
    code, out, _ = run(["verify", str(separated), "--key", KEY, "--id", "crate-42"], capsys)
    assert code == 0
    lines = out.splitlines()
    assert lines[0] == f'{separated}: id "crate-42" (0x63726174652d3432) present in 3 of 3 meshes'
    total = sum(m.n_vertices for m in parts)
    for line, mesh in zip(lines[1:], parts, strict=True):
        assert line.startswith(f'  {separated} [{mesh.name}]: id "crate-42"')
        assert line.endswith(f"read as one mesh with the file's 2 other meshes, {total} vertices)")
    code, out, _ = run(["extract", str(separated), "--key", KEY, "--json"], capsys)
    rows = json.loads(out)["meshes"]
    assert code == 0 and [r["id_text"] for r in rows] == ["crate-42"] * 3
    assert rows[0]["together"] == {"meshes": [m.name for m in parts], "vertices": total}


@pytest.mark.slow
def test_a_joined_mesh_under_another_key_carries_no_id(made, tmp_path, capsys):
    joined = _joined_kit(made, tmp_path / "joined.ply")
    code, out, _ = run(["verify", str(joined), "--key", "another key", "--any-id"], capsys)
    assert code == 1 and out == f"{joined}: an id absent\n"


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(3))
def test_the_joined_prop_reads_in_any_pose_and_order(made, tmp_path, capsys, seed):
    joined = _joined_kit(made, tmp_path / "joined.ply", seed=seed)
    code, out, _ = run(["verify", str(joined), "--key", KEY, "--id", "crate-42", "--json"], capsys)
    report = json.loads(out)
    assert code == 0 and report["detected"] and report["piece"]["vertices"] == 2562


def test_a_mesh_of_several_big_pieces_is_marked_piece_by_piece(tmp_path, capsys):
    # One object of three pieces, as a joined export gives: two that carry an id, a box too small.
    rock, box = bumpy(3), trimesh.creation.box()
    parts = [_boulder(), (rock.vertices - np.array([5, 0, 1]), np.array(rock.faces))]
    parts.append((box.vertices + np.array([0, 3, 0]), np.array(box.faces)))
    starts = np.cumsum([0] + [len(v) for v, _ in parts])
    v = np.concatenate([v for v, _ in parts])
    f = np.concatenate([f + s for (_, f), s in zip(parts, starts, strict=False)])
    source, marked = tmp_path / "three.ply", tmp_path / "marked.ply"
    write_mesh(source, v, f)
    argv = ["--key", KEY, "--id", "pieces-1"]
    code, out, err = run(["embed", str(source), "-o", str(marked), *argv, "--json"], capsys)
    assert code == 0, err
    row = json.loads(out)["meshes"][0]
    assert row["marked"] and row["pieces"] == {"marked": 2, "of": 2, "smaller": 1}
    mv, mf = read_mesh(marked)
    assert np.array_equal(mf, f) and len(mv) == len(v)
    np.testing.assert_array_equal(mv[starts[2] :], v[starts[2] :])  # the box as it was
    # Each big piece moved, and carries the id on its own: split off, each verifies.
    for a, b in itertools.pairwise(starts[:3]):
        assert np.abs(mv[a:b] - v[a:b]).max() > 0
        alone = tmp_path / f"piece_{a}.ply"
        write_mesh(alone, mv[a:b], f[(f >= a).all(axis=1) & (f < b).all(axis=1)] - a)
        code, out, _ = run(["verify", str(alone), *argv], capsys)
        assert code == 0 and " present " in out, out
    code, out, _ = run(["verify", str(marked), *argv], capsys)
    assert code == 0 and " present " in out
    code, out, _ = run(["embed", str(source), "-o", str(tmp_path / "again.ply"), *argv], capsys)
    assert "marked piece by piece: 2 of its 2 pieces big enough for the payload carry it" in out
    assert "1 smaller piece unchanged" in out


# --- messages that explain a mismatch ------------------------------------------------------


def test_a_mark_sought_in_an_id_marked_file(made, capsys):
    prop = made["out"]["prop.obj"]
    code, out, _ = run(["verify", str(prop), "--key", KEY], capsys)  # the bundled logo
    assert code == 1
    assert out.startswith(f"{prop}: mark absent: ")
    assert out.rstrip().endswith(
        ': this mesh carries an id, not a mark: "VENDOR_B" (0x56454e444f525f42); verify with '
        "--id or --any-id"
    )


def test_an_id_sought_in_a_logo_marked_file(made, capsys):
    logo = made["out"]["logo.ply"]
    code, out, _ = run(["verify", str(logo), "--key", KEY, "--any-id"], capsys)
    assert code == 1
    note = "this mesh carries the bundled logo, not an id: verify without --id"
    assert out == f"{logo}: an id absent: {note}\n"


def test_an_id_sought_in_a_file_with_another_id(made, capsys):
    prop = made["out"]["prop.obj"]
    code, out, _ = run(["verify", str(prop), "--key", KEY, "--id", "VENDOR_Z", "--json"], capsys)
    assert code == 1
    report = json.loads(out)
    assert report["detected"] is False and report["id_text"] == "VENDOR_B"
    assert report["note"] == 'this mesh carries another id: "VENDOR_B" (0x56454e444f525f42)'
    assert report["meshes"][0]["note"] == report["note"]


def test_verify_seeks_the_bundled_logo_by_default(made, capsys):
    code, out, _ = run(["verify", str(made["out"]["logo.ply"]), "--key", KEY], capsys)
    assert code == 0 and "mark present (BER 0.0000" in out


def test_extract_writes_no_noise_for_an_id(made, tmp_path, capsys):
    png = tmp_path / "mark.png"
    code, out, _ = run(["extract", str(made["out"]["prop.obj"]), "--key", KEY, "-o", str(png)],
                       capsys)  # fmt: skip
    assert code == 0 and not png.exists()
    assert out.rstrip().endswith("this mesh carries an id, not a mark: no mark image written")
    code, out, _ = run(["extract", str(made["out"]["logo.ply"]), "--key", KEY, "-o", str(png)],
                       capsys)  # fmt: skip
    assert code == 0 and png.exists() and out.rstrip().endswith("(the bundled logo)")


# --- progress and pipes --------------------------------------------------------------------


class Terminal(io.StringIO):
    """stdout and stderr of one terminal: one stream that says it is a TTY."""

    def isatty(self) -> bool:
        return True


def test_progress_never_shares_a_line_with_a_result(made, tmp_path, monkeypatch):
    for k in range(3):
        (tmp_path / f"copy{k}.obj").write_bytes(made["out"]["prop.obj"].read_bytes())
    screen = Terminal()
    monkeypatch.setattr(sys, "stdout", screen)
    monkeypatch.setattr(sys, "stderr", screen)
    assert main(["verify", str(tmp_path), "--key", KEY, "--any-id"]) == 0
    shown = [line.split("\r")[-1] for line in screen.getvalue().split("\n")]
    results = [line for line in shown if line.startswith(str(tmp_path))]
    assert len(results) == 3
    assert all("[" not in line and "%" not in line for line in results)
    assert "\r100% [" in screen.getvalue()  # the bar was drawn, between the results


def test_embed_shows_its_stages_on_a_terminal(made, tmp_path, monkeypatch):
    screen = Terminal()
    monkeypatch.setattr(sys, "stderr", screen)
    out = tmp_path / "prop.obj"
    assert main(["embed", str(made["dir"] / "prop.obj"), "-o", str(out), "--key", KEY,
                 "--id", "VENDOR_B"]) == 0  # fmt: skip
    drawn = screen.getvalue()
    for stage in ("reading ", "marking: 1178 vertices", "measuring the distance", "writing "):
        assert "\r" + stage in drawn, stage
    assert drawn.endswith("\r")  # blanked before the report


def test_a_closed_pipe_ends_quietly(tmp_path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen(
        [sys.executable, "-m", "meshwm", "docs", "keep"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=tmp_path, env=env,
    )  # fmt: skip
    assert proc.stdout is not None and proc.stderr is not None
    proc.stdout.close()  # as `| head` does once it has its lines
    err = proc.stderr.read()
    proc.stderr.close()
    assert proc.wait() == EXIT_PIPE and err == b""


def test_a_closed_pipe_in_process(monkeypatch, capsys):
    class Closed(io.StringIO):
        def write(self, text: str) -> int:
            raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(sys, "stdout", Closed())
    assert main(["docs"]) == EXIT_PIPE
    assert capsys.readouterr().err == ""


# --- docs and bundled data ------------------------------------------------------------------


def test_docs_lists_and_prints_the_pages(capsys):
    code, out, _ = run(["docs"], capsys)
    assert code == 0 and "assets  " in out and "attacks " in out
    code, out, _ = run(["docs", "assets"], capsys)
    assert code == 0 and out.startswith("# The studio's asset, kept whole")
    code, _, err = run(["docs", "nope"], capsys)
    assert code == 2 and "no page 'nope'; the pages are" in err


def test_help_texts_point_at_pages_that_exist(capsys):
    from meshwm.data import doc_topics

    for command in ("attack", "embed", "verify", "render", "bench", "registry", "trace"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        named = [w for w in text.split("meshwm docs ")[1:]]
        assert named, command
        for word in named:
            assert word.split()[0].strip(".,;:") in doc_topics(), (command, word)
        assert "docs/" not in text


@pytest.mark.slow
def test_the_readme_python_example_runs_from_any_folder(tmp_path):
    text = (ROOT / "README.md").read_text()
    block = text.split("```python\n", 1)[1].split("```", 1)[0]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run(
        [sys.executable, "-c", block], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ['"VENDOR_A" (0x56454e444f525f41)', "True"]


# --- attack on an STL -----------------------------------------------------------------------


def test_attack_welds_an_stl_before_moving_its_vertices(tmp_path, capsys):
    soup = tmp_path / "spot.stl"
    write_mesh(soup, *read_mesh(SPOT))
    out = tmp_path / "noisy.stl"
    code, text, _ = run(["attack", str(soup), "-o", str(out), "--kind", "noise", "--json"], capsys)
    assert code == 0
    assert json.loads(text)["welded"] == {"corners": 17568, "vertices": 2930}
    welded = trimesh.load(out)  # trimesh's default load merges corners at equal positions
    assert welded.is_watertight and len(welded.vertices) == 2930
