"""Tests for :mod:`meshwm.message.mark`: reading, writing and drawing the binary mark.

Every image file is generated here with Pillow under ``tmp_path``, except
``assets/mark32.png``, which was written once with
``save_mark("assets/mark32.png", default_mark())``.
"""

from __future__ import annotations

import math
import os
import re
import struct
import zlib
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from PIL import Image

import meshwm.message.mark as mmark
from meshwm.message.mark import default_mark, load_mark, neighbour_correlation, save_mark

ASSETS = Path(__file__).parent.parent.parent / "assets"

PROPERTY = settings(
    max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)

#: The 7 rotations and reflections of the square other than the identity.
SYMMETRIES = {
    "rot90": lambda a: np.rot90(a, 1),
    "rot180": lambda a: np.rot90(a, 2),
    "rot270": lambda a: np.rot90(a, 3),
    "flip_rows": lambda a: a[::-1],
    "flip_cols": lambda a: a[:, ::-1],
    "transpose": lambda a: a.T,
    "anti_transpose": lambda a: np.rot90(a, 2).T,
}


def _random_bits(shape: tuple[int, int], seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 2, size=shape, dtype=np.uint8)


def _save_gray(path: Path, gray: np.ndarray, **kwargs: object) -> Path:
    Image.fromarray(gray).save(path, **kwargs)
    return path


def _save_bits(path: Path, bits: np.ndarray) -> Path:
    save_mark(path, bits)
    return path


def _one_line_error_for(path: Path) -> str:
    """``match`` pattern: the message starts with the file name (and is one line)."""
    return "^" + re.escape(os.fspath(path)) + ": [^\n]*$"


def _png_header_only(width: int, height: int) -> bytes:
    """A PNG signature, a valid IHDR declaring ``width``×``height`` gray pixels, and IEND."""

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
        )

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IEND", b"")


# ---------------------------------------------------------------------------
# default_mark and the bundled asset


def test_default_mark_shape_and_values() -> None:
    mark = default_mark()
    assert mark.shape == (32, 32)
    assert mark.dtype == np.uint8
    assert set(np.unique(mark).tolist()) == {0, 1}
    assert int(mark.sum()) == 370
    assert mark.flags.c_contiguous


def test_default_mark_is_deterministic_and_fresh() -> None:
    first = default_mark()
    first[:] = 0
    np.testing.assert_array_equal(default_mark(), default_mark())
    assert default_mark().any()


def test_default_mark_frame_and_corner_details() -> None:
    mark = default_mark()
    assert mark[0].all() and mark[-1].all() and mark[:, 0].all() and mark[:, -1].all()
    assert mark[28:30, 24:28].all()  # the block at the bottom right
    assert not mark[28:30, 4:8].any()  # ... and nothing in the mirrored place


@pytest.mark.parametrize("name", sorted(SYMMETRIES))
def test_default_mark_has_no_symmetry(name: str) -> None:
    """Each rotation/reflection differs from the logo in at least 20 % of the pixels."""
    mark = default_mark()
    differing = int(np.count_nonzero(SYMMETRIES[name](mark) != mark))
    assert differing >= 0.2 * mark.size


def test_default_mark_symmetries_are_pairwise_distinct() -> None:
    images = [default_mark()] + [transform(default_mark()) for transform in SYMMETRIES.values()]
    assert len({image.tobytes() for image in images}) == 8


def test_asset_equals_default_mark() -> None:
    path = ASSETS / "mark32.png"
    np.testing.assert_array_equal(load_mark(path), default_mark())
    with Image.open(path) as image:  # independently of load_mark: black (0) is ink
        assert (image.format, image.mode, image.size) == ("PNG", "1", (32, 32))
        np.testing.assert_array_equal(np.asarray(image.convert("L")) == 0, default_mark() == 1)


@pytest.mark.parametrize("factor", [2, 4, 8])
def test_default_mark_enlarged_repeats_pixels(factor: int) -> None:
    expected = np.kron(default_mark(), np.ones((factor, factor), dtype=np.uint8))
    np.testing.assert_array_equal(default_mark(32 * factor), expected)


@pytest.mark.parametrize("size", [8, 16, 24, 33])
def test_default_mark_reduced(size: int) -> None:
    mark = default_mark(size)
    assert mark.shape == (size, size)
    assert set(np.unique(mark).tolist()) <= {0, 1}


