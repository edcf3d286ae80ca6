"""The mark: a small square binary image (section 3, step 4 of the paper).

The paper embeds a logo "converted into binary format" and measures success by the
correlation between the original and the extracted logo.  Here a mark is an ``(n, n)`` uint8
array of 0/1 with ``n`` in 8..256: 1 is ink (dark), 0 is background (light).

- :func:`load_mark` reads any image Pillow can read and binarises it;
- :func:`save_mark` writes a mark as a black-and-white 1-bit PNG;
- :func:`default_mark` is meshwm's own 32×32 logo (also shipped as ``assets/mark32.png``);
- :func:`neighbour_correlation` tells a drawing from noise (a blind reader's pick of a logo).

References
----------
.. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
   representation and fuzzy logic", section 3 step 4 and section 4.
"""

from __future__ import annotations

import io
import os
import struct
import warnings
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from PIL import Image, ImageOps, UnidentifiedImageError

from meshwm._atomic import write_atomic

__all__ = [
    "MARK_SIZE_RANGE",
    "MAX_IMAGE_SIDE",
    "default_mark",
    "load_mark",
    "neighbour_correlation",
    "save_mark",
]

PathLike = str | os.PathLike[str]

#: Smallest and largest side of a mark, in pixels (inclusive).
MARK_SIZE_RANGE = (8, 256)
#: Largest side of an image file load_mark decodes, in pixels.
MAX_IMAGE_SIDE = 4096

#: Pillow modes holding more than 8 bits of gray: read as numbers, not through mode "L"
#: (Pillow's conversion to "L" clips 16-bit values at 255).
_NUMERIC_MODES = frozenset({"I", "I;16", "I;16B", "I;16L", "I;16N", "F"})

#: What Pillow and its format plugins raise on files they cannot decode.
_DECODE_ERRORS = (
    OSError,  # includes UnidentifiedImageError and "image file is truncated"
    Image.DecompressionBombError,
    Image.DecompressionBombWarning,  # turned into an error while decoding
    SyntaxError,  # raised by several plugins for malformed headers
    ValueError,
    EOFError,
    struct.error,
    IndexError,
    KeyError,
    TypeError,
    ZeroDivisionError,
)

#: meshwm's logo, row by row ('#' = ink).  A frame, the letters "WM", a bar, a framed square,
#: rising bars, a dashed rule that runs into the right edge and a block at the bottom right.
#: "WM" alone is (nearly) symmetric under a half turn; the details below it are not, so the 8
#: rotations and reflections of the square all differ from the logo in many pixels.
_LOGO = """
################################
#..............................#
#.##.........##..##.........##.#
#.##.........##..###.......###.#
#.##.........##..####.....####.#
#.##.........##..##.##...##.##.#
#.##...###...##..##..##.##..##.#
#.##..##.##..##..##...###...##.#
#.##.##...##.##..##.........##.#
#.####.....####..##.........##.#
#.###.......###..##.........##.#
#.##.........##..##.........##.#
#..............................#
#.#####################........#
#.#####################........#
#..............................#
#..............................#
#.######..............##.......#
#.#....#..............##.......#
#.#.##.#..........##..##.......#
#.#.##.#..........##..##..##...#
#.#....#......##..##..##..##...#
#.######......##..##..##..##...#
#.............##..##..##..##...#
#..............................#
#.##.##.##.##.##.##.##.##.##.###
#..............................#
#..............................#
#.......................####...#
#.......................####...#
#..............................#
################################
"""


def _check_mark_size(size: object, name: str = "size") -> int:
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)):
        raise TypeError(f"{name} must be an integer, got {type(size).__name__}")
    low, high = MARK_SIZE_RANGE
    if not low <= size <= high:
        raise ValueError(f"{name} must be between {low} and {high} pixels, got {size}")
    return int(size)


def _error(path: PathLike, detail: str) -> ValueError:
    """One-line ``ValueError("<path>: <detail>")``."""
    return ValueError(" ".join(f"{os.fspath(path)}: {detail}".split()))


