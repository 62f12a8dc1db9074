"""The package's shape: no import cycles, and few long functions, each saying why it is long.

Import cycles
    Every ``import`` / ``from ... import`` of one ``spinemesh`` module by another is an edge
    to the module it names (``from a.b import c``: ``a.b.c`` when that is a module, else
    ``a.b``), wherever the statement stands: a function that imports late to dodge a cycle
    still depends on what it imports. An import that runs when the module is imported (at
    the top, or in a class body, ``if`` or ``try`` block, but not under
    ``if TYPE_CHECKING:``) also runs every package above the module it names, so it is an
    edge to those packages' ``__init__`` too, except to a package the importing module is
    itself inside (that one is being imported already). An import inside a function runs
    when the function is called and is not an edge to the packages above what it names.
    No cycle may remain.

Long functions
    A function's length is its ``def`` line to its last line (docstring and nested functions
    included, decorators not). At most :data:`MAX_LONG` functions in ``spinemesh/`` may be
    longer than :data:`LONG_LINES` lines, and each must say why on the line right above its
    first line (its first decorator, or ``def``)::

        # long: follows the runtime's computeWorldPositions line by line
        def path_positions(...):

Both checks are run on a small package written here first, with a cycle and a long function
without its comment, so that a checker that finds nothing cannot pass.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import spinemesh

PACKAGE = Path(spinemesh.__file__).resolve().parent

#: Longer than this many lines is long.
LONG_LINES = 80
#: How many long functions the package may hold.
MAX_LONG = 3
#: The comment that says why a function is long.
LONG_MARK = "# long:"


def _modules(root: Path) -> dict[str, tuple[Path, bool]]:
    """Dotted module name -> (file, whether it is a package's ``__init__``), for every .py below ``root``."""
    out = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        is_package = parts[-1] == "__init__"
        if is_package:
            parts = parts[:-1]
        out[".".join(parts)] = (path, is_package)
    return out


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _imports(tree: ast.Module):
    """``(statement, at_import)`` for every import statement, ``at_import`` True when it runs as
    the module is imported (not inside a function); those under ``if TYPE_CHECKING:`` never run."""
    stack = [(node, True) for node in tree.body]
    while stack:
        node, at_import = stack.pop()
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node, at_import
        elif isinstance(node, ast.If) and _is_type_checking(node):
            stack.extend((child, at_import) for child in node.orelse)
        else:
            inner = at_import and not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            stack.extend((child, inner) for child in ast.iter_child_nodes(node))


def _targets(node, module: str, is_package: bool, modules: dict, with_packages: bool) -> set[str]:
    """The package's modules one import statement names (the nearest known module of each
    name), and with ``with_packages`` the packages above them."""
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
    else:
        if node.level:
            base = module.split(".") if is_package else module.split(".")[:-1]
            base = base[:len(base) - (node.level - 1)]
            stem = ".".join(base + ([node.module] if node.module else []))
        else:
            stem = node.module or ""
        names = [f"{stem}.{a.name}" if f"{stem}.{a.name}" in modules else stem for a in node.names]
    out = set()
    for name in names:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        parts = name.split(".") if name else []
        for i in range(1 if with_packages else len(parts), len(parts) + 1):  # a.b.c runs a and a.b first
            target = ".".join(parts[:i])
            if target in modules and target != module and not module.startswith(target + "."):
                out.add(target)
    return out


def import_graph(root: Path) -> dict[str, set[str]]:
    """Module -> the package's modules it depends on by its imports (see the module docstring)."""
    modules = _modules(root)
    graph = {}
    for module, (path, is_package) in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        graph[module] = set()
        for node, at_import in _imports(tree):
            graph[module] |= _targets(node, module, is_package, modules, with_packages=at_import)
    return graph


def import_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), or a module that imports itself."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1 or v in graph.get(v, ()):
                cycles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return cycles


def long_functions(root: Path) -> list[tuple[str, int, str, int, str]]:
    """``(file, line, name, length, reason)`` of every function longer than :data:`LONG_LINES`;
    ``reason`` is the text after ``# long:`` on the line above it, or "" without one."""
    out = []
    for path in sorted(root.rglob("*.py")):
        lines = path.read_text(encoding="utf-8").splitlines()
        for node in ast.walk(ast.parse("\n".join(lines), str(path))):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            length = node.end_lineno - node.lineno + 1
            if length <= LONG_LINES:
                continue
            first = min([node.lineno] + [d.lineno for d in node.decorator_list])
            above = lines[first - 2].strip() if first >= 2 else ""
            reason = above[len(LONG_MARK):].strip() if above.startswith(LONG_MARK) else ""
            out.append((str(path.relative_to(root.parent)), node.lineno, node.name, length, reason))
    return out


