"""The code's shape, as anyone can reproduce it: the modules of drs_model and drs_ros with their
lines, the import graph between them (and any cycle), the functions over a length limit, and the
places that speak of the work that built the product instead of the product.

``python tests/layout.py [--graph] [--long N]`` prints the report; ``tests/test_layout.py`` and
``tests/test_imports.py`` assert on the same figures.

The graph is read from the source with ``ast`` (every ``import`` and ``from ... import``, at module
level or inside a function: an import inside a function is how a cycle hides), so it is what the
code says, not what a warm interpreter happens to have loaded.
"""

from __future__ import annotations

import argparse
import ast
import re
import subprocess
import sys
import tokenize
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The packages measured; drs_ros's modules import rclpy, drs_model's never do.
PACKAGES = ("drs_model", "drs_ros")
#: The longest a function of the packages may be [lines, ``def`` to its last line].
FUNCTION_LIMIT = 80
#: The longest a module of the packages may be [lines].
MODULE_LIMIT = 500
#: Ordinals and pointers before "pass" that make it a stage of the work rather than a loop.
_PASS_ORDINALS = (
    "first",
    "second",
    "third",
    "fourth",
    "fifth",
    "sixth",
    "seventh",
    "eighth",
    "ninth",
    "tenth",
    "eleventh",
    "twelfth",
    "this",
    "that",
    "last",
    "previous",
    "next",
    "composition",
)
#: Words about the work rather than the product: an issue by number, the work's sittings and its
#: workers (pytest's ``scope="session"`` excepted), a numbered or pointed-at pass, the builds of the
#: past, the model "of today". (Assembled from parts so that this file does not match itself.)
PROCESS_WORDS = re.compile(
    "|".join(
        [
            r"\b[Ii]ssues? " + r"#?\d+",
            r"\b[Ii]ssue-" + r"\d+",
            r"\btoday's " + "model",
            r"\b[Bb]efore " + r"issue\b",
            r"(?<!scope=.)\b[Ss]ess" + r"ions?\b",
            r"\b[Aa]gen" + r"ts?\b",
            r"(?i:\b(?:" + "|".join(_PASS_ORDINALS) + r")(?:-| )pass(?:es)?\b)",
            r"(?i:\b(?:earlier|older|previous|former|old) build" + r"s?\b)",
        ]
    )
)
#: Where the product's text lives: code, tests, docs, benchmarks, configuration.
TEXT_PLACES = (
    "drs_model",
    "drs_ros",
    "tests",
    "docs",
    "benchmarks",
    "config",
    "README.md",
    "Makefile",
    "pyproject.toml",
)
TEXT_SUFFIXES = {".py", ".md", ".toml", ".yaml", ".yml", ".json", ".txt", ""}


def module_name(path: Path, root: Path = ROOT) -> str:
    """Dotted name of the module in ``path`` (a package's ``__init__`` is the package)."""
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules(root: Path = ROOT) -> dict[str, Path]:
    """Dotted module name -> file, for every module of :data:`PACKAGES`."""
    return {module_name(p, root): p for pkg in PACKAGES for p in sorted((root / pkg).rglob("*.py"))}


def lines(path: Path) -> int:
    """Lines of the file."""
    return len(path.read_text().splitlines())


def imports(name: str, path: Path, known: set[str]) -> set[str]:
    """The modules of ``known`` that module ``name`` (in ``path``) imports, anywhere in its source:
    ``from pkg import mod`` names the module ``pkg.mod`` and the package ``pkg``."""
    is_package = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if is_package else name.split(".")[:-1]
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            targets = [mod] + [f"{mod}.{a.name}" for a in node.names]
        else:
            continue
        out.update(t for t in targets if t in known and t != name)
    return out