def _describe(exc: BaseException) -> str:
    text = " ".join(str(exc).split())[:200]
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _resample_nearest(array: NDArray, size: int) -> NDArray:
    """Nearest-neighbour resampling of a 2-D array to ``size``×``size`` (pixel centres).

    Output pixel ``i`` takes input pixel ``floor((i + 1/2) · h / size)``, in integer
    arithmetic; enlarging by a whole factor repeats each pixel exactly.
    """
    height, width = array.shape
    index = 2 * np.arange(size, dtype=np.int64) + 1
    return array[np.ix_(index * height // (2 * size), index * width // (2 * size))]


class _TooLarge(Exception):
    """The image's header declares more than ``MAX_IMAGE_SIDE`` pixels on a side."""


def _decode_gray(path: PathLike) -> NDArray:
    """Decode ``path`` to a 2-D array of gray levels (uint8, or wider for deep images).

    The size in the header is checked before any pixel is decoded (raising ``_TooLarge``).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # e.g. Pillow's notes on odd EXIF or palettes
        warnings.simplefilter("error", Image.DecompressionBombWarning)
        with Image.open(path) as image:
            width, height = image.size
            if max(width, height) > MAX_IMAGE_SIDE:
                raise _TooLarge(f"{width}×{height}")
            upright: Image.Image = ImageOps.exif_transpose(image)  # as it is meant to be viewed
            if upright.mode in _NUMERIC_MODES:
                return np.array(upright)
            if "A" in upright.getbands() or "transparency" in upright.info:
                rgba = upright.convert("RGBA")
                white = Image.new("RGBA", rgba.size, (255, 255, 255, 255))
                upright = Image.alpha_composite(white, rgba)
            return np.array(upright.convert("L"))


def load_mark(path: PathLike, *, size: int | None = None) -> NDArray[np.uint8]:
    """Read an image file and binarise it into a mark (1 = dark ink, 0 = light background).

    Parameters
    ----------
    path : str or os.PathLike
        Any image Pillow can read (PNG, BMP, GIF, TIFF, JPEG, ...).  Only the first frame of
        an animation is used.
    size : int, optional
        Resample the image to ``size``×``size`` pixels (nearest neighbour), 8..256.  Default:
        keep the image's own size, which must then be square with a side in 8..256.

    Returns
    -------
    (n, n) uint8 ndarray
        0/1, with ``n = size`` if given.

    Raises
    ------
    ValueError
        The file is missing, a directory, unreadable, not an image, truncated or corrupt; the
        image is larger than 4096 pixels on a side; it is not square and ``size`` is not
        given; its side (or ``size``) is outside 8..256; or the result is blank (all ink or
        all background).  A problem with the file gives a one-line message that starts with
        ``path``.
    TypeError
        ``size`` is not an integer.

    Notes
    -----
    The image is first shown as it is meant to be viewed: its EXIF orientation is applied
    and transparent pixels are composited over white.  It is then converted to gray (Pillow's
    ITU-R 601-2 luma, ``L = 0.299 R + 0.587 G + 0.114 B``; 16-bit and float images keep their
    own levels) and thresholded at the midpoint between its darkest and lightest gray level:
    a pixel is ink when ``gray < (min + max) / 2`` (ties go to the background).  The midpoint
    rather than Otsu's threshold because a mark is meant to be two-toned: for a
    black-and-white or anti-aliased logo the two agree, and the midpoint is one line,
    independent of the histogram.  The threshold is taken over the whole image before any
    resampling, then the binary image is resampled: output pixel ``i`` takes source pixel
    ``floor((i + 1/2) · h / size)`` (pixel centres, like Pillow's ``NEAREST``), so enlarging by
    a whole factor repeats each pixel exactly.  A non-square image is stretched to the
    square; its aspect ratio is not kept.  Pillow's warnings are silenced while decoding
    (its decompression-bomb warning becomes this function's ``ValueError``); the warning
    filters are process-global, so this is not thread-safe.

    Examples
    --------
    >>> import os, tempfile
    >>> from meshwm.message.mark import default_mark, load_mark, save_mark
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     save_mark(os.path.join(tmp, "mark.png"), default_mark())
    ...     mark = load_mark(os.path.join(tmp, "mark.png"), size=64)
    >>> mark.shape, mark.dtype.name, bool((mark[::2, ::2] == default_mark()).all())
    ((64, 64), 'uint8', True)
    """
    os.fspath(path)  # TypeError for anything that is not a path
    if size is not None:
        size = _check_mark_size(size)
    try:
        gray = _decode_gray(path)
    except _TooLarge as exc:
        raise _error(
            path, f"image is {exc} pixels, larger than the limit of {MAX_IMAGE_SIDE} per side"
        ) from None
    except FileNotFoundError:
        raise _error(path, "no such file") from None
    except IsADirectoryError:
        raise _error(path, "is a directory, not an image file") from None
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
        raise _error(path, f"image is too large to decode ({exc})") from None
    except UnidentifiedImageError:
        raise _error(path, "not a readable image (unknown format or corrupt header)") from None
    except OSError as exc:
        if exc.strerror:  # an operating-system error, e.g. permission denied
            raise _error(path, f"cannot read file ({exc.strerror})") from None
        raise _error(path, f"corrupt or truncated image ({_describe(exc)})") from None
    except _DECODE_ERRORS as exc:
        raise _error(path, f"corrupt or unreadable image ({_describe(exc)})") from None

    height, width = gray.shape
    if size is None:
        if height != width:
            raise _error(path, f"image is {width}×{height}, not square; pass size= to resample")
        low, high = MARK_SIZE_RANGE
        if not low <= height <= high:
            raise _error(
                path, f"image is {width}×{height}, outside {low}..{high}; pass size= to resample"
            )
    gray = gray.astype(np.float64)  # exact for every Pillow mode (at most 32-bit integers)
    if not np.isfinite(gray).all():
        raise _error(path, "image has NaN or infinite gray levels")
    darkest, lightest = gray.min(), gray.max()
    if darkest == lightest:
        raise _error(
            path, f"image is uniform (every pixel is {darkest:g}); a mark needs ink and paper"
        )
    bits = (2.0 * gray < darkest + lightest).astype(np.uint8)
    if size is not None:
        bits = _resample_nearest(bits, size)
        if bits.min() == bits.max():
            raise _error(
                path, f"mark is blank after resampling to {size}×{size}; use a larger size"
            )
    return np.ascontiguousarray(bits)


def _check_bits(bits: NDArray) -> NDArray[np.uint8]:
    array = np.asarray(bits)
    if array.dtype != np.bool_ and array.dtype.kind not in "iuf":
        raise TypeError(f"bits must be an array of 0/1 numbers, got dtype {array.dtype}")
    if array.ndim != 2 or array.size == 0:
        raise ValueError(f"bits must be a non-empty 2-D array, got shape {array.shape}")
    if max(array.shape) > MAX_IMAGE_SIDE:
        raise ValueError(
            f"bits must be at most {MAX_IMAGE_SIDE} pixels per side, got shape {array.shape}"
        )
    bad = (array != 0) & (array != 1)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise ValueError(
            f"bits must hold only 0 and 1, got {array[row, col].item()!r} at ({row}, {col})"
        )
    return array.astype(np.uint8)


def save_mark(path: PathLike, bits: NDArray) -> None:
    """Write a mark as a black (1) and white (0) 1-bit PNG, atomically.

    Parameters
    ----------
    path : str or os.PathLike
        Output file; its suffix must be ``.png``.
    bits : (h, w) array_like
        0/1 values (bool, integer or float).  :func:`load_mark` reads it back exactly when it
        is square with a side in 8..256.

    Raises
    ------
    TypeError
        ``bits`` is not numeric.
    ValueError
        ``bits`` is not a non-empty 2-D array of 0/1 at most 4096 pixels per side, the suffix
        is not ``.png``, or the file cannot be written (one line, starting with ``path``).

    Notes
    -----
    The PNG is built in memory, written to a temporary file in the target's directory,
    fsynced and moved onto ``path`` with :func:`os.replace`, so ``path`` is never left half
    written; on failure the temporary file is removed.  The file holds no metadata or
    timestamp, so the same bits give the same bytes with the same zlib build (the pixels,
    not the compressed bytes, are what :func:`load_mark` guarantees across builds).  A new
    file gets the usual permissions (``0o666`` minus the umask); an overwritten one keeps its
    own.

    Examples
    --------
    >>> import os, tempfile
    >>> from meshwm.message.mark import default_mark, load_mark, save_mark
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     save_mark(os.path.join(tmp, "mark.png"), default_mark())
    ...     same = bool((load_mark(os.path.join(tmp, "mark.png")) == default_mark()).all())
    >>> same
    True
    """
    if Path(os.fspath(path)).suffix.lower() != ".png":
        raise _error(path, "a mark is written as PNG; give the file a .png suffix")
    array = _check_bits(bits)
    height, width = array.shape
    # Mode "1" raw data: one bit per pixel, most significant first, rows padded to bytes,
    # bit set = white.  Ink (1) is black.
    packed = np.packbits(array == 0, axis=1)
    buffer = io.BytesIO()
    Image.frombytes("1", (width, height), packed.tobytes()).save(buffer, format="PNG")
    payload = buffer.getvalue()

    try:
        write_atomic(path, payload)
    except OSError as exc:
        raise _error(path, f"cannot write file ({exc.strerror or _describe(exc)})") from None


def default_mark(size: int = 32) -> NDArray[np.uint8]:
    """meshwm's own logo: "WM" in a frame, with asymmetric details.

    Parameters
    ----------
    size : int, optional
        Side of the mark in pixels, 8..256; default 32, the size it is drawn at.  Other sizes
        are resampled from the 32×32 drawing by nearest neighbour (as in :func:`load_mark`):
        64, 128 and 256 repeat each pixel exactly, smaller sizes lose strokes.

    Returns
    -------
    (size, size) uint8 ndarray
        0/1, 1 = ink; a new array on every call.

    Raises
    ------
    TypeError
        ``size`` is not an integer.
    ValueError
        ``size`` is outside 8..256.

    Notes
    -----
    Drawn from a character grid in this module, no randomness.  About 36 % of the pixels
    are ink.  "WM" is nearly symmetric under a half turn, so the drawing adds a bar, a framed
    square, rising bars and a block in one corner: each of the 7 other rotations and
    reflections of the square differs from the logo in at least 20 % of its pixels, so an
    extracted mark that came out rotated or mirrored is told apart from the right one.  The
    same bits are stored in ``assets/mark32.png``.

    Examples
    --------
    >>> from meshwm.message.mark import default_mark
    >>> mark = default_mark()
    >>> mark.shape, mark.dtype.name, int(mark.sum())
    ((32, 32), 'uint8', 370)
    >>> "".join(".#"[bit] for bit in mark[2, :16])
    '#.##.........##.'
    """
    size = _check_mark_size(size)
    logo = np.array([[char == "#" for char in line] for line in _LOGO.split()], dtype=np.uint8)
    return np.ascontiguousarray(logo if size == logo.shape[0] else _resample_nearest(logo, size))


def neighbour_correlation(mark: NDArray) -> tuple[float, int]:
    """How much a mark's neighbouring pixels agree beyond what its ink fraction explains.

    Parameters
    ----------
    mark : (n, m) array_like of 0/1
        A mark (extracted: its bits unscrambled).

    Returns
    -------
    r : float
        The autocorrelation at one pixel's distance of the ±1 pixels (about their mean), over
        every horizontally or vertically adjacent pair: about 0.5 for a logo (meshwm's:
        0.465), 0 for noise, whatever the ink fraction; 0 for a mark of one colour.
    pairs : int
        How many pairs: on independent pixels ``r`` has a standard deviation of about
        ``1 / sqrt(pairs)`` (0.022 on a 32×32 mark).

    Notes
    -----
    A logo is a drawing: its strokes and fields make neighbours agree.  A mark read with a bit
    error rate ``e`` keeps ``(1 - 2 e)**2`` of its correlation (the errors are scattered over
    the image by the Arnold scrambling), so among the images a blind reader offers, the one
    whose extracted mark correlates most is the one with the fewest wrong bits; a read of
    noise (an image that does not carry the mark) correlates at 0.  Tamane and Deshmukh judge
    an extracted logo by eye and by its correlation with the original; this asks the same
    question without the original.

    Examples
    --------
    >>> r, pairs = neighbour_correlation(default_mark())
    >>> round(r, 3), pairs
    (0.465, 1984)
    >>> neighbour_correlation(np.zeros((8, 8), dtype=np.uint8))
    (0.0, 112)
    """
    pm = 2.0 * np.asarray(mark, dtype=np.float64) - 1.0
    if pm.ndim != 2:
        raise ValueError(f"a mark is a 2-D array, got shape {pm.shape}")
    products = np.concatenate([(pm[1:] * pm[:-1]).ravel(), (pm[:, 1:] * pm[:, :-1]).ravel()])
    pairs = int(products.size)
    mean = float(pm.mean()) if pm.size else 0.0
    spread = 1.0 - mean * mean
    if pairs == 0 or spread <= 1e-12:
        return 0.0, pairs
    return float((products.mean() - mean * mean) / spread), pairs
