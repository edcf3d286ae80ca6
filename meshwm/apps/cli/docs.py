"""``meshwm docs [TOPIC]``: print a documentation page (they are installed with the package).

Help texts point here (``meshwm docs attacks``) rather than at ``docs/*.md`` paths, which a
``pip install`` does not put anywhere a user would look; the pages are package data
(:func:`meshwm.data.doc_topics`).
"""

from __future__ import annotations

import argparse

from meshwm.apps.cli.output import EXIT_OK

__all__ = ["HELP", "NAME", "add_parser", "run"]

NAME = "docs"
HELP = "print a documentation page (meshwm docs lists them)"


def add_parser(subparsers: argparse._SubParsersAction) -> argparse.ArgumentParser:
    """Add ``meshwm docs`` to ``subparsers``."""
    parser = subparsers.add_parser(
        NAME,
        help=HELP,
        description="Print the documentation page TOPIC (Markdown); without TOPIC, list them.",
    )
    parser.add_argument("topic", nargs="?", help="the page to print, e.g. assets, verify")
    parser.set_defaults(run=run)
    return parser


def _title(text: str) -> str:
    for line in text.splitlines():
        if line.startswith("#"):
            return line.lstrip("#").strip()
    return ""


def run(args: argparse.Namespace) -> int:
    """Print the page ``args.topic``, or the list of pages."""
    from meshwm.data import doc_topics

    topics = doc_topics()
    if not topics:
        raise ValueError("no documentation is installed with this copy of meshwm")
    if args.topic is None:
        width = max(len(name) for name in topics)
        for name, path in topics.items():
            print(f"{name:<{width}}  {_title(path.read_text(encoding='utf-8'))}")
        return EXIT_OK
    topic = args.topic.removesuffix(".md").lower()
    if topic not in topics:
        raise ValueError(f"no page {args.topic!r}; the pages are {', '.join(topics)}")
    print(topics[topic].read_text(encoding="utf-8"), end="")
    return EXIT_OK