def _write_package(root: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        path = root / "demo" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return root / "demo"


def test_the_checks_find_what_they_look_for(tmp_path):
    """Found: a cycle through a package ``__init__``, and one closed by an import inside a
    function (mask -> seg -> seg.comp -> mask). Not found: an import under TYPE_CHECKING, and
    a function's import of a module whose package's ``__init__`` imports back (geo, leaf).
    A long function without its comment has no reason."""
    body = "\n".join(f"    x{i} = {i}" for i in range(LONG_LINES))
    demo = _write_package(tmp_path, {
        "__init__.py": "",
        "a.py": "from .b import f\n",
        "b/__init__.py": "from .c import g\n",
        "b/c.py": "from .. import a\n",
        "d.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from . import e\n",
        "e.py": f"from . import d\n\n\ndef long_one():\n{body}\n\n\n# long: kept whole to mirror a reference\n"
                f"@staticmethod\ndef long_two():\n{body}\n",
        "mask.py": "def compute():\n    from . import seg\n",
        "seg/__init__.py": "from .comp import alpha\n",
        "seg/comp.py": "from ..mask import compute\n",
        "up/__init__.py": "from .run import go\n",
        "up/run.py": "from ..rig import bend\n",
        "up/geo.py": "X = 1\n",
        "rig.py": "def bend():\n    from .up.geo import X\n",
    })
    assert import_cycles(import_graph(demo)) == [["demo.a", "demo.b", "demo.b.c"],
                                                  ["demo.mask", "demo.seg", "demo.seg.comp"]]
    found = {name: reason for _, _, name, _, reason in long_functions(demo)}
    assert found == {"long_one": "", "long_two": "kept whole to mirror a reference"}


def test_no_import_cycles():
    cycles = import_cycles(import_graph(PACKAGE))
    assert not cycles, f"import cycles: {cycles}"


def test_few_long_functions_each_with_its_reason():
    found = long_functions(PACKAGE)
    listing = "\n".join(f"{f}:{line} {name} ({n} lines) {reason or 'NO # long: COMMENT'}"
                        for f, line, name, n, reason in found)
    assert len(found) <= MAX_LONG, f"{len(found)} functions over {LONG_LINES} lines (at most {MAX_LONG}):\n{listing}"
    assert all(reason for *_, reason in found), f"a long function must say why above its def:\n{listing}"


def package_graph(graph: dict[str, set[str]], root_name: str = "spinemesh") -> dict[str, set[str]]:
    """The module graph folded onto the package's layers: each module counts as the subpackage
    (or top-level module) of ``root_name`` it lies in, every import an edge between them,
    wherever the import stands (a function's late import still makes its package depend on
    the other)."""
    def layer(module: str) -> str:
        parts = module.split(".")
        return ".".join(parts[:2]) if len(parts) > 1 else module

    out: dict[str, set[str]] = {}
    for module, targets in graph.items():
        here = layer(module)
        out.setdefault(here, set())
        out[here] |= {layer(t) for t in targets if layer(t) != here and layer(t) != root_name}
    return out


def test_packages_are_layered():
    """No two packages use each other, not even through imports inside functions: what two
    commands share (the output folder, the mesh attachment geometry) sits below both."""
    cycles = import_cycles(package_graph(import_graph(PACKAGE)))
    assert not cycles, f"packages that import each other: {cycles}"


def test_package_layering_check_finds_a_late_import(tmp_path):
    demo = _write_package(tmp_path, {
        "__init__.py": "",
        "up/__init__.py": "",
        "up/run.py": "from ..rig import bend\n",
        "rig/__init__.py": "def bend():\n    from ..up.run import X\n",
    })
    assert import_cycles(package_graph(import_graph(demo), "demo")) == [["demo.rig", "demo.up"]]


# --- docs/architecture.md says what the code is ------------------------------------------------
#
# A newcomer reads docs/architecture.md first: its diagram, its table of packages and the names
# in backticks must be those of the code today. Each check is run first on a small package and
# page written here, so that a checker that finds nothing cannot pass.

ARCHITECTURE = PACKAGE.parent / "docs" / "architecture.md"
#: Names in backticks that are not spinemesh's own: typer's option type.
FOREIGN_NAMES = {"Annotated"}


def top_level_names(root: Path) -> set[str]:
    """The packages and modules right under ``root`` (``__init__`` and ``__main__`` left out)."""
    names = {p.name for p in root.iterdir() if (p / "__init__.py").is_file()}
    names |= {p.stem for p in root.glob("*.py") if p.stem not in ("__init__", "__main__")}
    return names


def diagram(text: str) -> tuple[dict[str, set[str]], set[tuple[str, str]]]:
    """The page's first ``flowchart BT`` (the layers): box id -> the names in its label (outside
    parentheses, between ``·`` and line breaks), and the arrows drawn ``(from, to)``."""
    block = re.search(r"```mermaid\s*\nflowchart BT\n(.*?)```", text, re.DOTALL).group(1)
    boxes, arrows = {}, set()
    for line in block.splitlines():
        box = re.match(r'\s*(\w+)\["(.*)"\]\s*$', line)
        if box:
            label = re.sub(r"\([^)]*\)", "", box.group(2))
            boxes[box.group(1)] = {n.strip() for n in re.split(r"·|<br/>", label) if n.strip()}
            continue
        arrow = re.match(r"\s*(\w+(?:\s*&\s*\w+)*)\s*-\.?->(?:\|[^|]*\|)?\s*(\w+(?:\s*&\s*\w+)*)\s*$", line)
        if arrow:
            for a in re.split(r"\s*&\s*", arrow.group(1)):
                arrows |= {(a, b) for b in re.split(r"\s*&\s*", arrow.group(2))}
    return boxes, arrows


def diagram_problems(text: str, root: Path) -> list[str]:
    """What the layer diagram gets wrong about the package at ``root``: a name in no box (or
    in two, or not in the package), an import between boxes not drawn, an arrow without one."""
    boxes, arrows = diagram(text)
    names = top_level_names(root)
    problems = []
    box_of = {}
    for box, inside in sorted(boxes.items()):
        for name in sorted(inside):
            if name not in names:
                problems.append(f"box {box} names {name}, which is not in the package")
            elif name in box_of:
                problems.append(f"{name} is in two boxes ({box_of[name]}, {box})")
            box_of[name] = box
    problems += [f"{name} is in no box" for name in sorted(names - set(box_of))]
    graph = package_graph(import_graph(root), root.name)
    imports = {(box_of[a.split(".")[1]], box_of[b.split(".")[1]])
               for a, targets in graph.items() for b in targets
               if "." in a and a.split(".")[1] in box_of and b.split(".")[1] in box_of}
    imports = {(a, b) for a, b in imports if a != b}
    problems += [f"{a} imports {b}: no arrow drawn" for a, b in sorted(imports - arrows)]
    problems += [f"arrow {a} --> {b}: no such import" for a, b in sorted(arrows - imports)]
    return problems


def table_problems(text: str, root: Path) -> list[str]:
    """A package or module the table of packages (its first column) does not name."""
    section = text.split("## The packages", 1)[1].split("\n## ", 1)[0]
    named = {name for row in section.splitlines() if row.startswith("| `")
             for name in re.findall(r"`([^`]+)`", row.split("|")[1])}
    return [f"{name} is not in the table of packages" for name in sorted(top_level_names(root) - named)]


def defined_names(root: Path) -> tuple[set[str], set[str]]:
    """Every module's dotted name (and each of its dotted tails: ``upgrade.write``, ``write``)
    under ``root``; every name defined in them (function, class, assignment, a class's fields
    and methods), also as ``Owner.name`` and ``module.name`` for each tail of the module."""
    modules, names = set(), set()
    for module, (path, _) in _modules(root).items():
        parts = module.split(".")
        tails = {".".join(parts[i:]) for i in range(len(parts))}
        modules |= tails
        tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
        for node in ast.walk(tree):
            found = []
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                found.append(node.name)
            elif isinstance(node, ast.Assign):
                found += [t.id for t in node.targets if isinstance(t, ast.Name)]
            elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                found.append(node.target.id)
            names |= set(found)
            names |= {f"{tail}.{n}" for tail in tails for n in found}
            if isinstance(node, ast.ClassDef):
                for child in node.body:
                    member = (child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) else
                              child.target.id if isinstance(child, ast.AnnAssign) and isinstance(child.target, ast.Name)
                              else None)
                    if member:
                        names.add(f"{node.name}.{member}")
    return modules, names


