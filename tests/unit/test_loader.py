"""Finding a component class: the import's errors, and what a running runner's
services refuse without importing anything (absent_component_class)."""

import sys
import textwrap

import pytest

from rtcf._core._errors import ComponentError
from rtcf._core._loader import absent_component_class, load_component_class


@pytest.fixture
def modules(tmp_path, monkeypatch):
    """Write modules into a folder on sys.path: {"pkg/__init__.py": source, ...}."""
    monkeypatch.syspath_prepend(str(tmp_path))
    written = []

    def write(files):
        for name, source in files.items():
            path = tmp_path / name
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(textwrap.dedent(source))
            written.append(path.parts[len(tmp_path.parts)].removesuffix(".py"))
        return tmp_path

    yield write
    for name in list(sys.modules):
        if name.split(".")[0] in written:
            del sys.modules[name]


def test_a_missing_module_or_submodule_is_named_without_importing_its_package(modules):
    root = modules({
        "boom/__init__.py": "raise RuntimeError('imported')\n",
        "boom/real.py": "class A: pass\n",
    })
    assert absent_component_class("rtcf_no_such_mod", "A", component="/c") == (
        "component '/c': module 'rtcf_no_such_mod' is not found; install it or add its "
        "folder to PYTHONPATH")
    said = absent_component_class("boom.nope", "A")
    assert said == "module 'boom.nope' is not found; install it or add its folder to PYTHONPATH"
    assert absent_component_class("boom.real", "A") is None
    assert "boom" not in sys.modules  # its __init__ would have raised
    said = absent_component_class("boom.real", "B")
    assert said == f"module 'boom.real' ({root / 'boom' / 'real.py'}) has no class 'B'"
    assert "boom.real" not in sys.modules


def test_the_import_agrees_where_the_check_refuses(modules):
    modules({"plainmod.py": "class A: pass\n"})
    for module, cls in (("plainmod", "B"), ("rtcf_no_such_mod", "A")):
        assert absent_component_class(module, cls)
        with pytest.raises(ComponentError):
            load_component_class(module, cls)


@pytest.mark.parametrize("source", [
    "class Wanted: pass\n",
    "from os import path as Wanted\n",
    "import Wanted\n",
    "if True:\n    Wanted = 1\nelse:\n    pass\n",
    "try:\n    from x import Wanted\nexcept ImportError:\n    Wanted = None\n",
    "for Wanted in range(2):\n    pass\n",
    "with open(__file__) as Wanted:\n    pass\n",
    "Wanted: int = 1\n",
    "(Wanted := 3)\n",
    "a, (b, Wanted) = 1, (2, 3)\n",
    "def Wanted(): pass\n",
])
def test_a_name_bound_at_the_top_level_in_any_form_is_found(modules, source):
    modules({"bindsit.py": source})
    assert absent_component_class("bindsit", "Wanted") is None


@pytest.mark.parametrize("source", [
    "from os import *\n",
    "def __getattr__(name):\n    return 1\n",
    "globals()['Wanted'] = 1\n",
    "def _register(n):\n    globals()[n] = 1\n_register('Wanted')\n",
    "import sys\nsys.modules[__name__] = object()\n",
    "import lazy\n__getattr__, __dir__ = lazy.attach(__name__)\n",
    "exec('Wanted = 1')\n",
])
def test_a_module_that_binds_names_the_source_does_not_show_is_left_to_the_import(
    modules, source
):
    modules({"dynamic.py": source})
    assert absent_component_class("dynamic", "Wanted") is None


def test_names_inside_functions_and_classes_do_not_count(modules):
    modules({"inner.py": """
        def f():
            Wanted = 1
        class C:
            Wanted = 2
        lambda Wanted: Wanted
        """})
    assert "has no class 'Wanted'" in absent_component_class("inner", "Wanted")


def test_what_only_the_import_can_tell_is_left_to_it(modules):
    modules({"broken.py": "class (:\n", "nsonly/sub.py": "class A: pass\n"})
    assert absent_component_class("broken", "A") is None  # its SyntaxError, from the import
    assert absent_component_class("_ctypes", "A") is None  # an extension module
    assert absent_component_class("os.path", "join") is None  # os's attribute
    assert absent_component_class("nsonly", "A") is None  # a namespace package
    assert absent_component_class("nsonly.sub", "A") is None
    assert absent_component_class("a..b", "A") is None  # refused by the fields' check


def test_an_installed_package_is_found_through_the_meta_path(modules):
    assert absent_component_class("rtcf_examples", "Mimo") is None
    assert "has no class 'NoSuchClass'" in absent_component_class("rtcf_examples", "NoSuchClass")
    assert absent_component_class("rtcf_examples._components", "Pid") is None
