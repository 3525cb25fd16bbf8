"""MkDocs hooks: the reference pages generated at build time from the code itself.

A page holds a marker line; the hook puts in its place
- `<!-- agile:commands -->`: every command that `agile --help` lists, with its `--help` (run as `python -m agile`,
  so the options shown are the parser's own),
- `<!-- agile:terms -->`: the term library (every `mdp` package under agile/): each public function and class with
  its signature and docstring, read from the source with `ast` (nothing imported),
- `<!-- agile:config -->`: the fields of the library's config classes (`@configclass`, outside agile/tasks/), with
  type, default and docstring.
"""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = ROOT / "agile"


def _agile_help(*args: str) -> str:
    result = subprocess.run([sys.executable, "-m", "agile", *args, "--help"], cwd=ROOT, capture_output=True,
                            text=True, timeout=120, env={**os.environ, "COLUMNS": "110"})
    if result.returncode != 0:
        raise RuntimeError(f"python -m agile {' '.join(args)} --help failed:\n{result.stderr}")
    return result.stdout


def command_names(top_help: str) -> list[str]:
    """The commands of `agile --help`'s positional-arguments block (`    name   what it does`)."""
    block = top_help.split("positional arguments:", 1)[1].split("\noptions:", 1)[0]
    return [m.group(1) for m in re.finditer(r"^ {4}([a-z_0-9]+)\b", block, flags=re.M)]


def commands_markdown() -> str:
    top = _agile_help()
    names = command_names(top)
    if not names:
        raise RuntimeError("agile --help lists no command")
    with ThreadPoolExecutor(max_workers=4) as pool:
        helps = list(pool.map(lambda name: _agile_help(name), names))
    parts = ["## agile", "", "```text", top.rstrip(), "```", ""]
    for name, text in zip(names, helps):
        parts += [f"## agile {name}", "", "```text", text.rstrip(), "```", ""]
    return "\n".join(parts)


def _first_paragraph(doc: str | None) -> str:
    return "" if not doc else doc.strip().split("\n\n", 1)[0]


def _signature(node: ast.FunctionDef) -> str:
    return f"{node.name}({ast.unparse(node.args)})"


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _escape(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def term_modules() -> list[Path]:
    """The modules of every `mdp` package under agile/ (the generic library and each family's own)."""
    modules = []
    for package in sorted(p for p in PACKAGE.rglob("mdp") if (p / "__init__.py").is_file()):
        modules += sorted(p for p in package.rglob("*.py") if p.name != "__init__.py")
    return modules


def terms_markdown() -> str:
    parts = []
    for path in term_modules():
        tree = ast.parse(path.read_text())
        rows = []
        for node in tree.body:
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and not node.name.startswith("_") \
                    and not any("wp." in ast.unparse(d) for d in node.decorator_list):  # Warp kernels: not terms
                what = _signature(node) if isinstance(node, ast.FunctionDef) else f"class {node.name}"
                rows.append(f"| `{_escape(what)}` | {_escape(_first_paragraph(ast.get_docstring(node)))} |")
        if rows:
            doc = _first_paragraph(ast.get_docstring(tree))
            parts += [f"## {_module_name(path)}", ""] + ([_escape(doc), ""] if doc else [])
            parts += ["| Term | What it does |", "|---|---|", *rows, ""]
    return "\n".join(parts)


def _is_configclass(node: ast.ClassDef) -> bool:
    return any((isinstance(d, ast.Name) and d.id == "configclass")
               or (isinstance(d, ast.Call) and getattr(d.func, "id", "") == "configclass") for d in node.decorator_list)


def _fields(node: ast.ClassDef, source: str) -> list[tuple[str, str, str, str]]:
    """(name, type, default, docstring) of a class body's annotated fields, each docstring the string after it."""
    fields = []
    body = node.body
    for i, stmt in enumerate(body):
        if isinstance(stmt, ast.AnnAssign) and isinstance(stmt.target, ast.Name) and not stmt.target.id.startswith("_"):
            doc = ""
            if i + 1 < len(body) and isinstance(body[i + 1], ast.Expr) and isinstance(body[i + 1].value, ast.Constant) \
                    and isinstance(body[i + 1].value.value, str):
                doc = _first_paragraph(body[i + 1].value.value)
            default = "" if stmt.value is None else ast.get_source_segment(source, stmt.value) or ""
            if len(default) > 60:
                default = default[:57] + "..."
            fields.append((stmt.target.id, ast.unparse(stmt.annotation), default, doc))
    return fields


def config_modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "tasks" not in p.relative_to(PACKAGE).parts)


def config_markdown() -> str:
    parts = []
    for path in config_modules():
        source = path.read_text()
        tree = ast.parse(source)
        classes = [n for n in tree.body if isinstance(n, ast.ClassDef) and _is_configclass(n)]
        blocks = []
        for cls in classes:
            fields = _fields(cls, source)
            if not fields:
                continue
            blocks += [f"### {cls.name}", ""]
            doc = _first_paragraph(ast.get_docstring(cls))
            blocks += [_escape(doc), ""] if doc else []
            blocks += ["| Field | Type | Default | What it is |", "|---|---|---|---|"]
            blocks += [f"| `{n}` | `{_escape(t)}` | {f'`{_escape(d)}`' if d else ''} | {_escape(doc)} |"
                       for n, t, d, doc in fields]
            blocks.append("")
        if blocks:
            parts += [f"## {_module_name(path)}", "", *blocks]
    return "\n".join(parts)


GENERATORS = {"<!-- agile:commands -->": commands_markdown, "<!-- agile:terms -->": terms_markdown,
              "<!-- agile:config -->": config_markdown}


def on_page_markdown(markdown: str, page, config, files) -> str:
    for marker, generate in GENERATORS.items():
        if marker in markdown:
            markdown = markdown.replace(marker, generate())
    return markdown
