"""The robust profile: dither modulation on smooth level-3 wavelet details in local frames.

The paper's scheme (:mod:`meshwm.profiles.paper`) hides bits in the level-3 packets
of its Haar tree, which all descend from the *level-1* details: a 3×3 blur of the geometry
image, a few steps of Laplacian smoothing or 8-bit quantisation of the coordinates erase them.
This module is meshwm's default for real pipelines.  Every choice below was measured on the
development meshes (docs/robust.md has the tables); in short:

1. **Band.** The level-3 *dyadic* details (H, V, D; 32×32 each at N = 256) of x, y and z:
   coarse enough to survive noise and quantisation, fine enough for 9 coefficients per
   position (8,100 slots, about 8 per bit of a 32×32 mark).  Level 2 loses to noise, level 4
   has too few coefficients, and level 3 + 4 together cost twice the distortion.
2. **Wavelet.** ``sym4`` (orthogonal, ``mode="periodization"``), not Haar: smoothing shrinks
   a Haar change (a step pattern) far more than the host, and a smooth atom less.  Longer
   filters (sym8) spread each atom over ~100 samples, which cropping then corrupts.
3. **Local frames.** Each level-3 position gets an orthonormal frame from the level-3
   *approximation*, which embedding does not change: tangent along the grid's first axis,
   normal, and their cross product.  Coefficients are read as 3-D vectors in that frame, so
   rotation and translation change nothing, and nothing depends on the whole model: a crop
   leaves the frames of the rest intact.
4. **Unit and steps.** Coefficients are divided by the *median* sample spacing of the
   approximation (uniform scale changes nothing; a crop moves the median a little, which the
   gain search absorbs).  One unit for the whole model, not the local spacing: quantisation
   and noise are uniform in space, and a per-position unit starved finely sampled regions
   (8-bit quantisation of plane_holes: corr2 0.80 with local units, 0.99 with one).  The
   tangential components take ``step``, the normal one :data:`NORMAL_RATIO` of it (a move
   along the surface barely changes the shape; 0.1 and 0.5 both measured worse), and the
   fuzzy perceptual guard multiplies the step by :data:`GUARD_RATIO` where
   :func:`meshwm.signal.mask.perceptual_weight` of the approximation says LOWEST..LOW (smooth
   regions, where a change shows most).  With ``tangential_step=None`` the step is calibrated
   per mesh so that :func:`~meshwm.profiles.robust.embed.normal_distortion` (a first-order MRMS)
   equals ``distortion`` (:class:`~meshwm.profiles.robust.options.RobustOptions`).
5. **Key and modulation.** An HMAC-SHA256 permutation deals the slots (band, component,
   position) to the bits, with a keyed dither per slot: dither modulation [2]_, distortion
   compensated: a coefficient moves :data:`ALPHA` = 0.7 of the way to its lattice point and
   the step grows to keep the distortion, which trades a little self-noise for a larger
   step (7-bit quantisation: corr2 0.52-0.66 → 0.67-0.85).  Without attack every vote still
   has the right sign (self-noise ≤ 0.15 of a step).
6. **Decoding.** Soft: each carrier votes ``cos 2π(c/Δ − u)`` (+1 for 0, −1 for 1), weighted
   by how much of its atom lies on samples the mesh still has, and by the reliability of its
   (band, component) group estimated from the data
   (:func:`meshwm.profiles.robust.decode._group_reliability`).  The decoder searches a gain
   ``g`` (``Δ → gΔ``, a factor 16 either way) that maximises
   ``Σ_bits |Σ votes|``, so it needs no step.  (With distortion compensation a model whose
   details are all far below a step also fits ``g ≈ ALPHA``; the bits are the same.)
7. **Candidates** (:mod:`meshwm.profiles.robust.search`): uniform Laplacian smoothing is a
   known, invertible linear map of the received mesh's own connectivity; when the mesh as
   received decodes weakly, the decoder also tries it despiked, then the reader's images with
   5, 10, ..., 60 steps undone, and keeps the best.
8. **Seams.** Samples on the grid border (welded cut seams, open boundaries) never move:
   the change is zeroed there and the slots re-targeted, three rounds.

References
----------
.. [1] S. C. Tamane, R. R. Deshmukh, "Blind 3D model watermarking based on multi-resolution
   representation and fuzzy logic".
.. [2] B. Chen, G. W. Wornell, "Quantization index modulation", IEEE Trans. Inf. Theory
   47(4), 2001, doi:10.1109/18.923725.

Modules: :mod:`~meshwm.profiles.robust.options` (the options), :mod:`~.slots` (transform,
frames, keyed layout, steps), :mod:`~.embed`, :mod:`~.decode` (one image), :mod:`~.search`
(the candidates of a received mesh), :mod:`~.profile` (the registered profile).
"""

from meshwm.profiles.robust.options import RobustOptions

__all__ = ["RobustOptions"]