def name_problems(text: str, root: Path) -> list[str]:
    """Names in backticks that the code does not have: a file (``x.py``, ``a/b.py``, ``x.js``, ``x.sh``,
    ``spinemesh/...``) that no file under ``root`` (or the repository, for ``tests/...``) is, and a
    Python name (``mesh_one``, ``run.finish_project``, ``Result.seconds``) that no module under
    ``root`` defines. Options, commands and data files (``report.json``) are left alone."""
    modules, names = defined_names(root)
    files = {p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file()}
    problems = []
    for token in sorted(set(re.findall(r"`([^`\n]+)`", text))):
        if re.fullmatch(r"[\w./-]+\.(py|js|sh)|[\w./-]+/", token):
            first = token.split("/", 1)[0]
            if "/" in token and first != root.name and (root.parent / first).is_dir():
                ok = (root.parent / token).exists()  # a folder of the repository: tests/, scripts/
            else:
                inside = token.removeprefix(f"{root.name}/").rstrip("/")
                ok = any(f == inside or f.endswith("/" + inside) or f.startswith(inside + "/") for f in files)
            if not ok:
                problems.append(f"`{token}`: no such file")
        elif re.fullmatch(r"[\w.]+\.(json|jsonl|onnx|png|md|html)", token):
            continue  # a data file's or a run's output file's name
        elif re.fullmatch(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*", token):
            dotted = token.removeprefix(f"{root.name}.")
            if token not in (root.name, *FOREIGN_NAMES) and dotted not in modules and dotted not in names:
                problems.append(f"`{token}`: not in the code")
    return problems


def test_architecture_checks_find_what_they_look_for(tmp_path):
    """A page that misses a module, draws an arrow without an import and misses one, puts a
    module in a box that does not exist, and names a function, a file and a script the code lacks."""
    demo = _write_package(tmp_path, {
        "__init__.py": "",
        "low.py": "def helper():\n    pass\n",
        "mid/__init__.py": "from ..low import helper\n",
        "mid/run.py": "class Result:\n    seconds: dict\n\n\ndef go():\n    from ..top import X\n",
        "top.py": "X = 1\n",
    })
    page = ("# A\n\n```mermaid\nflowchart BT\n  low[\"low\"]\n  mid[\"mid · gone<br/>(the middle)\"]\n"
            "  low --> mid\n```\n\n## The packages\n\n| p | job |\n| --- | --- |\n| `low`, `mid` | x |\n\n"
            "## More\n\n`run.go`, `Result.seconds`, `mid/run.py`, `helper`, `--pack`, `report.json`, "
            "`run.stop`, `mid/walk.py`, `Result.minutes`, `scripts/go.sh`, `scripts/gone.sh`\n")
    (tmp_path / "scripts").mkdir()
    (tmp_path / "scripts" / "go.sh").write_text("", encoding="utf-8")
    assert diagram_problems(page, demo) == [
        "box mid names gone, which is not in the package", "top is in no box",
        "mid imports low: no arrow drawn", "arrow low --> mid: no such import"]
    assert table_problems(page, demo) == ["top is not in the table of packages"]
    assert name_problems(page, demo) == ["`Result.minutes`: not in the code", "`mid/walk.py`: no such file",
                                         "`run.stop`: not in the code", "`scripts/gone.sh`: no such file"]


def test_architecture_diagram_draws_the_packages_as_they_import():
    problems = diagram_problems(ARCHITECTURE.read_text(encoding="utf-8"), PACKAGE)
    assert not problems, "docs/architecture.md's diagram:\n" + "\n".join(problems)


def test_architecture_table_names_every_package():
    problems = table_problems(ARCHITECTURE.read_text(encoding="utf-8"), PACKAGE)
    assert not problems, "docs/architecture.md:\n" + "\n".join(problems)


def test_architecture_names_only_what_the_code_has():
    problems = name_problems(ARCHITECTURE.read_text(encoding="utf-8"), PACKAGE)
    assert not problems, "docs/architecture.md:\n" + "\n".join(problems)


# --- cross-references in docstrings -----------------------------------------------------------

#: A Sphinx cross-reference to a Python object: its role and its target (``~`` shows the last part).
CROSS_REFERENCE = re.compile(r":(class|func|mod|meth|attr|data|exc):`~?([^`<>\s]+)`")


def _module_names(tree: ast.Module) -> tuple[set[str], dict[str, set[str]]]:
    """The names a module defines or imports at its top, and each of its classes' members
    (methods, class attributes, fields, and what its methods assign to ``self``)."""
    names, classes = set(), {}
    for node in tree.body:
        if isinstance(node, ast.If):  # TYPE_CHECKING imports, definitions by platform
            nodes = node.body + node.orelse
        elif isinstance(node, ast.Try):
            nodes = node.body + [n for h in node.handlers for n in h.body]
        else:
            nodes = [node]
        for n in nodes:
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names.add(n.name)
            elif isinstance(n, ast.Assign):  # ``A, B = 3, 0.7`` too
                names |= {t.id for target in n.targets for t in ast.walk(target) if isinstance(t, ast.Name)}
            elif isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name):
                names.add(n.target.id)
            elif isinstance(n, (ast.Import, ast.ImportFrom)):
                names |= {(a.asname or a.name).split(".")[0] for a in n.names}
            # a class made from a call (a namedtuple's fields) has members the code does not spell out
            if isinstance(n, ast.ClassDef) and not any(isinstance(b, ast.Call) for b in n.bases):
                members = classes[n.name] = set()
                for child in ast.walk(n):
                    if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                        members.add(child.name)
                    elif isinstance(child, ast.AnnAssign) and isinstance(child.target, ast.Name):
                        members.add(child.target.id)
                    elif isinstance(child, ast.Assign):
                        members |= {t.id for t in child.targets if isinstance(t, ast.Name)}
                    if isinstance(child, ast.Attribute) and isinstance(child.value, ast.Name) \
                            and child.value.id == "self" and isinstance(child.ctx, ast.Store):
                        members.add(child.attr)
    return names, classes


