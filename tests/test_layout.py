"""The code's layout: no import cycles (imports inside functions included), folders of at
most 12 modules, modules of at most 400 lines, functions of at most 60 code lines, no
storage id spelled outside ``core/storage/``, a small public API, and a core that installs
as ``gencoords`` and imports from any folder without Blender."""

import ast
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
MAX_MODULES_PER_FOLDER = 12
MAX_FUNCTION_LINES = 60
MAX_TOP_LEVEL_NAMES = 25
MAX_MODULE_LINES = 400  # as the add-on's (tests/addon/test_addon_package.py)
STORAGE_IDS = {"AUTO", "EXACT", "COMPACT", "SPARSE"}


def module_name(path):
    """Dotted name of a .py file under the repository (``core/base/inputs.py`` -> ``core.base.inputs``)."""
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def modules(folder):
    return {module_name(path): path for path in sorted((REPO / folder).rglob("*.py"))}


def imported_modules(name, path, known):
    """Modules of ``known`` that ``path`` imports anywhere (top level and inside functions).

    ``from package import name`` counts as importing ``package.name`` when that is a module,
    else ``package``; the extension's ``from .. import core`` reaches the repository's core.
    """
    is_package = path.name == "__init__.py"
    package = name.split(".") if is_package else name.split(".")[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - node.level + 1]  # empty above the top package
                stem = ".".join(base + ([node.module] if node.module else []))
            else:
                stem = node.module
            full = [f"{stem}.{alias.name}" if stem else alias.name for alias in node.names]
            targets = [name if name in known else stem for name in full]
        else:
            continue
        for target in targets:
            while target and target not in known:
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


def cycle_in(graph):
    """One import cycle of ``graph`` (name -> set of names) as a list, or None."""
    state, stack = {}, []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for following in sorted(graph[node]):
            if state.get(following) == "open":
                return stack[stack.index(following):] + [following]
            if following not in state and (found := visit(following)):
                return found
        stack.pop()
        state[node] = "done"
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def import_graph():
    known = {**modules("core"), **modules("gencoords_addon")}
    return {name: imported_modules(name, path, known) for name, path in known.items()}


def test_the_cycle_finder_finds_a_cycle():
    assert cycle_in({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert cycle_in({"a": {"b"}, "b": set()}) is None


def test_the_import_scan_sees_imports_inside_functions(tmp_path):
    source = tmp_path / "probe.py"
    source.write_text("def f():\n    from .evaluation.cage import Cage\n", encoding="utf-8")
    known = modules("core")
    assert imported_modules("core.probe", source, known) == {"core.evaluation.cage"}


@pytest.mark.parametrize("package", ["core", "gencoords_addon"])
def test_no_import_cycle(package):
    graph = import_graph()
    inside = {name: {other for other in targets if other.split(".")[0] == package}
              for name, targets in graph.items() if name.split(".")[0] == package}
    assert cycle_in(inside) is None, f"import cycle: {' -> '.join(cycle_in(inside))}"


def test_the_add_on_enum_and_layout_modules_are_leaves():
    graph = import_graph()
    for leaf in ("gencoords_addon.enums", "gencoords_addon.bind_layout"):
        assert {name for name in graph[leaf] if name.startswith("gencoords_addon")} == set()


def test_the_core_imports_nothing_of_the_add_on_and_no_blender():
    for name, targets in import_graph().items():
        if name.startswith("core"):
            assert not any(target.startswith("gencoords_addon") for target in targets), name
    for path in (REPO / "core").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.Import, ast.ImportFrom)):
                names = [alias.name for alias in node.names] + [getattr(node, "module", None) or ""]
                assert not any(n.split(".")[0] in ("bpy", "mathutils", "bmesh") for n in names), path


def test_no_folder_of_the_core_holds_more_than_12_modules():
    for folder in [REPO / "core", *(p for p in (REPO / "core").rglob("*") if p.is_dir())]:
        count = len([p for p in folder.glob("*.py") if p.name != "__init__.py"])
        assert count <= MAX_MODULES_PER_FOLDER, f"{folder.relative_to(REPO)} holds {count} modules"


def test_no_module_of_the_core_is_over_400_lines():
    found = {str(path.relative_to(REPO)): len(path.read_text(encoding="utf-8").splitlines())
             for path in sorted((REPO / "core").rglob("*.py"))}
    assert {name: count for name, count in found.items()
            if count > MAX_MODULE_LINES} == {}


