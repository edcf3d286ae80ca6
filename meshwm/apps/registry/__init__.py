"""The asset registry: which marked copy of which asset went to whom (storage only).

A studio records every copy it sends out: the input asset (its SHA-256, size, a shape
descriptor and the caller's opaque reference data per grid size) and each marked copy (its
payload, recipient, output file and the embedding's params).  It lives in an SQLite file or a
PostgreSQL database, through one SQLAlchemy Core code path (:mod:`.backends` holds what differs);
the tables are in :mod:`.schema`, the entries and records in :mod:`.entries`.  The registry
never holds a key.  The command line is ``meshwm registry`` (:mod:`meshwm.apps.cli.registry`);
the schema, the backends and concurrency: ``docs/registry.md``.
"""

from __future__ import annotations

from meshwm.apps.registry.entries import AssetEntry, AssetRecord, CopyEntry, CopyRecord
from meshwm.apps.registry.schema import SCHEMA_VERSION
from meshwm.apps.registry.store import Registry
from meshwm.errors import RegistryError

__all__ = [
    "SCHEMA_VERSION",
    "AssetEntry",
    "AssetRecord",
    "CopyEntry",
    "CopyRecord",
    "Registry",
    "RegistryError",
]