@pytest.mark.parametrize(
    ("size", "error", "message"),
    [
        (7, ValueError, "size must be between 8 and 256 pixels, got 7"),
        (257, ValueError, "size must be between 8 and 256 pixels, got 257"),
        (32.0, TypeError, "size must be an integer, got float"),
        (True, TypeError, "size must be an integer, got bool"),
    ],
)
def test_default_mark_bad_size(size: object, error: type[Exception], message: str) -> None:
    with pytest.raises(error, match=message):
        default_mark(size)


# ---------------------------------------------------------------------------
# save_mark


@given(
    bits=hnp.arrays(
        np.uint8, st.integers(8, 64).map(lambda n: (n, n)), elements=st.integers(0, 1)
    ).filter(lambda b: 0 < b.sum() < b.size)
)
@PROPERTY
def test_save_load_round_trip(tmp_path: Path, bits: np.ndarray) -> None:
    path = tmp_path / "mark.png"
    save_mark(path, bits)
    loaded = load_mark(path)
    assert loaded.dtype == np.uint8
    np.testing.assert_array_equal(loaded, bits)


@pytest.mark.parametrize("dtype", [np.bool_, np.uint8, np.int64, np.float32, np.float64])
def test_save_accepts_numeric_zero_one(tmp_path: Path, dtype: object) -> None:
    bits = _random_bits((13, 13), seed=3)
    save_mark(tmp_path / "mark.png", bits.astype(dtype))
    np.testing.assert_array_equal(load_mark(tmp_path / "mark.png"), bits)


def test_saved_file_is_one_bit_png_black_ink(tmp_path: Path) -> None:
    bits = _random_bits((9, 21), seed=1)  # width not a multiple of 8: row padding
    save_mark(tmp_path / "mark.png", bits)
    with Image.open(tmp_path / "mark.png") as image:
        assert (image.format, image.mode, image.size) == ("PNG", "1", (21, 9))
        assert image.info == {}
        np.testing.assert_array_equal(np.asarray(image.convert("L")), np.where(bits, 0, 255))


def test_save_is_deterministic(tmp_path: Path) -> None:
    save_mark(tmp_path / "a.png", default_mark())
    save_mark(tmp_path / "b.png", default_mark())
    assert (tmp_path / "a.png").read_bytes() == (tmp_path / "b.png").read_bytes()


def test_save_leaves_no_temporary_file_and_overwrites(tmp_path: Path) -> None:
    path = tmp_path / "mark.png"
    save_mark(path, _random_bits((16, 16), seed=1))
    os.chmod(path, 0o640)
    save_mark(path, default_mark())
    assert sorted(os.listdir(tmp_path)) == ["mark.png"]
    assert os.stat(path).st_mode & 0o777 == 0o640
    np.testing.assert_array_equal(load_mark(path), default_mark())


def test_save_failure_keeps_old_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "mark.png"
    save_mark(path, default_mark())
    before = path.read_bytes()

    def failing_replace(source: str, target: str) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(mmark.os, "replace", failing_replace)
    with pytest.raises(ValueError, match=_one_line_error_for(path)) as info:
        save_mark(path, _random_bits((16, 16)))
    assert "No space left on device" in str(info.value)
    assert path.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["mark.png"]


def test_save_into_missing_directory(tmp_path: Path) -> None:
    path = tmp_path / "missing" / "mark.png"
    with pytest.raises(ValueError, match=_one_line_error_for(path)):
        save_mark(path, default_mark())


@pytest.mark.parametrize("name", ["mark.bmp", "mark", "mark.png.txt"])
def test_save_needs_png_suffix(tmp_path: Path, name: str) -> None:
    with pytest.raises(ValueError, match=r"give the file a \.png suffix"):
        save_mark(tmp_path / name, default_mark())
    assert os.listdir(tmp_path) == []


def test_save_accepts_upper_case_suffix(tmp_path: Path) -> None:
    save_mark(tmp_path / "MARK.PNG", default_mark())
    np.testing.assert_array_equal(load_mark(tmp_path / "MARK.PNG"), default_mark())


