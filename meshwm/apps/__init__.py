"""Applications built on the library: what a person runs, none of the watermarking itself.

:mod:`~meshwm.apps.cli` is the ``meshwm`` command (one module per command, each importing the
library only when it runs); :mod:`~meshwm.apps.batch` verifies many files in parallel processes
or on a Dask cluster; :mod:`~meshwm.apps.demo` is ``meshwm demo``; :mod:`~meshwm.apps.render`
draws shaded views and distance heat maps; :mod:`~meshwm.apps.bench` reproduces the paper's
tables beside ours.  Each composes :mod:`meshwm.watermark`, :mod:`meshwm.attacks` and
:mod:`meshwm.mesh`, and nothing downstream of the library imports from here.
"""