def storage_id_literals(path):
    """(line, value) of every string literal in ``path``'s code that is a storage id
    (docstrings and comments may name them; code uses ``gencoords.storage.Storage``)."""
    return [(node.lineno, node.value) for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
            if isinstance(node, ast.Constant) and node.value in STORAGE_IDS]


def test_the_storage_ids_are_spelled_only_in_the_storage_folder():
    found = [f"{path.relative_to(REPO)}:{line} {value!r}" for path in sorted((REPO / "core").rglob("*.py"))
             if "storage" not in path.relative_to(REPO / "core").parts[:1]
             for line, value in storage_id_literals(path)]
    assert found == []


def test_the_storage_id_scan_sees_a_literal_and_not_a_docstring(tmp_path):
    source = tmp_path / "probe.py"
    source.write_text('"""Stored \'SPARSE\'."""\nchoice = "EXACT"\n', encoding="utf-8")
    assert storage_id_literals(source) == [(2, "EXACT")]


def storage_spellings(path):
    """Where ``path`` spells a storage id as a string ('SPARSE' or 'sparse'; 'Sparse' is the
    panel's word) rather than through the enum (``gencoords.storage.Storage``). 'AUTO' is
    also the Worker Processes preference's, so it is not looked for."""
    from gencoords.storage import Storage

    ids = {storage.value for storage in Storage} - {Storage.AUTO.value}
    ids |= {value.lower() for value in ids}
    return [f"{path.name}:{node.lineno} {node.value!r}"
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value in ids]


def test_the_storage_finder_finds_a_spelled_storage(tmp_path):
    source = tmp_path / "probe.py"
    source.write_text('"""Sparse."""\nif data.storage == \'SPARSE\' or kind == "compact" or label == "Exact":\n'
                      '    pass\n', encoding="utf-8")
    assert storage_spellings(source) == ["probe.py:2 'SPARSE'", "probe.py:2 'compact'"]


def test_storage_ids_are_spelled_only_in_the_storage_modules():
    """The add-on names a storage through the core's enum; each storage's decisions live in
    its module under ``gencoords_addon/storage/``."""
    home = REPO / "gencoords_addon" / "storage"
    found = [f"{path.parent.name}/{spelling}" for path in sorted((REPO / "gencoords_addon").rglob("*.py"))
             if home not in path.parents for spelling in storage_spellings(path)]
    assert not found


def test_the_graph_builds_nodes_and_the_storages_write_the_mesh():
    """``graph/`` neither reads nor writes mesh data (``blender_io.mesh_arrays``) nor knows the
    storages' modules: each storage's module writes its attributes and calls the graph."""
    graph = import_graph()
    for name, targets in graph.items():
        if name.startswith("gencoords_addon.graph"):
            assert not {target for target in targets
                        if target == "gencoords_addon.blender_io.mesh_arrays"
                        or target.startswith("gencoords_addon.storage")}, name
    assert "gencoords_addon.graph.deformer" in graph["gencoords_addon.storage.exact"]


def code_lines(function, source_lines):
    """Lines of ``function`` holding code: no blank lines, comments or docstrings."""
    docstrings = set()
    for node in ast.walk(function):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) \
                    and isinstance(first.value.value, str):
                docstrings.update(range(first.lineno, first.end_lineno + 1))
    return sum(1 for number in range(function.lineno, function.end_lineno + 1)
               if number not in docstrings
               and source_lines[number - 1].strip() and not source_lines[number - 1].strip().startswith("#"))