@pytest.mark.parametrize(
    ("bits", "error", "message"),
    [
        (np.full((8, 8), 2), ValueError, r"only 0 and 1, got 2 at \(0, 0\)"),
        (np.full((8, 8), 0.5), ValueError, r"only 0 and 1, got 0.5 at \(0, 0\)"),
        (np.full((8, 8), np.nan), ValueError, r"only 0 and 1, got nan"),
        (np.zeros(8), ValueError, r"non-empty 2-D array, got shape \(8,\)"),
        (np.zeros((0, 8)), ValueError, r"non-empty 2-D array, got shape \(0, 8\)"),
        (np.zeros((2, 8, 8)), ValueError, r"non-empty 2-D array, got shape \(2, 8, 8\)"),
        (np.zeros((1, 4097)), ValueError, "at most 4096 pixels per side"),
        (np.full((8, 8), "1"), TypeError, "array of 0/1 numbers, got dtype <U1"),
        (np.ones((8, 8), dtype=complex), TypeError, "got dtype complex128"),
    ],
)
def test_save_bad_bits(
    tmp_path: Path, bits: np.ndarray, error: type[Exception], message: str
) -> None:
    with pytest.raises(error, match=message):
        save_mark(tmp_path / "mark.png", bits)
    assert os.listdir(tmp_path) == []


# ---------------------------------------------------------------------------
# load_mark: formats and binarisation


def test_load_gray_levels_threshold_at_midpoint(tmp_path: Path) -> None:
    """Levels 40..200: midpoint 120; 119 is ink, 120 (the tie) and above are paper."""
    gray = np.full((8, 8), 200, dtype=np.uint8)
    gray[0, :4] = [40, 100, 119, 120]
    gray[1, :3] = [121, 150, 199]
    bits = load_mark(_save_gray(tmp_path / "gray.png", gray))
    expected = np.zeros((8, 8), dtype=np.uint8)
    expected[0, :3] = 1
    np.testing.assert_array_equal(bits, expected)


def test_load_uses_image_range_not_full_scale(tmp_path: Path) -> None:
    """A faint logo (gray 180 on 220) is still two-toned: midpoint 200."""
    mark = default_mark()
    gray = np.where(mark == 1, 180, 220).astype(np.uint8)
    np.testing.assert_array_equal(load_mark(_save_gray(tmp_path / "faint.png", gray)), mark)


@pytest.mark.parametrize("suffix", [".bmp", ".gif", ".tif", ".png", ".pgm", ".webp"])
def test_load_lossless_formats(tmp_path: Path, suffix: str) -> None:
    mark = default_mark()
    rgb = np.where(mark[..., None] == 1, [20, 30, 120], [250, 240, 200]).astype(np.uint8)
    image = Image.fromarray(rgb if suffix not in (".pgm", ".gif") else rgb[..., 0])
    kwargs = {"lossless": True} if suffix == ".webp" else {}
    image.save(tmp_path / f"mark{suffix}", **kwargs)
    np.testing.assert_array_equal(load_mark(tmp_path / f"mark{suffix}"), mark)


def test_load_jpeg_of_a_blocky_mark(tmp_path: Path) -> None:
    mark = default_mark()
    gray = np.where(np.kron(mark, np.ones((8, 8), np.uint8)) == 1, 0, 255).astype(np.uint8)
    _save_gray(tmp_path / "mark.jpg", gray, quality=95)
    np.testing.assert_array_equal(load_mark(tmp_path / "mark.jpg", size=32), mark)


def test_load_one_bit_bmp(tmp_path: Path) -> None:
    mark = default_mark()
    Image.fromarray(mark == 0).save(tmp_path / "mark.bmp")  # mode "1": True is white
    with Image.open(tmp_path / "mark.bmp") as image:
        assert image.mode == "1"
    np.testing.assert_array_equal(load_mark(tmp_path / "mark.bmp"), mark)


def test_load_sixteen_bit_png(tmp_path: Path) -> None:
    """16-bit levels above 255 (Pillow's own conversion to 8 bits would clip them all)."""
    mark = default_mark()
    deep = np.where(mark == 1, 1000, 60000).astype(np.uint16)
    Image.fromarray(deep).save(tmp_path / "deep.png")
    with Image.open(tmp_path / "deep.png") as image:
        assert image.mode.startswith("I")
    np.testing.assert_array_equal(load_mark(tmp_path / "deep.png"), mark)


def test_load_float_tiff(tmp_path: Path) -> None:
    mark = default_mark()
    Image.fromarray(np.where(mark == 1, -0.5, 0.25).astype(np.float32)).save(tmp_path / "f.tif")
    np.testing.assert_array_equal(load_mark(tmp_path / "f.tif"), mark)


