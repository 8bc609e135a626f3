"""The type stubs (bindings/python/stubs/vdbmap/*.pyi, installed beside the module) describe the
module as it is: the same public names in the module, in each submodule (vdbmap.<name> is
described by <name>.pyi) and in every class, and the same parameter names for every function and
method (read from pybind11's signatures). A binding added or renamed without its stub fails here."""
from __future__ import annotations

import ast
import pathlib
import re
import types

import pytest

import vdbmap

STUBS = pathlib.Path(__file__).resolve().parents[2] / "bindings" / "python" / "stubs" / "vdbmap"


def modules_and_stubs():
    """(runtime module, stub file) for vdbmap and each of its submodules."""
    pairs = [(vdbmap, STUBS / "__init__.pyi")]
    for name in sorted(dir(vdbmap)):
        value = getattr(vdbmap, name)
        if isinstance(value, types.ModuleType) and value.__name__.startswith("vdbmap."):
            pairs.append((value, STUBS / f"{name}.pyi"))
    return pairs


def public(names):
    return {n for n in names if not n.startswith("_")}


def stub_classes(tree):
    return {node.name: node for node in tree.body if isinstance(node, ast.ClassDef)}


def class_members(node, classes):
    """Names a stub class declares, with those of its stub bases."""
    names = {}
    for base in node.bases:
        if isinstance(base, ast.Name) and base.id in classes:
            names.update(class_members(classes[base.id], classes))
    for item in node.body:
        if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)):
            names.setdefault(item.name, []).append(item)
        elif isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name):
            names[item.target.id] = []
    return names


def stub_parameters(defs):
    """The set of parameter-name tuples of a (possibly overloaded) stub function, without self."""
    out = set()
    for d in defs:
        if any(isinstance(x, ast.Name) and x.id == "property" for x in d.decorator_list):
            continue
        a = d.args
        names = [x.arg for x in a.posonlyargs + a.args + a.kwonlyargs]
        if names and names[0] == "self":
            names = names[1:]
        if a.vararg:
            names.append("*" + a.vararg.arg)
        if a.kwarg:
            names.append("**" + a.kwarg.arg)
        out.add(tuple(names))
    return out


def runtime_parameters(obj, name):
    """Parameter-name tuples from pybind11's signature lines 'name(a: T, b: T = ...) -> R'."""
    doc = getattr(obj, "__doc__", None) or ""
    out = set()
    for line in doc.splitlines():
        m = re.match(r"^(?:\d+\. )?" + re.escape(name) + r"\((.*)\) -> ", line.strip())
        if not m:
            continue
        depth, current, params = 0, "", []
        for ch in m.group(1):
            if ch in "([{":
                depth += 1
            elif ch in ")]}":
                depth -= 1
            if ch == "," and depth == 0:
                params.append(current)
                current = ""
            else:
                current += ch
        if current.strip():
            params.append(current)
        names = [p.split(":")[0].split("=")[0].strip() for p in params]
        if names and names[0] == "self":
            names = names[1:]
        if names == ["*args", "**kwargs"] and "Overloaded function" in doc:
            continue
        out.add(tuple(names))
    return out


@pytest.fixture(params=modules_and_stubs(), ids=lambda pair: pair[0].__name__)
def module_and_stub(request):
    module, stub = request.param
    assert stub.exists(), f"{module.__name__} has no stub {stub}"
    return module, ast.parse(stub.read_text())


def test_the_stub_names_every_public_module_attribute(module_and_stub):
    module, tree = module_and_stub
    declared = set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            declared.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            declared.add(node.target.id)
        elif isinstance(node, ast.ImportFrom) and node.module is None:  # from . import sim as sim
            declared.update(alias.asname or alias.name for alias in node.names)
    assert public(dir(module)) == public(declared)


def test_every_class_has_the_same_public_members_as_its_stub(module_and_stub):
    module, tree = module_and_stub
    classes = stub_classes(tree)
    for name, node in classes.items():
        if name.startswith("_") or name == "BadFrameError":
            continue
        assert public(dir(getattr(module, name))) == public(class_members(node, classes)), name


def test_every_function_and_method_has_the_stubs_parameter_names(module_and_stub):
    module, tree = module_and_stub
    classes = stub_classes(tree)
    checked = 0
    for node in tree.body:
        if isinstance(node, ast.FunctionDef):
            assert runtime_parameters(getattr(module, node.name), node.name) == stub_parameters([node]), node.name
            checked += 1
    for name, node in classes.items():
        if name.startswith("_") or name == "BadFrameError":
            continue
        runtime_class = getattr(module, name)
        for member, defs in class_members(node, classes).items():
            if not defs or member in ("__eq__", "__ne__", "__hash__", "__index__", "__int__"):
                continue
            expected = stub_parameters(defs)
            if not expected:
                continue  # properties
            assert runtime_parameters(getattr(runtime_class, member), member) == expected, f"{name}.{member}"
            checked += 1
    assert checked > (80 if module is vdbmap else 0)


def has_text_beyond_signature(doc, name):
    lines = [l for l in (doc or "").splitlines() if l.strip()]
    return any(not (l.startswith(name + "(") or l.startswith("Overloaded") or re.match(r"^\d+\. ", l)) for l in lines)


def test_docstrings_everywhere(module_and_stub):
    module, _ = module_and_stub
    assert module.__doc__
    missing = []
    for name in public(dir(module)):
        obj = getattr(module, name)
        if not callable(obj):
            continue
        if not (obj.__doc__ or "").strip():
            missing.append(name)
        if not isinstance(obj, type) or hasattr(obj, "__members__"):
            continue  # enums: their members are documented on the type
        for attr, value in vars(obj).items():
            if attr.startswith("_"):
                continue
            if isinstance(value, property):
                ok = bool((value.__doc__ or "").strip())
            else:
                ok = has_text_beyond_signature(getattr(obj, attr).__doc__, attr)
            if not ok:
                missing.append(f"{name}.{attr}")
    assert missing == []


def test_the_stubs_are_installed_beside_the_module():
    built = pathlib.Path(vdbmap.__file__).parent / "vdbmap"
    if not built.is_dir():
        pytest.skip(f"module not loaded from a build tree with stubs ({vdbmap.__file__})")
    for stub in STUBS.glob("*.pyi"):
        assert (built / stub.name).read_text() == stub.read_text(), stub.name
    assert "ValueError" in vdbmap.__doc__
