"""For colcon and other setup.py-based tools: the metadata are in pyproject.toml.

colcon builds ament_python packages by running setup.py; pip does not need this file.
The console scripts go to <prefix>/bin, and pyproject.toml's data-files put the ament
index marker, share/rtcf/package.xml and the wrappers lib/rtcf/rt_runner and
lib/rtcf/rt_launcher (which run them) into the prefix, for pip and colcon alike
(docs/ros2.md, "Installing").
"""

import platform
from pathlib import Path
from typing import Any

from setuptools import Extension, setup
from setuptools.dist import Distribution

# The memory fences of the channels between processes (src/rtcf/_core/_atomics.c).
# x86-64's store order makes them unnecessary there, so a machine without a C compiler
# still installs rtcf; anywhere else the build must succeed (rtcf._core._rings refuses
# to run across processes without them).
_FENCES = Extension(
    "rtcf._core._atomics",
    sources=["src/rtcf/_core/_atomics.c"],
    optional=platform.machine().lower() in ("x86_64", "amd64", "i386", "i686"),
)

# The loop's hot path (src/rtcf/_core/_compiled*.c: slots, ports, the timed part of an
# iteration), one module from one file per concept and their internal header (which
# `depends` names: a change to it rebuilds them all, and the sdist carries it).
# Optional: without a C compiler rtcf installs and runs the same in Python
# (rtcf._core._interpreted), several times slower per component, and says so.
_HOT_PATH = Extension(
    "rtcf._core._compiled",
    sources=[
        f"src/rtcf/_core/{name}.c"
        for name in (
            "_compiled", "_compiled_slot", "_compiled_loop_state", "_compiled_ports",
            "_compiled_plans", "_compiled_calculation", "_compiled_word_tap",
            "_compiled_handover", "_compiled_feeders", "_compiled_limits",
        )
    ],
    depends=["src/rtcf/_core/_compiled.h"],
    optional=True,
)


def _link_project_files() -> None:
    """Give `colcon build --symlink-install` the files that setuptools reads.

    colcon links only setup.py, setup.cfg, the packages and the data files into its
    build directory and runs `setup.py develop` there: without pyproject.toml beside
    it, setuptools would build a package named UNKNOWN. Link the project's other
    top-level files (pyproject.toml, README.md, ...) beside them.
    """
    script = Path(__file__)
    if not script.is_symlink() or script.absolute().parent != Path.cwd():
        return  # pip, or colcon without --symlink-install: run in the source
    source = script.resolve().parent
    for item in source.iterdir():
        link = Path.cwd() / item.name
        if item.is_file() and not item.name.startswith(".") and not link.is_symlink():
            if not link.exists():
                link.symlink_to(item)


class _Distribution(Distribution):
    def parse_config_files(self, *args: Any, **kwargs: Any) -> None:
        super().parse_config_files(*args, **kwargs)
        # pyproject.toml's requires-python arrives as a packaging SpecifierSet, which
        # colcon cannot read back (colcon-python-setup-py evaluates the repr of the
        # configuration with ast.literal_eval, and fails on "<SpecifierSet(...)>"):
        # keep it the string that a setup.py would give.
        if getattr(self, "python_requires", None) is not None:
            self.python_requires = str(self.python_requires)
            self.metadata.python_requires = self.python_requires

    def has_data(self) -> bool:
        # `pip install -e` (setuptools' editable_wheel) installs the data files only
        # when the distribution answers has_data(), which setuptools' Distribution
        # lacks (it has has_data_files(); seen up to setuptools 84.2): without this,
        # an editable install would register nothing in the ament index and put
        # nothing into lib/rtcf/.
        return self.has_data_files()


_link_project_files()
setup(distclass=_Distribution, ext_modules=[_FENCES, _HOT_PATH])
