"""The radial carrier: spread-transform dither modulation on a spherical geometry image.

The mark on a mesh kept as it is (:mod:`meshwm.watermark.keep`) is carried twice.  The profile's
own mark lives in the surface map's image (:mod:`meshwm.gim.surface`), which survives noise,
quantisation and smoothing but not edits of the connectivity.  This carrier lives in the
spherical image of the vertices' radii (:mod:`meshwm.gim.sphere`), which edits of the
connectivity do not change at all: flipped edges, re-triangulated quads, split or welded seams,
an STL soup.

Method
------
The image's level-3 ``sym4`` details (periodic extension) are the slots, ``3 (N/8)²`` of them.
A key (HMAC-SHA256, :mod:`meshwm.message.keying`) deals each bit an equal share of the slots and
a sign for each; the bit's *projection* is the signed sum of its slots over the square root of
their number, and it is quantised with a fixed step :data:`RADIAL_STEP` (in units of the point
set's RMS radius, which a similarity does not change) and a keyed dither, to the integer
lattice for a 0 and the half-integer one for a 1 (Chen & Wornell's dither modulation, spread
over several coefficients: spread-transform dither modulation).  Reading needs no search: each
bit's confidence is ``-cos 2π(projection / step - dither)``.
"""

from meshwm.profiles.radial.scheme import (
    RADIAL_LEVEL,
    RADIAL_STEP,
    RadialLayout,
    radial_layout,
    radial_projections,
    radial_spread,
    read_radial_bits,
)

__all__ = [
    "RADIAL_LEVEL",
    "RADIAL_STEP",
    "RadialLayout",
    "radial_layout",
    "radial_projections",
    "radial_spread",
    "read_radial_bits",
]
