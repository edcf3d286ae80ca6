"""The paper's multi-resolution representation (MRR) of one N×N matrix: Haar wavelets via pywt.

Section 3 of the paper transforms each coordinate matrix of the geometry image (x1, x2, x3,
each N×N) before marking it:

    Step 1: Apply Haar wavelet transform on the 3d model and generate four coefficient sets as
    approximation coefficients matrix CA and details coefficients matrices as CH, CV and CD.
    Step 2: Apply Haar wavelet transform again on CH and CV of detail coefficient matrices to
    generate level 2 approximation and detail coefficient matrices.  Total 8 matrices are
    generated in this step.
    Step 3: Apply Haar wavelet transform again on CH and CV coefficients of level 2 matrices to
    generate level 3 approximations and detail coefficients.  Total 16 matrices are generated
    in this step.

and step 9 applies the inverse transform "up to level 3".  This module is a thin, exact wrapper
around :func:`pywt.dwt2` / :func:`pywt.idwt2` that builds that representation and inverts it,
plus the standard dyadic decomposition (:func:`pywt.wavedec2`) as a second representation.

The paper's tree (a wavelet *packet* tree)
    The steps are read literally, as a packet tree in which only the H and V children are split
    further:

    - level 1: the four subbands ``a``, ``h``, ``v``, ``d`` of the matrix (CA, CH, CV, CD);
    - level 2: the four subbands of ``h`` and the four of ``v``: ``ha hh hv hd`` and
      ``va vh vv vd`` (the 8 matrices of step 2);
    - level 3: the four subbands of the H and V children of each level-2 set, i.e. of ``hh``,
      ``hv``, ``vh`` and ``vv``: ``hha hhh hhv hhd``, ``hva hvh hvv hvd``, ``vha vhh vhv vhd``,
      ``vva vvh vvv vvd`` (the 16 matrices of step 3).

    Read this way the steps give exactly the counts the paper states (4, then 8, then 16).
    A key is the path from the root: its i-th letter is the subband taken at level i, so a key's
    length is its level and an (N, N) matrix gives (N / 2**len(key))-square leaves.

The alternative reading
    The paper builds on Amirgholipour's joint DWT-DCT scheme (its reference [3]), which marks
    the middle-frequency detail bands of an ordinary 3-level DWT, where each level splits the
    previous *approximation*.  Under that reading "CH and CV" in steps 2 and 3 would be a slip
    for CA, and the paper's counts (8, 16) would not hold (a dyadic 3-level transform has 10
    subbands).  Since the project may embed in the level-3 dyadic detail bands instead,
    :func:`dyadic_decompose` / :func:`dyadic_reconstruct` give that representation too.

Letters follow pywt's ``(cA, (cH, cV, cD))`` order for :func:`pywt.dwt2`: ``a`` is low-pass along
both axes; ``h`` is high-pass along axis 0 (rows) and low-pass along axis 1 (pywt's ``'da'``,
horizontal edges); ``v`` is low-pass along axis 0 and high-pass along axis 1 (``'ad'``); ``d``
is high-pass along both (``'dd'``).

Why ``mode='periodization'``
    It is the pywt extension mode under which a one-level DWT of an even-sided matrix returns
    subbands of exactly half the side, so the coefficients number exactly the samples, and, with
    an orthogonal wavelet, the transform is an orthogonal map.  Hence (verified by the tests):
    reconstruction is exact to rounding; the sum of squares of all leaves equals that of the
    matrix (Parseval); and changing one coefficient by ``delta`` changes the reconstructed matrix
    by a pattern of L2 norm exactly ``|delta|``, which is what lets the embedder bound the
    distortion it adds.  For Haar on even sides every pywt mode happens to give the same
    coefficients (the two-tap filter never reaches past the border); with a longer filter the
    other modes add extra boundary coefficients at each level and the transform is no longer
    orthogonal.  Fixing the mode, rather than exposing it, keeps that guarantee if the wavelet
    ever changes, and keeps the extractor's transform identical to the embedder's.

All computation is in float64, whatever the input's real dtype.

References
----------
.. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
   representation and fuzzy logic", section 3, steps 1-3 and 9.
.. [2] G. R. Lee, R. Gommers, F. Wasilewski, K. Wohlfahrt, A. O'Leary, "PyWavelets: A Python
   package for wavelet analysis", JOSS 4(36), 1237, 2019, doi:10.21105/joss.01237.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from meshwm._validate import check_integer

__all__ = [
    "MRR_KEYS",
    "MRR_LEVEL3_KEYS",
    "dyadic_decompose",
    "dyadic_reconstruct",
    "mrr_decompose",
    "mrr_reconstruct",
]

_WAVELET = "haar"
_MODE = "periodization"
_SUBBANDS = ("a", "h", "v", "d")

#: Nodes of the paper's packet tree that are split further, root ("") first.
_MRR_SPLIT = ("", "h", "v", "hh", "hv", "vh", "vv")

#: The 16 level-3 matrices of step 3 (each (N/8, N/8) for an (N, N) matrix).
MRR_LEVEL3_KEYS: tuple[str, ...] = tuple(
    parent + band for parent in ("hh", "hv", "vh", "vv") for band in _SUBBANDS
)

#: Every leaf of the paper's packet tree, by level: the keys of :func:`mrr_decompose`.
MRR_KEYS: tuple[str, ...] = ("a", "d", "ha", "hd", "va", "vd", *MRR_LEVEL3_KEYS)

#: The paper's tree has three levels, so matrices must be at least 2**3 on a side.
_MRR_LEVEL = 3


def mrr_decompose(matrix: NDArray) -> dict[str, NDArray[np.float64]]:
    """Decompose a matrix into the paper's 3-level Haar packet tree (steps 1-3 of [1]_).

    Parameters
    ----------
    matrix : (N, N) array_like of real numbers
        One coordinate matrix of a geometry image; ``N`` a power of two, at least 8.  It is
        not modified; the transform is computed in float64.

    Returns
    -------
    coeffs : dict of str to float64 ndarray
        The 22 leaves of the tree, keyed by path (see the module docstring), in the order of
        :data:`MRR_KEYS`: ``"a"`` and ``"d"`` of level 1, shape (N/2, N/2); ``"ha"``, ``"hd"``,
        ``"va"`` and ``"vd"`` of level 2, shape (N/4, N/4); and the 16 level-3 matrices of
        :data:`MRR_LEVEL3_KEYS`, shape (N/8, N/8).  The intermediate nodes ``h``, ``v``, ``hh``,
        ``hv``, ``vh`` and ``vv`` are not returned: they are determined by their children.

    Raises
    ------
    TypeError
        ``matrix`` does not hold real numbers (bool, complex, strings, objects).
    ValueError
        ``matrix`` is not square and 2-D, its side is not a power of two >= 8, or it contains
        NaN or infinite values.

    See Also
    --------
    mrr_reconstruct : the inverse.
    dyadic_decompose : the standard dyadic 3-level decomposition.

    Notes
    -----
    Each split is one level of :func:`pywt.dwt2` with ``'haar'`` and ``mode='periodization'``, an
    orthogonal map.  The tree is therefore orthogonal as a whole: ``sum(c**2)`` over all leaves
    equals ``sum(matrix**2)``, and the leaves hold exactly ``N**2`` numbers.

    References
    ----------
    .. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
       representation and fuzzy logic", section 3, steps 1-3.

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.signal.wavelet import mrr_decompose
    >>> x = np.arange(64.0).reshape(8, 8)
    >>> coeffs = mrr_decompose(x)
    >>> len(coeffs), coeffs["a"].shape, coeffs["hd"].shape, coeffs["hvh"].shape
    (22, (4, 4), (2, 2), (1, 1))
    >>> round(float(sum((c**2).sum() for c in coeffs.values())), 6) == float((x**2).sum())
    True
    """
    import pywt  # imported on use: the constants above are needed without it

    x = _check_matrix(matrix, level=_MRR_LEVEL, name="matrix")
    nodes = {"": x}
    for path in _MRR_SPLIT:
        a, (h, v, d) = pywt.dwt2(nodes.pop(path), _WAVELET, mode=_MODE)
        nodes.update({path + "a": a, path + "h": h, path + "v": v, path + "d": d})
    return {key: nodes[key] for key in MRR_KEYS}


def mrr_reconstruct(coeffs: Mapping[str, NDArray]) -> NDArray[np.float64]:
    """Rebuild the matrix from the leaves of the paper's packet tree (step 9 of [1]_).

    Parameters
    ----------
    coeffs : mapping of str to array_like
        Exactly the keys of :data:`MRR_KEYS`, with the shapes :func:`mrr_decompose` returns for
        some (N, N) matrix, N a power of two >= 8; possibly modified.  Not modified here.

    Returns
    -------
    matrix : (N, N) float64 ndarray

    Raises
    ------
    TypeError
        ``coeffs`` is not a mapping, or a value does not hold real numbers.
    ValueError
        Missing or unexpected keys, inconsistent shapes, or NaN or infinite values.

    See Also
    --------
    mrr_decompose : the forward transform.

    Notes
    -----
    The tree is orthogonal, so changing one coefficient by ``delta`` changes the result by a
    pattern whose L2 (Frobenius) norm is exactly ``|delta|``.

    References
    ----------
    .. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
       representation and fuzzy logic", section 3, step 9.

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.signal.wavelet import mrr_decompose, mrr_reconstruct
    >>> x = np.arange(64.0).reshape(8, 8)
    >>> coeffs = mrr_decompose(x)
    >>> bool(np.allclose(mrr_reconstruct(coeffs), x, rtol=0, atol=1e-12))
    True
    >>> coeffs["hhh"] = coeffs["hhh"] + 0.5
    >>> round(float(np.linalg.norm(mrr_reconstruct(coeffs) - x)), 12)
    0.5
    """
    import pywt  # imported on use: the constants above are needed without it

    leaves = _check_coeffs(coeffs, MRR_KEYS, name="coeffs")
    side = leaves["a"].shape[0] * 2
    _check_shapes(leaves, {key: side >> len(key) for key in MRR_KEYS}, side, _MRR_LEVEL)
    nodes = dict(leaves)
    for path in reversed(_MRR_SPLIT):
        bands = [nodes.pop(path + band) for band in _SUBBANDS]
        nodes[path] = pywt.idwt2((bands[0], tuple(bands[1:])), _WAVELET, mode=_MODE)
    return nodes[""]


def dyadic_decompose(matrix: NDArray, *, level: int = 3) -> dict[str, NDArray[np.float64]]:
    """Standard dyadic Haar decomposition (each level splits the previous approximation).

    The alternative representation discussed in the module docstring: :func:`pywt.wavedec2`
    with ``'haar'`` and ``mode='periodization'``.

    Parameters
    ----------
    matrix : (N, N) array_like of real numbers
        ``N`` a power of two, at least ``2**level``.  Not modified; computed in float64.
    level : int, optional
        Number of levels, at least 1; default 3.

    Returns
    -------
    coeffs : dict of str to float64 ndarray
        ``f"a{level}"``, the approximation at the coarsest level, of shape (M, M) with
        M = N / 2**level, then ``f"h{k}"``, ``f"v{k}"``, ``f"d{k}"`` for k = level down to 1
        (pywt's order), of shape (N / 2**k, N / 2**k).  For ``level=3``:
        ``a3 h3 v3 d3 h2 v2 d2 h1 v1 d1``; the level-3 detail bands are ``h3``, ``v3``, ``d3``.

    Raises
    ------
    TypeError
        ``level`` is not an integer, or ``matrix`` does not hold real numbers.
    ValueError
        ``level`` < 1; ``matrix`` not square and 2-D, its side not a power of two >=
        ``2**level``; or NaN or infinite values.

    See Also
    --------
    dyadic_reconstruct : the inverse.
    mrr_decompose : the paper's packet tree.

    Notes
    -----
    Orthogonal, like :func:`mrr_decompose`: Parseval holds and a change ``delta`` in one
    coefficient moves the matrix by exactly ``|delta|`` in L2.

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.signal.wavelet import dyadic_decompose
    >>> coeffs = dyadic_decompose(np.ones((16, 16)))
    >>> list(coeffs)
    ['a3', 'h3', 'v3', 'd3', 'h2', 'v2', 'd2', 'h1', 'v1', 'd1']
    >>> coeffs["a3"].shape, coeffs["d1"].shape, round(float(coeffs["a3"][0, 0]), 12)
    ((2, 2), (8, 8), 8.0)
    """
    import pywt  # imported on use: the constants above are needed without it

    level = _check_level(level)
    x = _check_matrix(matrix, level=level, name="matrix")
    approx, *details = pywt.wavedec2(x, _WAVELET, mode=_MODE, level=level)
    coeffs = {f"a{level}": approx}
    for k, (h, v, d) in zip(range(level, 0, -1), details, strict=True):
        coeffs.update({f"h{k}": h, f"v{k}": v, f"d{k}": d})
    return coeffs


def dyadic_reconstruct(coeffs: Mapping[str, NDArray]) -> NDArray[np.float64]:
    """Invert :func:`dyadic_decompose`; the level is read from the ``a{level}`` key.

    Parameters
    ----------
    coeffs : mapping of str to array_like
        Exactly the keys :func:`dyadic_decompose` returns for some level, with its shapes;
        possibly modified.  Not modified here.

    Returns
    -------
    matrix : (N, N) float64 ndarray

    Raises
    ------
    TypeError
        ``coeffs`` is not a mapping, or a value does not hold real numbers.
    ValueError
        No single ``a{level}`` key, missing or unexpected keys, inconsistent shapes, or NaN or
        infinite values.

    Examples
    --------
    >>> import numpy as np
    >>> from meshwm.signal.wavelet import dyadic_decompose, dyadic_reconstruct
    >>> x = np.arange(256.0).reshape(16, 16)
    >>> bool(np.allclose(dyadic_reconstruct(dyadic_decompose(x)), x, rtol=0, atol=1e-12))
    True
    """
    import pywt  # imported on use: the constants above are needed without it

    if not isinstance(coeffs, Mapping):
        raise TypeError(f"coeffs must be a dict of subbands, got {type(coeffs).__name__}")
    approx = [key for key in coeffs if isinstance(key, str) and _is_approx_key(key)]
    if len(approx) != 1:
        raise ValueError(
            f"coeffs must have exactly one approximation key 'a<level>' (as dyadic_decompose "
            f"returns), got {sorted(map(str, approx)) or 'none'}"
        )
    level = int(approx[0][1:])
    keys = (approx[0], *(f"{b}{k}" for k in range(level, 0, -1) for b in "hvd"))
    leaves = _check_coeffs(coeffs, keys, name="coeffs")
    side = leaves[approx[0]].shape[0] << level
    _check_shapes(leaves, {key: side >> int(key[1:]) for key in keys}, side, level)
    details = [tuple(leaves[f"{b}{k}"] for b in "hvd") for k in range(level, 0, -1)]
    return pywt.waverec2([leaves[approx[0]], *details], _WAVELET, mode=_MODE)


def _is_approx_key(key: str) -> bool:
    """``"a1"``, ``"a2"``, ...: the approximation key of a dyadic decomposition."""
    return key[:1] == "a" and key[1:].isdigit() and key == f"a{int(key[1:])}" and key != "a0"


def _check_level(level: int) -> int:
    return check_integer(level, name="level", low=1)


def _as_real(value: NDArray, name: str) -> NDArray[np.float64]:
    """``value`` as a float64 array (no copy when it already is one); reject non-real dtypes."""
    arr = np.asarray(value)
    if arr.dtype == np.bool_ or not (
        np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)
    ):
        raise TypeError(f"{name} must hold real numbers (int or float), got dtype {arr.dtype}")
    return np.asarray(arr, dtype=np.float64)


def _check_finite(arr: NDArray[np.float64], name: str) -> None:
    bad = int(np.count_nonzero(~np.isfinite(arr)))
    if bad:
        raise ValueError(f"{name} contains {bad} NaN or infinite values; all must be finite")


def _check_matrix(matrix: NDArray, *, level: int, name: str) -> NDArray[np.float64]:
    x = _as_real(matrix, name)
    smallest = 1 << level
    side = x.shape[0] if x.ndim == 2 else 0
    if x.ndim != 2 or x.shape[1] != side or side < smallest or side & (side - 1):
        raise ValueError(
            f"{name} must be a square 2-D array whose side is a power of two >= {smallest} "
            f"(2**level, level {level}), got shape {x.shape}"
        )
    _check_finite(x, name)
    return x


def _check_coeffs(
    coeffs: Mapping[str, NDArray], keys: tuple[str, ...], *, name: str
) -> dict[str, NDArray[np.float64]]:
    """Check the key set and the values' dtypes, dimensions and finiteness; keep ``keys`` order."""
    if not isinstance(coeffs, Mapping):
        raise TypeError(f"{name} must be a dict of subbands, got {type(coeffs).__name__}")
    missing = [key for key in keys if key not in coeffs]
    unexpected = sorted(str(key) for key in coeffs if key not in keys)
    if missing or unexpected:
        raise ValueError(
            f"{name} must have exactly the keys {list(keys)}; missing {missing}, "
            f"unexpected {unexpected}"
        )
    leaves = {}
    for key in keys:
        arr = _as_real(coeffs[key], f"{name}[{key!r}]")
        if arr.ndim != 2:
            raise ValueError(f"{name}[{key!r}] must be a 2-D array, got shape {arr.shape}")
        _check_finite(arr, f"{name}[{key!r}]")
        leaves[key] = arr
    return leaves


def _check_shapes(
    leaves: dict[str, NDArray[np.float64]], sides: dict[str, int], side: int, level: int
) -> None:
    """Every leaf must be square of the side its level implies for a power-of-two ``side``."""
    if side < (1 << level) or side & (side - 1):
        shapes = {key: arr.shape for key, arr in leaves.items()}
        raise ValueError(
            f"coefficient shapes {shapes} do not come from a square matrix whose side is a "
            f"power of two >= {1 << level}"
        )
    for key, arr in leaves.items():
        if arr.shape != (sides[key], sides[key]):
            raise ValueError(
                f"coeffs[{key!r}] must have shape {(sides[key], sides[key])} for a "
                f"{side}×{side} matrix, got {arr.shape}"
            )
