"""Build hook: the documentation pages are copied into the package, so ``meshwm docs TOPIC``
prints them after ``pip install`` (``meshwm/data/__init__.py`` finds them there, or in
``docs/`` itself in a source checkout).  Everything else is in ``pyproject.toml``.
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent


class BuildWithDocs(build_py):
    """``build_py`` that also copies ``docs/*.md`` to ``meshwm/data/docs/`` in the build."""

    def run(self) -> None:
        super().run()
        target = Path(self.build_lib) / "meshwm" / "data" / "docs"
        target.mkdir(parents=True, exist_ok=True)
        for page in sorted((ROOT / "docs").glob("*.md")):
            shutil.copy2(page, target / page.name)


setup(cmdclass={"build_py": BuildWithDocs})