def test_load_float_tiff_with_nan(tmp_path: Path) -> None:
    values = np.where(default_mark() == 1, 0.0, 1.0).astype(np.float32)
    values[3, 3] = np.nan
    path = tmp_path / "nan.tif"
    Image.fromarray(values).save(path)
    with pytest.raises(ValueError, match=_one_line_error_for(path)) as info:
        load_mark(path)
    assert "NaN" in str(info.value)


def test_load_transparent_background_is_paper(tmp_path: Path) -> None:
    """Black ink on transparent *black* pixels: composited over white, not read as ink."""
    mark = default_mark()
    rgba = np.zeros((32, 32, 4), dtype=np.uint8)
    rgba[..., 3] = np.where(mark == 1, 255, 0)
    Image.fromarray(rgba).save(tmp_path / "alpha.png")
    np.testing.assert_array_equal(load_mark(tmp_path / "alpha.png"), mark)


def test_load_palette_with_transparency(tmp_path: Path) -> None:
    mark = default_mark()
    image = Image.fromarray(mark, mode="L").convert("P")  # index 0 and 1
    image.putpalette([0, 0, 0, 0, 0, 0] + [255] * 762)  # both indices black ...
    image.info["transparency"] = 0  # ... but index 0 (paper) transparent
    image.save(tmp_path / "palette.gif", transparency=0)
    np.testing.assert_array_equal(load_mark(tmp_path / "palette.gif"), mark)


def test_load_applies_exif_orientation(tmp_path: Path) -> None:
    mark = default_mark()
    exif = Image.Exif()
    exif[0x0112] = 6  # "rotate 90° clockwise to display"
    Image.fromarray(np.where(mark == 1, 0, 255).astype(np.uint8)).save(
        tmp_path / "rotated.png", exif=exif
    )
    np.testing.assert_array_equal(load_mark(tmp_path / "rotated.png"), np.rot90(mark, -1))


def test_load_first_frame_of_animation(tmp_path: Path) -> None:
    first = default_mark()
    frames = [
        Image.fromarray(np.where(b == 1, 0, 255).astype(np.uint8)) for b in (first, 1 - first)
    ]
    frames[0].save(tmp_path / "anim.gif", save_all=True, append_images=frames[1:])
    np.testing.assert_array_equal(load_mark(tmp_path / "anim.gif"), first)


def test_load_returns_fresh_contiguous_uint8(tmp_path: Path) -> None:
    path = tmp_path / "mark.png"
    save_mark(path, default_mark())
    mark = load_mark(str(path))
    assert mark.dtype == np.uint8 and mark.flags.c_contiguous and mark.flags.writeable


# ---------------------------------------------------------------------------
# load_mark: resampling


@pytest.mark.parametrize("factor", [2, 4])
def test_resize_up_repeats_pixels(tmp_path: Path, factor: int) -> None:
    bits = _random_bits((16, 16), seed=2)
    save_mark(tmp_path / "mark.png", bits)
    expected = np.kron(bits, np.ones((factor, factor), dtype=np.uint8))
    np.testing.assert_array_equal(load_mark(tmp_path / "mark.png", size=16 * factor), expected)


def test_resize_down_takes_pixel_centres(tmp_path: Path) -> None:
    bits = _random_bits((32, 32), seed=4)
    save_mark(tmp_path / "mark.png", bits)
    np.testing.assert_array_equal(load_mark(tmp_path / "mark.png", size=16), bits[1::2, 1::2])


def test_resize_same_size_is_identity(tmp_path: Path) -> None:
    bits = _random_bits((24, 24), seed=5)
    save_mark(tmp_path / "mark.png", bits)
    np.testing.assert_array_equal(load_mark(tmp_path / "mark.png", size=24), bits)


def test_resize_non_square_stretches(tmp_path: Path) -> None:
    bits = _random_bits((20, 40), seed=6)  # 40 wide, 20 high
    save_mark(tmp_path / "wide.png", bits)
    np.testing.assert_array_equal(load_mark(tmp_path / "wide.png", size=20), bits[:, 1::2])


def test_resize_matches_pillow_nearest_away_from_ties(tmp_path: Path) -> None:
    """From 30×50 to 32×32, (i + 1/2)·h/32 is never a whole number: same pixels as Pillow."""
    gray = np.where(_random_bits((50, 30), seed=7) == 1, 0, 255).astype(np.uint8)
    _save_gray(tmp_path / "odd.png", gray)
    pillow = np.asarray(Image.fromarray(gray).resize((32, 32), Image.Resampling.NEAREST))
    np.testing.assert_array_equal(load_mark(tmp_path / "odd.png", size=32), pillow == 0)


