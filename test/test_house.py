"""House rules read from the source: short functions and modules, one home each, no ctypes.

No function of ``swazure_ros`` or ``bench`` is longer than 80 lines, its
docstring aside (numpydoc's sections document the code, they are not code to
hold in mind), and none takes more than 10 parameters (``self`` and ``cls``
aside) unless it is a numba kernel (decorated ``@jit.kernel``), whose arrays
numba takes one by one. No module of ``swazure_ros`` uses ctypes: a mirror of
a C library's structs breaks silently when the library changes (issue 53).
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = "swazure_ros"
ROOT = REPO / PACKAGE
#: The folders the rules hold in: the product and its benchmarks.
SCANNED = (ROOT, REPO / "bench")
MOST_LINES = 80
MOST_PARAMETERS = 10

Function = ast.FunctionDef | ast.AsyncFunctionDef


def functions(tree: ast.AST, prefix: str = "") -> Iterator[tuple[str, Function]]:
    """Every function of ``tree``, nested ones too, with its qualified name."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            yield prefix + node.name, node
            yield from functions(node, f"{prefix}{node.name}.")
        elif isinstance(node, ast.ClassDef):
            yield from functions(node, f"{prefix}{node.name}.")
        else:
            yield from functions(node, prefix)


def parameters(function: Function) -> int:
    """How many parameters ``function`` takes, ``self`` or ``cls`` aside."""
    arguments = function.args
    named = [*arguments.posonlyargs, *arguments.args, *arguments.kwonlyargs]
    count = len(named) + (arguments.vararg is not None) + (arguments.kwarg is not None)
    if arguments.args[:1] and arguments.args[0].arg in ("self", "cls"):
        count -= 1
    return count


def code_lines(function: Function) -> int:
    """The lines of ``function``, less those of its docstring."""
    lines = (function.end_lineno or function.lineno) - function.lineno + 1
    first = function.body[0]
    value = first.value if isinstance(first, ast.Expr) else None
    if isinstance(value, ast.Constant) and isinstance(value.value, str):
        lines -= (first.end_lineno or first.lineno) - first.lineno + 1
    return lines


def is_kernel(function: Function) -> bool:
    """Whether ``function`` is a numba kernel: decorated ``@jit.kernel``."""
    return any(ast.unparse(d).startswith("jit.kernel") for d in function.decorator_list)


def offenders(roots: tuple[Path, ...] = SCANNED) -> list[str]:
    """Each function over the limits, as "file:line: name: why"."""
    found = []
    for root in roots:
        for path in sorted(root.rglob("*.py")):
            for name, function in functions(ast.parse(path.read_text(), str(path))):
                lines = code_lines(function)
                count = parameters(function)
                why = []
                if lines > MOST_LINES:
                    why.append(f"{lines} lines")
                if count > MOST_PARAMETERS and not is_kernel(function):
                    why.append(f"{count} parameters")
                if why:
                    where = path.relative_to(root.parent).as_posix()
                    found.append(f"{where}:{function.lineno}: {name}: {', '.join(why)}")
    return found


def ctypes_users(root: Path = ROOT) -> list[str]:
    """Each module under ``root`` that names ctypes, in an import or in code it runs."""
    return sorted(
        path.relative_to(root.parent).as_posix()
        for path in root.rglob("*.py")
        if "ctypes" in path.read_text()
    )


def test_no_function_is_over_80_lines_or_10_parameters_outside_kernels():
    assert offenders() == []


def test_the_scan_sees_long_functions_and_kernels():
    source = "def f(a, b, c, d, e, f, g, h, i, j, k):\n" + "    pass\n" * 80
    source += "class C:\n    @jit.kernel(cache=True)\n"
    source += "    def g(self, a, b, c, d, e, f, g, h, i, j, k): ...\n"
    named = dict(functions(ast.parse(source)))
    assert set(named) == {"f", "C.g"}
    assert parameters(named["f"]) == 11 and parameters(named["C.g"]) == 11
    assert not is_kernel(named["f"]) and is_kernel(named["C.g"])
    assert named["f"].end_lineno - named["f"].lineno + 1 == 81


def test_the_scan_reports_a_long_function_by_file_and_line(tmp_path: Path) -> None:
    (tmp_path / "long.py").write_text("x = 1\n\n\ndef f():\n" + "    pass\n" * 80)
    (tmp_path / "short.py").write_text("def g():\n" + "    pass\n" * 79)
    assert offenders((tmp_path,)) == [f"{tmp_path.name}/long.py:4: f: 81 lines"]


def test_the_scan_counts_a_function_s_code_not_its_docstring(tmp_path: Path) -> None:
    documented = '    """Summary.\n\n' + "    More.\n" * 30 + '    """\n'
    (tmp_path / "long.py").write_text("def f():\n" + documented + "    pass\n" * 80)
    (tmp_path / "short.py").write_text("def g():\n" + documented + "    pass\n" * 79)
    assert offenders((tmp_path,)) == [f"{tmp_path.name}/long.py:1: f: 81 lines"]


