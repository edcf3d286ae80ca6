"""``meshwm registry {list,show,remove,upgrade} DB``: what the asset registry holds, removing from
it, and adding what this meshwm records that an older one did not.

DB is a registry file (SQLite) or a ``postgresql://`` URL; no action here creates one (a
missing or damaged registry is one line on stderr and exit code 2).  The storage is
:mod:`meshwm.apps.registry`; the schema and the backends: ``meshwm docs registry``.
"""

from __future__ import annotations

import argparse
import json
from typing import TYPE_CHECKING, Any

from meshwm.apps.cli import options
from meshwm.apps.cli.output import EXIT_OK

if TYPE_CHECKING:  # pragma: no cover - types only; the library is imported inside run
    from meshwm.apps.registry import AssetRecord, CopyRecord, Registry

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "registry"
HELP = "list, show, remove or upgrade the assets and marked copies of an asset registry"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm registry`` and its actions to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description=(
            "The asset registry records every marked copy sent out and the asset it was made "
            "from. DB is a registry file (SQLite) or a postgresql://user@host/db URL (needs "
            "pip install 'meshwm[postgres]'). Schema and backends: meshwm docs registry."
        ),
    )
    actions = parser.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True
    database = {"metavar": "DB", "help": "the registry: a file path or a postgresql:// URL"}

    listing = actions.add_parser(
        "list", help="every asset and its copies", description="List every asset and its copies."
    )
    listing.add_argument("database", **database)
    listing.add_argument("--json", action="store_true", help="print the registry as JSON")

    show = actions.add_parser(
        "show",
        help="one asset: its copies and reference sizes",
        description="Show one asset: its fields, its references' sizes and its copies.",
    )
    show.add_argument("database", **database)
    show.add_argument("asset_id", type=options.positive_int, metavar="ASSET_ID")
    show.add_argument("--json", action="store_true", help="print the asset as JSON")

    remove = actions.add_parser(
        "remove",
        help="remove an asset (with its copies) or one copy",
        description="Remove an asset with its references and copies, or one copy.",
    )
    remove.add_argument("database", **database)
    what = remove.add_mutually_exclusive_group(required=True)
    what.add_argument("--asset", type=options.positive_int, metavar="ID", help="an asset's id")
    what.add_argument("--copy", type=options.positive_int, metavar="ID", help="a copy's id")

    upgrade = actions.add_parser(
        "upgrade",
        help="add probes and crop descriptors to assets recorded by an older meshwm",
        description=(
            "Give every asset recorded without a probe or crop descriptors (by an older meshwm) "
            "what embed records now, made from its stored reference: trace then orders it "
            "among near-duplicate assets, and finds crops of it, as it does new ones. What an "
            "asset has is left as it is."
        ),
    )
    upgrade.add_argument("database", **database)
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Run the registry action ``args.action`` on ``args.database``."""
    from meshwm.apps.registry import Registry

    with Registry.open(args.database, create=False) as registry:
        if args.action == "list":
            _list(registry, as_json=args.json)
        elif args.action == "show":
            _show(registry, args.asset_id, as_json=args.json)
        elif args.action == "upgrade":
            _upgrade(registry)
        else:
            _remove(registry, asset_id=args.asset, copy_id=args.copy)
    return EXIT_OK


def _payload_text(payload: str) -> str:
    """``"VENDOR_A" (0x…)`` for a text id, ``0x…`` for another id, a mark's hash as it is."""
    if payload.startswith("mark:"):
        return payload
    from meshwm.message.payload import format_id

    return format_id(payload)


def _asset_json(asset: AssetRecord) -> dict[str, Any]:
    return {
        "id": asset.id,
        "name": asset.name,
        "input_sha256": asset.input_sha256,
        "vertices": asset.vertices,
        "faces": asset.faces,
        "created": asset.created,
        "copy_count": asset.copies,
    }


def _copy_json(copy: CopyRecord) -> dict[str, Any]:
    return {
        "id": copy.id,
        "asset_id": copy.asset_id,
        "payload": copy.payload,
        "payload_text": _payload_text(copy.payload),
        "recipient": copy.recipient,
        "output_name": copy.output_name,
        "output_sha256": copy.output_sha256,
        "n": copy.n,
        "created": copy.created,
        "params": copy.params,
    }


def _copy_line(copy: CopyRecord) -> str:
    recipient = copy.recipient if copy.recipient is not None else "-"
    return f"  copy {copy.id}  {_payload_text(copy.payload)}  to {recipient}  {copy.created}"


def _list(registry: Registry, *, as_json: bool) -> None:
    assets, copies = registry.assets(), registry.copies()
    by_asset: dict[int, list[CopyRecord]] = {}
    for copy in copies:
        by_asset.setdefault(copy.asset_id, []).append(copy)
    if as_json:
        rows = [
            {**_asset_json(a), "copies": [_copy_json(c) for c in by_asset.get(a.id, [])]}
            for a in assets
        ]
        print(json.dumps({"registry": registry.name, "assets": rows}, indent=2))
        return
    if not assets:
        print(f"{registry.name}: no assets")
        return
    for asset in assets:
        plural = "y" if asset.copies == 1 else "ies"
        print(
            f"asset {asset.id}  {asset.name}  {asset.vertices} vertices  {asset.copies} cop{plural}"
        )
        for copy in by_asset.get(asset.id, []):
            print(_copy_line(copy))


#: References recorded under a grid size that is not one.
_REFERENCE_NAMES = {0: "probe", 1: "crop descriptors"}


def _show(registry: Registry, asset_id: int, *, as_json: bool) -> None:
    asset = registry.asset(asset_id)
    sizes = registry.reference_sizes(asset_id)
    copies = registry.copies(asset_id)
    if as_json:
        report = {
            "registry": registry.name,
            "asset": _asset_json(asset),
            "references": {str(n): size for n, size in sizes.items()},
            "copies": [_copy_json(c) for c in copies],
        }
        print(json.dumps(report, indent=2))
        return
    print(f"asset {asset.id}  {asset.name}")
    print(f"  input sha256  {asset.input_sha256}")
    print(f"  size          {asset.vertices} vertices, {asset.faces} faces")
    print(f"  recorded      {asset.created}")
    references = (
        ", ".join(f"{_REFERENCE_NAMES.get(n, f'N={n}')}: {size} bytes" for n, size in sizes.items())
        or "none"
    )
    print(f"  references    {references}")
    print(f"  copies        {asset.copies}")
    for copy in copies:
        print(_copy_line(copy))
        print(f"    output {copy.output_name}  sha256 {copy.output_sha256}  N={copy.n}")
        print(f"    params {json.dumps(copy.params, sort_keys=True)}")


def _upgrade(registry: Registry) -> None:
    from meshwm.apps.tracing import upgrade_assets

    added, skipped = upgrade_assets(registry)
    total = len(registry.assets())
    print(f"probes or crop descriptors added to {len(added)} of {total} assets", end="")
    print(f"; {len(skipped)} without a reference to make one from" if skipped else "")


def _remove(registry: Registry, *, asset_id: int | None, copy_id: int | None) -> None:
    if asset_id is not None:
        asset = registry.asset(asset_id)
        registry.remove_asset(asset_id)
        plural = "y" if asset.copies == 1 else "ies"
        print(f"removed asset {asset_id} ({asset.name}) and its {asset.copies} cop{plural}")
    elif copy_id is not None:
        registry.remove_copy(copy_id)
        print(f"removed copy {copy_id}")