def long_functions(package):
    found = []
    for path in sorted((REPO / package).rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        lines = text.splitlines()
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                count = code_lines(node, lines)
                if count > MAX_FUNCTION_LINES:
                    found.append(f"{path.relative_to(REPO)}:{node.lineno} {node.name} ({count} lines)")
    return found


def test_code_lines_skip_docstrings_and_comments():
    source = 'def f():\n    """Doc.\n\n    More."""\n    # why\n    x = 1\n\n    return x\n'
    function = ast.parse(source).body[0]
    assert code_lines(function, source.splitlines()) == 3  # def, x = 1, return


@pytest.mark.parametrize("package", ["core", "gencoords_addon"])
def test_no_function_over_60_code_lines(package):
    assert long_functions(package) == []


def test_the_public_api_is_small_and_every_sub_api_lists_its_names():
    import gencoords
    assert len(gencoords.__all__) <= MAX_TOP_LEVEL_NAMES
    for api in (gencoords, *gencoords.SUB_APIS):
        assert len(set(api.__all__)) == len(api.__all__), api.__name__
        for name in api.__all__:
            assert hasattr(api, name), f"{api.__name__}.{name}"


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """The core installed by pip (no network: this venv's setuptools builds it) into a folder."""
    target = tmp_path_factory.mktemp("site")
    # A copy of what the package is built from: pip builds in the source folder (build/,
    # *.egg-info), which must not be the checkout other runs use at the same time.
    source = tmp_path_factory.mktemp("source")
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / name, source / name)
    shutil.copytree(REPO / "core", source / "core", ignore=shutil.ignore_patterns("__pycache__"))
    completed = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-build-isolation", "--no-deps",
         "--no-index", "--target", str(target), str(source)],
        capture_output=True, text=True, cwd=source)
    assert completed.returncode == 0, completed.stderr
    return target


def test_pip_installs_the_core_as_gencoords_and_it_imports_from_another_folder(installed, tmp_path):
    assert not (installed / "core").exists()  # the import name, never the folder's
    probe = textwrap.dedent(f"""
        import sys
        import numpy as np
        import gencoords
        assert gencoords.__file__.startswith({str(installed)!r}), gencoords.__file__
        from gencoords.cages.shapes import icosphere
        vertices, faces = icosphere(1)
        points = np.random.default_rng(0).uniform(-0.3, 0.3, size=(400, 3))
        alone = gencoords.coordinates(points, vertices, faces, workers=1)
        spread = gencoords.coordinates(points, vertices, faces, workers=2)  # workers import gencoords
        assert np.array_equal(alone, spread)
        assert not any(name.split(".")[0] in ("bpy", "core") for name in sys.modules), "bpy or core imported"
        print("ok", len(gencoords.__all__))
    """)
    environment = {key: value for key, value in os.environ.items() if key != "PYTHONPATH"}
    environment["PYTHONPATH"] = str(installed)
    completed = subprocess.run([sys.executable, "-c", probe], cwd=tmp_path, capture_output=True, text=True,
                               env=environment)
    assert completed.returncode == 0, completed.stderr
    assert completed.stdout.startswith("ok")


def test_the_core_package_and_the_extension_have_one_version():
    """gencoords.__version__ is the one source: pyproject.toml reads it, the manifest
    repeats it (and the installed package's metadata says it)."""
    import importlib.metadata
    import tomllib

    import gencoords
    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    assert "version" in pyproject["project"]["dynamic"] and "version" not in pyproject["project"]
    assert pyproject["tool"]["setuptools"]["dynamic"]["version"] == {"attr": "gencoords.__version__"}
    extension = tomllib.loads((REPO / "blender_manifest.toml").read_text(encoding="utf-8"))["version"]
    assert gencoords.__version__ == extension == importlib.metadata.version("gencoords")


def public_objects():
    """(qualified name, object) of every function and class the public APIs list in
    ``__all__``: the top level, its named sub-APIs (``gencoords.SUB_APIS``) and the modules
    they name (the layers below are internal)."""
    import inspect

    import gencoords
    apis = [gencoords, *gencoords.SUB_APIS] + [getattr(api, name) for api in gencoords.SUB_APIS
                                               for name in api.__all__ if inspect.ismodule(getattr(api, name))]
    found = {}
    for api in apis:
        for name in getattr(api, "__all__", ()):
            value = getattr(api, name)
            if (inspect.isfunction(value) or inspect.isclass(value)) and not issubclass_of_exception(value):
                found.setdefault(f"{api.__name__}.{name}", value)
    return sorted(found.items())


def issubclass_of_exception(value):
    return isinstance(value, type) and issubclass(value, BaseException)


@pytest.mark.parametrize("name, value", public_objects())
def test_every_public_function_has_examples_that_run(name, value):
    import doctest
    import inspect
    # cleandoc: Python 3.13 strips docstrings' indentation when compiling, 3.11 does not
    assert "\nExamples\n--------\n" in inspect.cleandoc(value.__doc__ or ""), \
        f"{name}: no numpydoc Examples section"
    test = doctest.DocTestParser().get_doctest(value.__doc__, {}, name, None, 0)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    output = []
    runner.run(test, out=output.append)
    assert runner.failures == 0 and runner.tries > 0, "".join(output)
