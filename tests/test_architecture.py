"""The package's shape as a test: one-way layers, no import cycles, no oversized code.

The layers (docs/architecture.md), lowest first; a module imports only from its own
layer or a lower one:

core        kinsync, errors, frames, trajectory, mount, messages, crs, crs_axes, robust, _*
algorithms  budget, fit, clock, latency, sync, ins, georef, validation, calibration
io          file formats
pipelines   files streamed through the algorithms
sim         simulators (they write the files real sensors do)
report      figures and the HTML report
demo        the demo's sections
cli         the command line

io reads and writes the containers of the algorithm packages, so it may import their
classes, type aliases and constants, never their functions. Algorithm and core modules
never print, exit, open files or take a path. Every import counts: at the top, inside
functions and under ``TYPE_CHECKING``.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import shutil
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"

LAYERS: tuple[tuple[str, tuple[str, ...]], ...] = (
    (
        "core",
        (
            "kinsync",
            "kinsync.__init__",
            "kinsync._arrays",
            "kinsync._lazy",
            "kinsync._toml",
            "kinsync._typing",
            "kinsync._validate",
            "kinsync.crs",
            "kinsync.crs_axes",
            "kinsync.errors",
            "kinsync.frames",
            "kinsync.messages",
            "kinsync.mount",
            "kinsync.mount_slips",
            "kinsync.robust",
            "kinsync.trajectory",
            "kinsync.trajectory_gaps",
            "kinsync.trajectory_rows",
            "kinsync.trajectory_times",
            "kinsync.trajectory_velocity",
            "kinsync.time_spans",
        ),
    ),
    (
        "algorithms",
        (
            "kinsync.budget",
            "kinsync.calibration",
            "kinsync.clock",
            "kinsync.fit",
            "kinsync.georef",
            "kinsync.ins",
            "kinsync.latency",
            "kinsync.sync",
            "kinsync.validation",
        ),
    ),
    ("io", ("kinsync.io",)),
    ("pipelines", ("kinsync.pipelines",)),
    ("sim", ("kinsync.sim",)),
    ("report", ("kinsync.report",)),
    ("demo", ("kinsync.demo",)),
    ("cli", ("kinsync.cli", "kinsync.__main__")),
)
LAYER_NAMES = tuple(name for name, _ in LAYERS)
PURE_LAYERS = ("core", "algorithms")  # no printing, exiting, files or paths

MAX_MODULE_LINES = 900
MAX_FUNCTION_LINES = 100  # statements after the docstring; numba kernels are exempt


@dataclass(frozen=True)
class Import:
    """One ``import`` of a kinsync module: who, what, which names and where."""

    module: str
    target: str
    names: tuple[str, ...]
    line: int


def module_name(path: Path, src: Path) -> str:
    """``kinsync.georef.kernel`` for ``src/kinsync/georef/kernel.py`` (packages by name)."""
    parts = path.relative_to(src).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def layer_of(module: str) -> str:
    """The layer a kinsync module belongs to (its longest listed prefix)."""
    best, best_len = "", -1
    for name, prefixes in LAYERS:
        for prefix in prefixes:
            if (module == prefix or module.startswith(prefix + ".")) and len(prefix) > best_len:
                best, best_len = name, len(prefix)
    if not best:
        msg = f"{module} is in no layer: add it to LAYERS and docs/architecture.md"
        raise AssertionError(msg)
    return best


def modules(src: Path) -> dict[str, Path]:
    """Every module of the package under ``src``, by dotted name."""
    return {module_name(p, src): p for p in sorted((src / "kinsync").rglob("*.py"))}


def imports(src: Path) -> Iterator[Import]:
    """Every import of a kinsync module anywhere in the package (absolute or relative)."""
    for mod, path in modules(src).items():
        is_pkg = path.name == "__init__.py"
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == "kinsync":
                        yield Import(mod, alias.name, (), node.lineno)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    pkg = mod.split(".") if is_pkg else mod.split(".")[:-1]
                    pkg = pkg[: len(pkg) - node.level + 1]
                    base = ".".join([*pkg, base] if base else pkg)
                if base.split(".")[0] != "kinsync":
                    continue
                names = tuple(a.name for a in node.names)
                yield Import(mod, base, names, node.lineno)


def resolved_targets(imp: Import, known: set[str]) -> list[str]:
    """The modules an import loads: ``from pkg import sub`` names the submodule."""
    subs = [f"{imp.target}.{n}" for n in imp.names if f"{imp.target}.{n}" in known]
    return subs or [imp.target]


def layer_violations(src: Path) -> list[str]:
    """Imports that go up the layers (or io importing an algorithm's function)."""
    known = set(modules(src))
    out = []
    for imp in imports(src):
        here = layer_of(imp.module)
        for target in resolved_targets(imp, known):
            there = layer_of(target)
            if LAYER_NAMES.index(there) > LAYER_NAMES.index(here):
                out.append(
                    f"{imp.module} (line {imp.line}, layer {here}) imports {target} (layer {there})"
                )
    return out


def io_function_imports(src: Path) -> list[str]:
    """Functions io imports from the algorithm packages (it may take only containers)."""
    out = []
    for imp in imports(src):
        if layer_of(imp.module) != "io" or layer_of(imp.target) != "algorithms":
            continue
        if not imp.names:
            out.append(f"{imp.module} (line {imp.line}) imports the module {imp.target}")
            continue
        module = importlib.import_module(imp.target)
        for name in imp.names:
            obj = getattr(module, name, None)
            if inspect.isfunction(obj) or inspect.isbuiltin(obj):
                out.append(
                    f"{imp.module} (line {imp.line}) imports the function {imp.target}.{name}"
                )
    return out


def import_cycles(src: Path) -> list[list[str]]:
    """Strongly connected groups of modules that import each other (Tarjan)."""
    known = set(modules(src))
    graph: dict[str, set[str]] = {m: set() for m in known}
    for imp in imports(src):
        for target in resolved_targets(imp, known):
            if target in known and target != imp.module:
                graph[imp.module].add(target)
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                cycles.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return cycles


def impure_code(src: Path) -> list[str]:
    """print, sys.exit, open(), Path.read_*/write_* or a ``Path`` parameter in core/algorithms."""
    out = []
    for mod, path in modules(src).items():
        if layer_of(mod) not in PURE_LAYERS:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            where = f"{mod} (line {getattr(node, 'lineno', 0)})"
            if isinstance(node, ast.Call):
                func = ast.unparse(node.func)
                if func in ("print", "open", "sys.exit", "exit") or func.endswith(
                    (".read_text", ".write_text", ".read_bytes", ".write_bytes", ".open")
                ):
                    out.append(f"{where} calls {func}")
            elif isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                args = [*node.args.args, *node.args.kwonlyargs, *node.args.posonlyargs]
                out.extend(
                    f"{where}: {node.name}() takes a path ({arg.arg})"
                    for arg in args
                    if arg.annotation is not None and "Path" in ast.unparse(arg.annotation)
                )
    return out


def _compiled(tree: ast.Module) -> set[str]:
    """Names of functions compiled by numba: ``njit(...)(f)``, ``_jit(f)``, ``@njit``."""
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and "jit" in ast.unparse(node.func):
            names.update(a.id for a in node.args if isinstance(a, ast.Name))
        if isinstance(node, ast.FunctionDef) and any(
            "jit" in ast.unparse(d) for d in node.decorator_list
        ):
            names.add(node.name)
    return names


def oversized(src: Path) -> list[str]:
    """Modules over MAX_MODULE_LINES lines; functions over MAX_FUNCTION_LINES (no kernels)."""
    out = []
    for mod, path in modules(src).items():
        text = path.read_text(encoding="utf-8")
        n_lines = text.count("\n")
        if n_lines > MAX_MODULE_LINES:
            out.append(f"{mod}: {n_lines} lines (at most {MAX_MODULE_LINES})")
        tree = ast.parse(text)
        compiled = _compiled(tree)
        for node in ast.walk(tree):
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            body = node.body
            first = body[0]
            if (
                isinstance(first, ast.Expr)
                and isinstance(first.value, ast.Constant)
                and isinstance(first.value.value, str)
                and len(body) > 1
            ):
                first = body[1]
            n_body = (node.end_lineno or node.lineno) - first.lineno + 1
            if n_body > MAX_FUNCTION_LINES and node.name not in compiled:
                out.append(
                    f"{mod}.{node.name} (line {node.lineno}): {n_body} lines of body "
                    f"(at most {MAX_FUNCTION_LINES})"
                )
    return out


# ---------------------------------------------------------------------- the package
def test_every_module_has_a_layer() -> None:
    for mod in modules(SRC):
        layer_of(mod)  # raises for a module in no layer


def test_layers_import_one_way() -> None:
    found = layer_violations(SRC)
    assert not found, "\n".join(found)


def test_io_takes_only_containers_from_the_algorithms() -> None:
    found = io_function_imports(SRC)
    assert not found, "\n".join(found)


def test_no_import_cycle() -> None:
    cycles = import_cycles(SRC)
    assert not cycles, "\n".join(" <-> ".join(c) for c in cycles)


def test_algorithms_never_print_exit_or_touch_files() -> None:
    found = impure_code(SRC)
    assert not found, "\n".join(found)


def test_no_oversized_module_or_function() -> None:
    found = oversized(SRC)
    assert not found, "\n".join(found)


# ---------------------------------------------------------------------- the checks
@pytest.fixture
def tree(tmp_path: Path) -> Path:
    """A copy of the package source to break on purpose."""
    shutil.copytree(SRC / "kinsync", tmp_path / "kinsync")
    return tmp_path


def _append(path: Path, text: str) -> None:
    path.write_text(path.read_text(encoding="utf-8") + text, encoding="utf-8")


def test_an_algorithm_importing_io_is_caught(tree: Path) -> None:
    path = tree / "kinsync" / "latency" / "sphere.py"
    _append(path, "\nfrom kinsync.io.las import las_info\n")
    expected = (
        f"kinsync.latency.sphere (line {_last_line(path)}, layer algorithms) imports "
        "kinsync.io.las (layer io)"
    )
    assert layer_violations(tree) == [expected]


def test_imports_inside_functions_and_relative_ones_count(tree: Path) -> None:
    path = tree / "kinsync" / "latency" / "planning.py"
    _append(path, "\ndef _late() -> None:\n    from ..cli import app\n")
    found = layer_violations(tree)
    assert len(found) == 1
    assert "kinsync.latency.planning" in found[0]
    assert "imports kinsync.cli.app (layer cli)" in found[0]


def test_core_importing_pipelines_and_a_cycle_are_caught(tree: Path) -> None:
    _append(tree / "kinsync" / "frames.py", "\nimport kinsync.pipelines.georef\n")
    assert any("kinsync.frames" in v for v in layer_violations(tree))
    cycles = import_cycles(tree)
    assert any("kinsync.frames" in group for group in cycles)


def test_a_cycle_inside_a_package_is_caught(tree: Path) -> None:
    path = tree / "kinsync" / "georef" / "trajectory.py"
    _append(path, "\nfrom kinsync.georef import georeference\n")
    assert any(
        {"kinsync.georef", "kinsync.georef.trajectory"} <= set(c) for c in import_cycles(tree)
    )


def test_io_importing_an_algorithm_function_is_caught(tree: Path) -> None:
    _append(tree / "kinsync" / "io" / "las.py", "\nfrom kinsync.fit import fit_sphere\n")
    expected = (
        f"kinsync.io.las (line {_last_line(tree / 'kinsync/io/las.py')}) imports the "
        "function kinsync.fit.fit_sphere"
    )
    assert io_function_imports(tree) == [expected]


def test_printing_and_paths_in_an_algorithm_are_caught(tree: Path) -> None:
    _append(
        tree / "kinsync" / "budget.py",
        "\ndef _leak(p: Path) -> None:\n    print(p.read_text())\n",
    )
    found = impure_code(tree)
    assert any("_leak() takes a path" in v for v in found)
    assert any("calls print" in v for v in found)
    assert any("calls p.read_text" in v for v in found)


def test_an_oversized_function_is_caught(tree: Path) -> None:
    body = "".join(f"    x{i} = {i}\n" for i in range(MAX_FUNCTION_LINES + 1))
    _append(tree / "kinsync" / "budget.py", f'\ndef _long() -> None:\n    """Doc."""\n{body}')
    found = [v for v in oversized(tree) if "_long" in v]
    assert len(found) == 1
    assert f"{MAX_FUNCTION_LINES + 1} lines of body" in found[0]


def _last_line(path: Path) -> int:
    return path.read_text(encoding="utf-8").count("\n")