def _resolves(target: str, index: dict) -> bool:
    """Whether ``target`` (dotted, absolute) names a module under the package, or a name one
    defines or imports (and, for a class it defines, one of its members)."""
    parts = target.split(".")
    for i in range(len(parts), 0, -1):
        module = ".".join(parts[:i])
        if module not in index:
            continue
        rest = parts[i:]
        if not rest:
            return True
        names, classes = index[module]
        if rest[0] not in names:
            return False
        return len(rest) == 1 or rest[0] not in classes or (len(rest) == 2 and rest[1] in classes[rest[0]])
    return False


def cross_reference_problems(root: Path) -> list[str]:
    """Each ``:class:``/``:func:``/``:mod:`` (and ``:meth:``, ``:attr:``, ``:data:``, ``:exc:``)
    target under ``root`` that names nothing the package has: a relative one (``.stream.SkelReader``)
    read from the module's package, an absolute one (``spinemesh.files.atomic``) as it is, any
    other from the module, its package or the top package. A bare method or attribute (a member of
    the docstring's class) and a name from another library (``numpy.ndarray``) are left alone."""
    import importlib.util

    modules = _modules(root)
    index = {m: _module_names(ast.parse(p.read_text(encoding="utf-8"), str(p))) for m, (p, _) in modules.items()}
    top = root.name
    problems = []
    for module, (path, is_package) in modules.items():
        package = module if is_package else module.rpartition(".")[0]
        text = path.read_text(encoding="utf-8")
        for match in CROSS_REFERENCE.finditer(text):
            role, target = match.groups()
            if role in ("meth", "attr") and "." not in target:
                continue
            if target.startswith("."):
                dots = len(target) - len(target.lstrip("."))
                base = package.split(".")[:len(package.split(".")) - dots + 1]
                found = _resolves(".".join(base) + "." + target.lstrip("."), index)
            elif target.split(".")[0] == top:
                found = _resolves(target, index)
            else:
                first = target.split(".")[0]
                found = any(_resolves(f"{where}.{target}", index) for where in (module, package, top)) or (
                    first not in index[module][0] and "." in target and importlib.util.find_spec(first) is not None)
            if not found:
                line = text.count("\n", 0, match.start()) + 1
                problems.append(f"{path.relative_to(root.parent).as_posix()}:{line}: :{role}:`{target}`")
    return problems