def test_resize_is_exact_at_ties(tmp_path: Path) -> None:
    """From 30 to 37 columns, column 18 samples at exactly 15.0: exact floor gives 15.

    (Pillow's floating-point NEAREST computes 14.999... and takes column 14.)
    """
    bits = _random_bits((50, 30), seed=7)
    _save_bits(tmp_path / "odd.png", bits)
    rows = [math.floor(Fraction(2 * i + 1, 2) * 50 / 37) for i in range(37)]
    cols = [math.floor(Fraction(2 * i + 1, 2) * 30 / 37) for i in range(37)]
    assert cols[18] == 15
    np.testing.assert_array_equal(
        load_mark(tmp_path / "odd.png", size=37), bits[np.ix_(rows, cols)]
    )


def test_threshold_uses_the_whole_image(tmp_path: Path) -> None:
    """The one pixel at gray 0 sets the midpoint (127.5) even though resampling skips it."""
    gray = np.full((32, 32), 255, dtype=np.uint8)
    gray[0, 0] = 0
    gray[1::2, 1:16:2] = 100  # sampled by size=16: ink
    gray[1::2, 17::2] = 150  # sampled: paper (it would be ink with the samples' midpoint 177.5)
    bits = load_mark(_save_gray(tmp_path / "mark.png", gray), size=16)
    expected = np.zeros((16, 16), dtype=np.uint8)
    expected[:, :8] = 1
    np.testing.assert_array_equal(bits, expected)


# ---------------------------------------------------------------------------
# load_mark: refusals


def test_non_square_without_size(tmp_path: Path) -> None:
    path = _save_bits(tmp_path / "wide.png", _random_bits((16, 24)))
    with pytest.raises(ValueError, match=_one_line_error_for(path)) as info:
        load_mark(path)
    assert "24×16, not square; pass size=" in str(info.value)


@pytest.mark.parametrize("side", [4, 7, 257, 300])
def test_side_outside_range_without_size(tmp_path: Path, side: int) -> None:
    path = _save_bits(tmp_path / "mark.png", _random_bits((side, side)))
    with pytest.raises(ValueError, match=_one_line_error_for(path)) as info:
        load_mark(path)
    assert f"{side}×{side}, outside 8..256" in str(info.value)
    assert load_mark(path, size=32).shape == (32, 32)


@pytest.mark.parametrize(
    ("size", "error", "message"),
    [
        (7, ValueError, "size must be between 8 and 256 pixels, got 7"),
        (0, ValueError, "size must be between 8 and 256 pixels, got 0"),
        (4096, ValueError, "size must be between 8 and 256 pixels, got 4096"),
        (32.0, TypeError, "size must be an integer, got float"),
        ("32", TypeError, "size must be an integer, got str"),
    ],
)
def test_bad_size(tmp_path: Path, size: object, error: type[Exception], message: str) -> None:
    path = _save_bits(tmp_path / "mark.png", default_mark())
    with pytest.raises(error, match=message):
        load_mark(path, size=size)


def test_image_larger_than_limit(tmp_path: Path) -> None:
    path = _save_gray(tmp_path / "long.png", np.zeros((8, 4097), dtype=np.uint8))
    with pytest.raises(ValueError, match=_one_line_error_for(path)) as info:
        load_mark(path, size=32)
    assert "4097×8 pixels, larger than the limit of 4096 per side" in str(info.value)


@pytest.mark.parametrize(
    ("width", "height", "detail"),
    [
        (5000, 5000, "larger than the limit of 4096"),  # refused before decoding
        (10_000, 10_000, "too large to decode"),  # Pillow's DecompressionBombWarning
        (100_000, 100_000, "too large to decode"),  # Pillow's DecompressionBombError
    ],
)
def test_huge_header_refused_before_decoding(
    tmp_path: Path, width: int, height: int, detail: str
) -> None:
    path = tmp_path / "bomb.png"
    path.write_bytes(_png_header_only(width, height))
    with pytest.raises(ValueError, match=_one_line_error_for(path)) as info:
        load_mark(path, size=32)
    assert detail in str(info.value)


