"""numpydoc sections on the public API: every public function or class (the ``__all__`` of the
packages in PACKAGES) that takes parameters has a ``Parameters`` section (``Attributes`` for a
dataclass's fields) naming each of them, and a function that returns a value has a ``Returns``
(or ``Yields``) section. A class that inherits its constructor may leave the Parameters to the
class that defines it (``Linear`` to ``Model``). Enumerations are left out: they are looked up
by value, not constructed, and their members are named in the generated catalogue. The public
methods of those classes (defined in the class, not inherited; properties left out) follow the
same rule in the packages of METHODS_CHECKED.

Run as a script to print, per package, how many public names take parameters and which lack
their sections:

    .venv/bin/python tests/style/test_docstrings.py [PACKAGE ...]
"""

from __future__ import annotations

import ast
import dataclasses
import enum
import importlib
import inspect
import re
import sys
import textwrap

import pytest

PACKAGES = [
    "porosense",
    "porosense.protocol",
    "porosense.device",
    "porosense.control",
    "porosense.data",
    "porosense.quant",
    "porosense.dsp",
    "porosense.structure",
    "porosense.ident",
    "porosense.sim",
    "porosense.diagnose",
]
# Packages whose public classes' methods are checked too.
METHODS_CHECKED = [
    "porosense.protocol",
    "porosense.device",
    "porosense.control",
    "porosense.data",
    "porosense.quant",
    "porosense.structure",
    "porosense.ident",
    "porosense.sim",
    "porosense.diagnose",
]

_HEADER = re.compile(r"^(\w[\w ]*)\n-{3,}$", re.MULTILINE)


def sections(doc: str) -> dict[str, str]:
    """The numpydoc sections of a docstring.

    Parameters
    ----------
    doc : str
        A docstring, cleaned (``inspect.getdoc``).

    Returns
    -------
    dict of str to str
        Section title (``"Parameters"``, ``"Returns"``, ...) to the section's text.
    """
    found = list(_HEADER.finditer(doc))
    return {
        m.group(1): doc[m.end() : found[i + 1].start() if i + 1 < len(found) else len(doc)] for i, m in enumerate(found)
    }


def named_entries(section: str) -> set[str]:
    """The names a Parameters or Attributes section describes (``a, b : float`` names two).

    Parameters
    ----------
    section : str
        The section's text, without its title.

    Returns
    -------
    set of str
        The names, without leading ``*``.
    """
    names = set()
    for line in section.splitlines():
        if line and not line[0].isspace():
            for name in line.split(" : ")[0].split(","):
                names.add(name.strip().lstrip("*"))
    return names


def _returns_a_value(func) -> bool:
    """Whether a function returns something: its annotation says so, or (unannotated) one of its own
    return statements carries a value."""
    annotation = inspect.signature(func).return_annotation
    if annotation is not inspect.Signature.empty:
        return annotation not in (None, "None", type(None))
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(func)))
    except (OSError, TypeError, SyntaxError):
        return False
    body = tree.body[0]
    nodes = list(ast.iter_child_nodes(body))
    while nodes:
        node = nodes.pop()
        if isinstance(node, ast.Return) and node.value is not None:
            return True
        if isinstance(node, ast.Yield | ast.YieldFrom):
            return True
        if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda | ast.ClassDef):
            nodes.extend(ast.iter_child_nodes(node))
    return False


def _parameter_names(obj) -> list[str]:
    if dataclasses.is_dataclass(obj):
        return [f.name for f in dataclasses.fields(obj) if f.init and not f.name.startswith("_")]
    target = obj.__init__ if inspect.isclass(obj) else obj
    if not inspect.isfunction(target):  # a builtin's constructor (Exception's): nothing of ours to document
        return []
    try:
        params = inspect.signature(target).parameters
    except (TypeError, ValueError):
        return []
    return [name for name in params if name not in ("self", "cls") and not name.startswith("_")]


def public_names(package: str) -> list[tuple[str, object]]:
    """The functions and classes a package exports, enumerations left out.

    Parameters
    ----------
    package : str
        Dotted module name.

    Returns
    -------
    list of (str, object)
        Name and object of each exported function or class, in ``__all__`` order.
    """
    module = importlib.import_module(package)
    names = getattr(module, "__all__", None)
    assert names is not None, f"{package} has no __all__: its public API is not stated"
    found = []
    for name in names:
        obj = getattr(module, name)
        if inspect.isclass(obj) and issubclass(obj, enum.Enum):
            continue
        if inspect.isfunction(obj) or inspect.isclass(obj):
            found.append((name, obj))
    return found