def test_the_cross_reference_check_finds_what_it_looks_for(tmp_path):
    demo = _write_package(tmp_path, {
        "__init__.py": "",
        "low.py": "class Reader:\n    def read(self):\n        self.at = 0\n",
        "mid/__init__.py": '"""A :class:`.low.Reader` (wrong: no mid.low), :class:`~demo.low.Reader`, '
                           ':meth:`demo.low.Reader.read`, :attr:`demo.low.Reader.at`, :meth:`demo.low.Reader.gone`, '
                           ':mod:`.run`, :func:`.run.go`, :func:`go` (not here), :class:`numpy.ndarray`, '
                           ':meth:`local`."""\n',
        "mid/run.py": '"""See :func:`go`, :mod:`.run` (mid.run), :func:`low.helper`."""\ndef go():\n    pass\n',
    })
    assert [p.split(": ", 1)[1] for p in cross_reference_problems(demo)] == [
        ":class:`.low.Reader`", ":meth:`demo.low.Reader.gone`", ":func:`go`", ":func:`low.helper`"]


def test_docstring_cross_references_name_what_the_code_has():
    """``.stream.SkelReader`` in ``skeleton_binary/v4`` named a module that does not exist (the
    stream is ``skeleton_binary.stream``): every cross-reference resolves, or this names it."""
    problems = cross_reference_problems(PACKAGE)
    assert not problems, "\n".join(problems)
