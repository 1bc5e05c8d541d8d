"""The typed stubs name every parameter the compiled functions take, in order, with the same keyword-only split and
defaults. (mypy's stubtest, run by CTest too, checks the names of the module against the stubs, but pybind11's
functions show it no signature; their docstrings do.)"""
import ast
import os
import re

import cpvs

STUB = os.path.join(os.path.dirname(cpvs.__file__), "_cpvs.pyi")


def stub_functions():
    """name -> (positional names, keyword-only names, **kwargs?) of every def in the stub, classes' as Class.def."""
    tree = ast.parse(open(STUB).read())
    out = {}

    def visit(body, prefix):
        for node in body:
            if isinstance(node, ast.ClassDef):
                visit(node.body, node.name + ".")
            elif isinstance(node, ast.FunctionDef) and not node.decorator_list:
                a = node.args
                out[prefix + node.name] = ([x.arg for x in a.posonlyargs + a.args if x.arg != "self"],
                                           [x.arg for x in a.kwonlyargs], a.kwarg is not None)
    visit(tree.body, "")
    return out


def runtime_signature(function):
    """The same from pybind11's docstring, e.g. 'lookup(self: ..., points: handle, *, light: handle = None) -> ...'."""
    first = function.__doc__.splitlines()[0]
    inside = first[first.index("(") + 1:first.rindex(") ->")]
    depth, part, parts = 0, "", []
    for ch in inside:  # split on the commas outside brackets
        depth += ch in "[(" and 1 or ch in "])" and -1 or 0
        if ch == "," and depth == 0:
            parts.append(part.strip())
            part = ""
        else:
            part += ch
    parts.append(part.strip())
    positional, keyword, kwargs, star = [], [], False, False
    for p in parts:
        name = re.split(r"[:=]", p)[0].strip()
        if name == "*":
            star = True
        elif name.startswith("**"):
            kwargs = True
        elif name and name != "self":
            (keyword if star else positional).append(name)
    return positional, keyword, kwargs


def test_every_stub_function_matches_the_module():
    stubs = stub_functions()
    objects = {"open": cpvs.open, "read_info": cpvs.read_info, "bake": cpvs.bake, "sample": cpvs.sample,
               "reference": cpvs.reference, "ShadowFile.lookup": cpvs.ShadowFile.lookup,
               "Reference.lookup": cpvs.Reference.lookup}
    for name, function in objects.items():
        assert name in stubs, name
        assert stubs[name] == runtime_signature(function), name
