"""The paper's scheme (Tamane & Deshmukh), made exact: for the side-by-side benchmark.

Bits go into the 16 level-3 matrices of the paper's Haar packet tree, in a pose-free frame,
where its fuzzy perceptual mask says HIGH or HIGHER, by a dithered remainder rule.  Modules:
:mod:`~meshwm.profiles.paper.options` (its options), :mod:`~meshwm.profiles.paper.scheme` (the
method, with the notes on every choice), :mod:`~meshwm.profiles.paper.profile` (the registered
profile).
"""

from meshwm.profiles.paper.options import PaperOptions

__all__ = ["PaperOptions"]