def problems(obj) -> list[str]:
    """What a public function's or class's docstring lacks.

    Parameters
    ----------
    obj : function or class
        The documented object.

    Returns
    -------
    list of str
        One short phrase per missing section or name; empty when the docstring is complete.
    """
    if inspect.isclass(obj) and not dataclasses.is_dataclass(obj):
        # The constructor's parameters are documented where the constructor is defined.
        obj = next((k for k in obj.__mro__ if "__init__" in vars(k)), obj)
    doc = inspect.getdoc(obj) or ""
    if inspect.isclass(obj) and obj.__doc__ is None:
        doc = ""
    found = sections(doc)
    missing = []
    params = _parameter_names(obj)
    if params:
        title = "Attributes" if dataclasses.is_dataclass(obj) and "Attributes" in found else "Parameters"
        if title not in found:
            missing.append("no Parameters" + (" or Attributes" if dataclasses.is_dataclass(obj) else "") + " section")
        else:
            unnamed = [p for p in params if p not in named_entries(found[title])]
            if unnamed:
                missing.append(f"{title} does not name {', '.join(unnamed)}")
    if inspect.isfunction(obj) and _returns_a_value(obj) and not ({"Returns", "Yields"} & found.keys()):
        missing.append("no Returns section")
    return missing


def public_methods(package: str) -> list[tuple[str, object]]:
    """The public methods of a package's public classes that take parameters or return a value.

    Parameters
    ----------
    package : str
        Dotted module name.

    Returns
    -------
    list of (str, function)
        ``Class.method`` and the function, classmethods and staticmethods unwrapped.
    """
    found = []
    for name, cls in public_names(package):
        if not inspect.isclass(cls):
            continue
        for attr, member in vars(cls).items():
            func = member.__func__ if isinstance(member, classmethod | staticmethod) else member
            if attr.startswith("_") or not inspect.isfunction(func):
                continue
            if _parameter_names(func) or _returns_a_value(func):
                found.append((f"{name}.{attr}", func))
    return found


def report(package: str) -> tuple[int, dict[str, list[str]]]:
    """How many public names of a package take parameters, and what each incomplete one lacks.

    Parameters
    ----------
    package : str
        Dotted module name.

    Returns
    -------
    count : int
        Public functions and classes that take parameters or return a value.
    lacking : dict of str to list of str
        Name to its problems, for the names whose docstring is incomplete.
    """
    count, lacking = 0, {}
    for name, obj in public_names(package):
        if not _parameter_names(obj) and not (inspect.isfunction(obj) and _returns_a_value(obj)):
            continue
        count += 1
        if missing := problems(obj):
            lacking[name] = missing
    return count, lacking


@pytest.mark.parametrize("package", METHODS_CHECKED)
def test_public_methods_have_numpydoc_sections(package):
    methods = public_methods(package)
    assert methods, f"{package}'s public classes have no method that takes parameters"
    lacking = {name: missing for name, func in methods if (missing := problems(func))}
    listing = "\n".join(f"  {name}: {'; '.join(missing)}" for name, missing in lacking.items())
    assert not lacking, (
        f"{len(lacking)} of {len(methods)} public methods of {package} lack numpydoc sections:\n{listing}"
    )


@pytest.mark.parametrize("package", PACKAGES)
def test_public_api_has_numpydoc_sections(package):
    count, lacking = report(package)
    assert count > 0, f"{package} exports no function or class that takes parameters: is __all__ right?"
    listing = "\n".join(f"  {name}: {'; '.join(missing)}" for name, missing in lacking.items())
    assert not lacking, f"{len(lacking)} of {count} public names of {package} lack numpydoc sections:\n{listing}"


def test_checker_sees_a_missing_section_and_an_unnamed_parameter():
    def documented(a, b):
        """Sum.

        Parameters
        ----------
        a, b : float
            Terms, kPa.

        Returns
        -------
        float
            Their sum, kPa.
        """
        return a + b

    def half(a, b):
        """Sum.

        Parameters
        ----------
        a : float
            A term, kPa.
        """
        return a + b

    assert problems(documented) == []
    assert problems(half) == ["Parameters does not name b", "no Returns section"]


def test_checker_reads_an_inherited_constructor_where_it_is_defined():
    class Base:
        """A base.

        Parameters
        ----------
        rate_hz : float
            Sample rate, Hz.
        """

        def __init__(self, rate_hz):
            self.rate_hz = rate_hz

    class Child(Base):
        """A child built like its base."""

    class Own(Base):
        """A child with a constructor of its own and no Parameters section."""

        def __init__(self, rate_hz, gain):
            super().__init__(rate_hz)

    assert problems(Child) == []
    assert problems(Own) == ["no Parameters section"]


if __name__ == "__main__":
    for package in sys.argv[1:] or PACKAGES:
        count, lacking = report(package)
        methods = public_methods(package)
        methods_lacking = {name: missing for name, func in methods if (missing := problems(func))}
        print(
            f"{package}: {count - len(lacking)} of {count} public names documented, "
            f"{len(methods) - len(methods_lacking)} of {len(methods)} public methods"
        )
        for name, missing in {**lacking, **methods_lacking}.items():
            print(f"  {name}: {'; '.join(missing)}")
