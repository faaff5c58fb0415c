"""The type stubs (mfcbeam/_mfcbeam.pyi) describe the compiled module: the
same names, and for every function and method the same parameters, kinds
and defaults as the signature the module reports (inspect.signature)."""

import ast
import inspect
from pathlib import Path

import pytest

import mfcbeam
from mfcbeam import _mfcbeam

STUBS = ast.parse((Path(mfcbeam.__file__).parent / "_mfcbeam.pyi").read_text())
TYPE_ONLY = {"ArrayLike", "FloatArray", "BoolArray", "StrPath"}


def stub_classes():
    return {n.name: n for n in STUBS.body if isinstance(n, ast.ClassDef)}


def is_typed_dict(node):
    return any(getattr(b, "id", None) == "TypedDict" for b in node.bases)


def stub_functions(body):
    return {n.name: n for n in body if isinstance(n, ast.FunctionDef)}


def public(names):
    return {n for n in names if not n.startswith("_")}


def test_the_same_names():
    classes = {k for k, v in stub_classes().items() if not is_typed_dict(v)}
    functions = set(stub_functions(STUBS.body))
    runtime = public(dir(_mfcbeam))
    assert classes | functions == runtime
    assert set(mfcbeam.__all__) == runtime | {"__version__"}
    assert isinstance(mfcbeam.__version__, str)


def stub_parameters(fn, drop_self):
    a = fn.args
    params = []
    positional = a.posonlyargs + a.args
    defaults = [None] * (len(positional) - len(a.defaults)) + a.defaults
    for arg, default in zip(positional, defaults):
        params.append((arg.arg, "positional", default))
    for arg, default in zip(a.kwonlyargs, a.kw_defaults):
        params.append((arg.arg, "keyword", default))
    if drop_self and params and params[0][0] == "self":
        params = params[1:]
    return [(n, k, None if d is None else ast.literal_eval(d)) for n, k, d in params]


def runtime_parameters(obj):
    out = []
    for p in inspect.signature(obj).parameters.values():
        kind = "keyword" if p.kind is p.KEYWORD_ONLY else "positional"
        default = None if p.default is p.empty else p.default
        out.append((p.name, kind, default))
    return out


@pytest.mark.parametrize("name", sorted(stub_functions(STUBS.body)))
def test_function_signatures(name):
    stub = stub_parameters(stub_functions(STUBS.body)[name], drop_self=False)
    assert stub == runtime_parameters(getattr(_mfcbeam, name))


@pytest.mark.parametrize("name", sorted(k for k, v in stub_classes().items() if not is_typed_dict(v)))
def test_class_members_and_signatures(name):
    node, cls = stub_classes()[name], getattr(_mfcbeam, name)
    methods = stub_functions(node.body)
    assert public(methods) == public(dir(cls)), name
    for m, fn in methods.items():
        if m in ("__copy__", "__deepcopy__"):
            continue
        decorators = {getattr(d, "id", None) for d in fn.decorator_list}
        if "property" in decorators:
            assert isinstance(inspect.getattr_static(cls, m), type(_mfcbeam.Model.sample_time)), m
            continue
        target = cls if m == "__init__" else getattr(cls, m)
        stub = stub_parameters(fn, drop_self=True)
        assert stub == [p for p in runtime_parameters(target) if p[0] != "self"], (name, m)