def graph(root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the project modules it imports."""
    mods = modules(root)
    return {name: imports(name, path, set(mods)) for name, path in mods.items()}


def package_of(name: str) -> set[str]:
    """The packages whose ``__init__`` runs when ``name`` is imported (not a dependency cycle:
    Python imports a parent package before its modules)."""
    parts = name.split(".")
    return {".".join(parts[:i]) for i in range(1, len(parts))}


def first_cycle(g: dict[str, set[str]]) -> list[str] | None:
    """An import cycle of ``g`` as ``[a, b, ..., a]`` (depth-first search for a back edge; a
    module importing its own parent package is not one), or None."""
    state: dict[str, int] = {}  # 1 on the stack, 2 done
    for start in sorted(g):
        if start in state:
            continue
        stack, todo = [start], [iter(sorted(g[start] - package_of(start)))]
        state[start] = 1
        while todo:
            nxt = next(todo[-1], None)
            if nxt is None:
                state[stack.pop()] = 2
                todo.pop()
            elif state.get(nxt) == 1:
                return stack[stack.index(nxt) :] + [nxt]
            elif nxt not in state and nxt in g:
                state[nxt] = 1
                stack.append(nxt)
                todo.append(iter(sorted(g[nxt] - package_of(nxt))))
    return None


def long_functions(
    limit: int = FUNCTION_LIMIT, root: Path = ROOT
) -> list[tuple[str, int, str, int]]:
    """``(file, line, name, length)`` of every function of the packages longer than ``limit``
    lines, longest first."""
    out = []
    for path in modules(root).values():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > limit:
                    out.append((str(path.relative_to(root)), node.lineno, node.name, n))
    return sorted(out, key=lambda r: -r[3])


def long_modules(limit: int = MODULE_LIMIT, root: Path = ROOT) -> list[tuple[str, int]]:
    """``(module, lines)`` of every module of the packages longer than ``limit`` lines."""
    return [(m, lines(p)) for m, p in modules(root).items() if lines(p) > limit]


def unlisted_modules(root: Path = ROOT) -> list[str]:
    """Modules of the packages that the README's layout table (its rows starting ``| `drs_``)
    does not name: by their file (```name```, ```name.py```) or, for a package, its folder."""
    rows = [r for r in (root / "README.md").read_text().splitlines() if r.startswith("| `drs_")]
    table = "\n".join(rows)
    out = []
    for name, path in modules(root).items():
        leaf = path.parent.name if path.stem == "__init__" else path.stem
        if leaf == "__main__":
            continue
        forms = (f"`{leaf}`", f"`{leaf}.py`", f"`{leaf}/", f"/{leaf}/", f"/{leaf}.py`")
        if not any(form in table for form in forms):
            out.append(name)
    return out


def text_files(root: Path = ROOT) -> list[Path]:
    """The product's text files (:data:`TEXT_PLACES`), caches and generated data left out."""
    out = []
    for place in TEXT_PLACES:
        path = root / place
        files = [path] if path.is_file() else sorted(path.rglob("*")) if path.is_dir() else []
        out += [
            f
            for f in files
            if f.is_file()
            and f.suffix in TEXT_SUFFIXES
            and "__pycache__" not in f.parts
            and "data" not in f.relative_to(root).parts
        ]
    return out


def process_words(root: Path = ROOT) -> list[str]:
    """``file:line: text`` of every line that speaks of the work (:data:`PROCESS_WORDS`)."""
    out = []
    for path in text_files(root):
        try:
            text = path.read_text()
        except UnicodeDecodeError:
            continue
        for i, line in enumerate(text.splitlines(), 1):
            if PROCESS_WORDS.search(line):
                out.append(f"{path.relative_to(root)}:{i}: {line.strip()}")
    return out


#: What ``ruff format`` keeps formatted (the configuration is pyproject.toml's ``[tool.ruff]``).
FORMATTED = ("drs_model", "drs_ros", "tests", "benchmarks", "interfaces")
#: How many ``# fmt: skip`` the tree may hold: only a table that reads better aligned.
FMT_SKIP_LIMIT = 5
FMT_SKIP = re.compile(r"(?:^|\s)#\s*fmt:\s*(?:skip|off)\s*$")  # a pragma ends its comment


def unformatted(root: Path = ROOT) -> list[str]:
    """The files ``ruff format --check`` would change (the venv's ruff, beside this Python)."""
    ruff = Path(sys.executable).with_name("ruff")
    paths = [d for d in FORMATTED if (root / d).is_dir()]
    done = subprocess.run(
        [str(ruff), "format", "--check", "--output-format", "concise", *paths],
        cwd=root,
        capture_output=True,
        text=True,
    )
    if done.returncode not in (0, 1):  # 2: ruff itself failed (a syntax error, a bad config)
        raise RuntimeError(f"ruff format --check failed ({done.returncode}): {done.stderr}")
    # one line a file: "path:line:column: unformatted: File would be reformatted"
    said = (line.split(":", 1)[0] for line in done.stdout.splitlines() if ": unformatted:" in line)
    return sorted(set(said))


def format_skips(root: Path = ROOT) -> list[str]:
    """``file:line`` of every ``# fmt: skip`` (or ``off``) comment in the formatted trees (a
    comment: the words inside a string do not count)."""
    out = []
    for d in FORMATTED:
        for path in sorted((root / d).rglob("*.py")):
            with path.open("rb") as f:
                tokens = tokenize.tokenize(f.readline)
                for tok in tokens:
                    if tok.type == tokenize.COMMENT and FMT_SKIP.search(tok.string):
                        out.append(f"{path.relative_to(root)}:{tok.start[0]}")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--graph", action="store_true", help="print each module's project imports")
    ap.add_argument(
        "--long", type=int, default=FUNCTION_LIMIT, help="function length limit [lines]"
    )
    ap.add_argument("--root", type=Path, default=ROOT, help="the repository (default: this one)")
    args = ap.parse_args(argv)
    mods, g = modules(args.root), graph(args.root)
    total = dict.fromkeys(PACKAGES, 0)
    print(f"{'module':<48} {'lines':>6}  imports")
    for m, p in mods.items():
        n = lines(p)
        total[m.split(".")[0]] += n
        deps = ", ".join(sorted(g[m])) if args.graph else str(len(g[m]))
        print(f"{m:<48} {n:>6}  {deps}")
    print("total lines: " + ", ".join(f"{k} {v}" for k, v in total.items()))
    print(f"modules over {MODULE_LIMIT} lines: {len(long_modules(root=args.root))}")
    cycle = first_cycle(g)
    print("import cycles: " + (" -> ".join(cycle) if cycle else "none"))
    longf = long_functions(args.long, args.root)
    print(f"functions over {args.long} lines: {len(longf)}")
    for f, line, name, n in longf:
        print(f"  {f}:{line} {name} ({n})")
    words = process_words(args.root)
    print(f"lines speaking of the work instead of the product: {len(words)}")
    for w in words:
        print(f"  {w}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