def test_no_module_of_the_package_uses_ctypes() -> None:
    assert ctypes_users() == []


def test_the_ctypes_scan_sees_a_module_that_loads_libc(tmp_path: Path) -> None:
    (tmp_path / "exit.py").write_text("import ctypes\nctypes.CDLL(None).exit(0)\n")
    (tmp_path / "clean.py").write_text("import os\n")
    assert ctypes_users(tmp_path) == [f"{tmp_path.name}/exit.py"]


# The fourth floor (issue 70): rooms of one job, one home for the array types and
# for the engine's pipeline, typed documents, the core documented like scipy.

#: No module of the package is longer than this: a longer one holds two jobs.
MOST_MODULE_LINES = 600
#: ``dict[str, Any]`` is a document whose shape nobody wrote down: a few are
#: honest (JSON from outside, rclpy's parameter maps), most had a type.
MOST_ANY_DICTS = 20
#: The engine's steps after plain Swazure; a module that calls them builds the pipeline.
PIPELINE_STEPS = frozenset({"run_technique", "fuse_paths", "fuse", "refine"})


def long_modules(root: Path = ROOT, most: int = MOST_MODULE_LINES) -> list[str]:
    """Each module under ``root`` longer than ``most`` lines, as "file: lines"."""
    found = []
    for path in sorted(root.rglob("*.py")):
        lines = len(path.read_text().splitlines())
        if lines > most:
            found.append(f"{path.relative_to(root.parent).as_posix()}: {lines}")
    return found


def array_alias_definitions(roots: tuple[Path, ...] = SCANNED) -> list[str]:
    """Each module-level ``NameArray = NDArray[...]``, as "file:line: name"."""
    found = []
    for root in roots:
        for path in sorted(root.rglob("*.py")):
            for node in ast.parse(path.read_text(), str(path)).body:
                target = node.target if isinstance(node, ast.AnnAssign) else None
                if isinstance(node, ast.Assign) and len(node.targets) == 1:
                    target = node.targets[0]
                value = node.value if isinstance(node, ast.Assign | ast.AnnAssign) else None
                if (
                    isinstance(target, ast.Name)
                    and target.id.endswith("Array")
                    and value is not None
                    and ast.unparse(value).startswith("NDArray[")
                ):
                    where = path.relative_to(root.parent).as_posix()
                    found.append(f"{where}:{node.lineno}: {target.id}")
    return found


def any_dicts(root: Path = ROOT) -> list[str]:
    """Each ``dict[str, Any]`` written in a module under ``root``, as "file:line"."""
    return [
        f"{path.relative_to(root.parent).as_posix()}:{number}"
        for path in sorted(root.rglob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), 1)
        for _ in range(line.count("dict[str, Any]"))
    ]


def pipeline_builders(root: Path = ROOT) -> list[str]:
    """Each module outside ``core/`` that calls an engine step after plain Swazure."""
    found = set()
    for path in sorted(root.rglob("*.py")):
        if path.relative_to(root).parts[0] == "core":
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Call):
                called = node.func
                name = called.attr if isinstance(called, ast.Attribute) else None
                name = called.id if isinstance(called, ast.Name) else name
                if name in PIPELINE_STEPS:
                    found.add(path.relative_to(root.parent).as_posix())
    return sorted(found)


def test_no_module_of_the_package_is_over_600_lines() -> None:
    assert long_modules() == []


def test_the_array_types_are_defined_once() -> None:
    assert [line.split(": ")[-1] for line in array_alias_definitions()] == [
        "FloatArray",
        "IntArray",
        "IdArray",
        "BoolArray",
    ]


def test_at_most_20_documents_are_typed_dict_of_str_to_any() -> None:
    found = any_dicts()
    assert len(found) <= MOST_ANY_DICTS, found


def test_the_engine_pipeline_is_built_in_at_most_one_module_outside_core() -> None:
    found = pipeline_builders()
    assert len(found) <= 1, found


def test_the_module_scans_see_what_they_look_for(tmp_path: Path) -> None:
    package = tmp_path / "package"
    (package / "core").mkdir(parents=True)
    (package / "core" / "engine.py").write_text("def plain(x):\n    return refine(x)\n")
    (package / "cli.py").write_text(
        "from numpy.typing import NDArray\nFloatArray = NDArray[np.float64]\n"
        "def run(doc: dict[str, Any]) -> dict[str, Any]:\n    return fuse(run_technique(doc))\n"
        + "\n"
        * 600
    )
    assert long_modules(package) == ["package/cli.py: 604"]
    assert array_alias_definitions((package,)) == ["package/cli.py:2: FloatArray"]
    assert any_dicts(package) == ["package/cli.py:3", "package/cli.py:3"]
    assert pipeline_builders(package) == ["package/cli.py"]
