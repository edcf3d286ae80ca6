"""The errors meshwm raises for bad input, all :class:`ValueError` subclasses.

Every message is one line that names what was wrong, the value received and, where there is one,
the fix; the command line prints it on stderr and exits with code 2.
"""

from __future__ import annotations

__all__ = ["CapacityError", "GridError", "MeshError", "RegistryError"]


class MeshError(ValueError):
    """A mesh (or mesh file) that meshwm cannot work with; the message is one line."""


class GridError(ValueError):
    """The connectivity is not (part of) a regular N×N grid meshwm could have written."""


class CapacityError(ValueError):
    """A payload longer than the geometry image can carry; the message names the largest."""


class RegistryError(ValueError):
    """An asset registry that cannot be opened or used, or an id it does not hold.

    The message is one line and names the registry (a path, or a URL without its password).
    """