def _valid_png_bytes(tmp_path: Path) -> bytes:
    gray = np.where(_random_bits((64, 64), seed=8) == 1, 0, 255).astype(np.uint8)
    return _save_gray(tmp_path / "valid.png", gray).read_bytes()


@pytest.mark.parametrize(
    ("case", "detail"),
    [
        ("missing", "no such file"),
        ("directory", "is a directory"),
        ("empty", "not a readable image"),
        ("garbage", "not a readable image"),
        ("text", "not a readable image"),
        ("truncated", "corrupt or truncated image"),
        ("bad_crc", "corrupt header"),
        ("bad_data", "corrupt or truncated image"),
        ("header_only", "corrupt or truncated image"),
    ],
)
def test_unreadable_file(tmp_path: Path, case: str, detail: str) -> None:
    path = tmp_path / "mark.png"
    valid = _valid_png_bytes(tmp_path)
    if case == "directory":
        path.mkdir()
    elif case == "empty":
        path.write_bytes(b"")
    elif case == "garbage":
        path.write_bytes(np.random.default_rng(0).bytes(500))
    elif case == "text":
        path.write_text("this is not a picture\n")
    elif case == "truncated":
        path.write_bytes(valid[: len(valid) // 2])
    elif case == "bad_crc":
        path.write_bytes(valid[:40] + bytes([valid[40] ^ 0xFF]) + valid[41:])
    elif case == "bad_data":
        path.write_bytes(valid[:-20] + bytes([valid[-20] ^ 0xFF]) + valid[-19:])
    elif case == "header_only":
        path.write_bytes(_png_header_only(32, 32))
    with pytest.raises(ValueError, match=_one_line_error_for(path)) as info:
        load_mark(path)
    assert detail in str(info.value)


def test_uniform_image(tmp_path: Path) -> None:
    path = _save_gray(tmp_path / "blank.png", np.full((16, 16), 77, dtype=np.uint8))
    with pytest.raises(ValueError, match=_one_line_error_for(path)) as info:
        load_mark(path)
    assert "uniform (every pixel is 77)" in str(info.value)


def test_blank_after_resampling(tmp_path: Path) -> None:
    bits = np.zeros((64, 64), dtype=np.uint8)
    bits[0, 0] = 1  # never sampled at size 8 (rows/columns 4, 12, ...)
    path = _save_bits(tmp_path / "dot.png", bits)
    with pytest.raises(ValueError, match=_one_line_error_for(path)) as info:
        load_mark(path, size=8)
    assert "blank after resampling to 8×8" in str(info.value)


def test_path_must_be_a_path() -> None:
    with pytest.raises(TypeError):
        load_mark(123)  # type: ignore[arg-type]


@pytest.mark.parametrize("wrong", [0.0, 0.05, 0.1, 0.2, 0.3])
def test_a_logo_read_with_wrong_bits_keeps_its_share_of_the_drawing(wrong: float) -> None:
    # Scattered wrong bits (the Arnold scrambling scatters them) keep (1 - 2 e)**2 of the
    # correlation: the least wrong read correlates most.
    logo = default_mark(32)
    r0, pairs = neighbour_correlation(logo)
    assert pairs == 2 * 32 * 31 and r0 > 0.4
    for seed in range(5):
        rng = np.random.default_rng(seed)
        read = logo ^ (rng.random(logo.shape) < wrong).astype(np.uint8)
        r, _ = neighbour_correlation(read)
        assert abs(r - r0 * (1 - 2 * wrong) ** 2) < 4 / math.sqrt(pairs)


def test_noise_has_no_drawing_whatever_its_ink() -> None:
    for seed in range(300):
        rng = np.random.default_rng(seed)
        ink = [0.5, 0.2, 0.05][seed % 3]
        noise = (rng.random((32, 32)) < ink).astype(np.uint8)
        r, pairs = neighbour_correlation(noise)
        assert abs(r) * math.sqrt(pairs) < 5


def test_a_drawing_and_its_negative_correlate_alike_and_one_colour_not_at_all() -> None:
    logo = default_mark(32)
    assert neighbour_correlation(1 - logo)[0] == pytest.approx(neighbour_correlation(logo)[0])
    assert neighbour_correlation(np.ones((16, 16), dtype=np.uint8)) == (0.0, 2 * 16 * 15)
    with pytest.raises(ValueError, match="2-D"):
        neighbour_correlation(np.zeros(16, dtype=np.uint8))
