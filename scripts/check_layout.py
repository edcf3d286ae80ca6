"""Check the package's shape: import cycles, module sizes and function sizes.

Prints, for the ``meshwm`` package:

- every cycle in the graph of imports between meshwm modules (module-level imports and imports
  inside functions alike; imports under ``if TYPE_CHECKING:`` are skipped, they never run;
  ``from pkg import submodule`` is an edge to the submodule only);
- every module over ``--max-module`` lines (default 500) and every function over
  ``--max-function`` lines of code (default 80; docstrings, comments and blank lines not
  counted);
- the largest modules and functions, for reference.

Exit code 0 when there is no cycle (sizes are a guide and only reported), 1 otherwise.

Usage::

    python scripts/check_layout.py [--max-module 500] [--max-function 80]
"""

from __future__ import annotations

import argparse
import ast
import io
import sys
import tokenize
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = ROOT / "meshwm"


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(tree: ast.AST, modules: set[str], here: str) -> set[str]:
    """The meshwm modules a module imports (a ``from pkg import name`` of a submodule too)."""
    found: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node):
            for child in node.orelse:
                visit(child)
            return
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name in modules)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            # ``from pkg import sub`` imports the submodule; the package's own ``__init__``
            # runs for every import below it and is no edge of its own.
            subs = {f"{node.module}.{a.name}" for a in node.names} & modules
            if node.module in modules and len(subs) < len(node.names):
                found.add(node.module)
            found.update(subs)
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    found.discard(here)
    return found


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def strong(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10_000)
    for v in sorted(graph):
        if v not in index:
            strong(v)
    return out


def _code_lines(source: str, node: ast.AST) -> int:
    """Lines of code in a function: not blank, not comments, not its docstring."""
    assert isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
    lines = source.splitlines()[node.lineno - 1 : node.end_lineno]
    doc = set()
    body = node.body
    if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
        if isinstance(body[0].value.value, str):
            doc = set(range(body[0].lineno, (body[0].end_lineno or body[0].lineno) + 1))
    comment_only = set()
    text = "\n".join(lines)
    try:
        for tok in tokenize.generate_tokens(io.StringIO(text).readline):
            if (
                tok.type == tokenize.COMMENT
                and not text.splitlines()[tok.start[0] - 1][: tok.start[1]].strip()
            ):
                comment_only.add(tok.start[0] + node.lineno - 1)
    except (tokenize.TokenError, IndentationError):
        pass
    count = 0
    for offset, line in enumerate(lines):
        number = node.lineno + offset
        if line.strip() and number not in doc and number not in comment_only:
            count += 1
    return count


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--max-module", type=int, default=500)
    parser.add_argument("--max-function", type=int, default=80)
    args = parser.parse_args(argv)
    paths = sorted(PACKAGE.rglob("*.py"))
    modules = {_module_name(p): p for p in paths}
    graph: dict[str, set[str]] = {}
    sizes: list[tuple[int, str]] = []
    functions: list[tuple[int, str]] = []
    for name, path in modules.items():
        source = path.read_text(encoding="utf-8")
        tree = ast.parse(source)
        graph[name] = _imports(tree, set(modules), name)
        sizes.append((len(source.splitlines()), name))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                functions.append((_code_lines(source, node), f"{name}.{node.name}"))
    cycles = _cycles(graph)
    print(f"{len(modules)} modules, {sum(len(g) for g in graph.values())} internal imports")
    print(f"import cycles: {len(cycles)}")
    for comp in cycles:
        print("  cycle:", " <-> ".join(comp))
    big = sorted((s for s in sizes if s[0] > args.max_module), reverse=True)
    print(f"modules over {args.max_module} lines: {len(big)}")
    for lines, name in big:
        print(f"  {lines:5d}  {name}")
    long = sorted((f for f in functions if f[0] > args.max_function), reverse=True)
    print(f"functions over {args.max_function} lines of code: {len(long)}")
    for lines, name in long:
        print(f"  {lines:5d}  {name}")
    print("largest modules:", ", ".join(f"{n} {s}" for s, n in sorted(sizes, reverse=True)[:5]))
    print(
        "largest functions:",
        ", ".join(f"{n} {s}" for s, n in sorted(functions, reverse=True)[:5]),
    )
    return 1 if cycles else 0


if __name__ == "__main__":
    raise SystemExit(main())
