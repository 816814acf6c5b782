"""The sans-I/O core stays sans-I/O: no event loop, socket, clock or broker imports.

House rule 1 ("pure core, I/O at the edges") checked on the source of every
core module, so a stray ``import time`` in the geometry fails here, not in a
flaky flight.
"""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

IO_MODULES = {"asyncio", "socket", "selectors", "threading", "time", "aiomqtt", "paho"}

PURE = [
    "convoy_mav.coverage",
    "convoy_mav.convoy",
    "convoy_mav.geo",
    "convoy_mav.history",
    "convoy_mav.monitor",
    "convoy_mav.schedule",
    "convoy_mav.scoring",
    "convoy_mav.types",
    "convoy_mav.mavlink.codec",
    "convoy_mav.mavlink.connection",
    "convoy_mav.mavlink.tlog",
    "convoy_mav.mission.join",
    "convoy_mav.mission.mission",
    "convoy_mav.mission.replan",
    "convoy_mav.mission.view",
    "convoy_mav.planning.dubins",
    "convoy_mav.planning.moving",
    "convoy_mav.planning.plan",
    "convoy_mav.planning.stationary",
    "convoy_mav.publish.topics",
    "convoy_mav.tracks",
    "convoy_mav.tracks.csvfile",
    "convoy_mav.tracks.geotrack",
    "convoy_mav.tracks.gpx",
    "convoy_mav.tracks.kml",
    "convoy_mav.tracks.routejson",
    "convoy_mav.tracks.tlog",
    "convoy_mav.tracks.xmlfeed",
    "sitl_mock.airframe",
    "sitl_mock.autopilot",
    "sitl_mock.flight",
    "sitl_mock.ground",
    "sitl_mock.kinematics",
    "sitl_mock.messages",
    "sitl_mock.params",
    "sitl_mock.personality",
    "sitl_mock.streams",
]


def _imports(module: str) -> set[str]:
    """Full dotted names of everything ``module`` imports (``from a import b`` -> a.b)."""
    source = importlib.import_module(module).__file__
    assert source is not None
    tree = ast.parse(Path(source).read_text(encoding="utf-8"))
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            names |= {node.module} | {f"{node.module}.{alias.name}" for alias in node.names}
    return names


@pytest.mark.parametrize("module", PURE)
def test_core_module_imports_no_io(module: str) -> None:
    names = _imports(module)
    roots = {name.split(".")[0] for name in names}
    assert not roots & IO_MODULES, f"{module} imports {sorted(roots & IO_MODULES)}"
    # The generated dialect only: never pymavlink's mavutil (blocking I/O, globals).
    assert not any(name.startswith("pymavlink.mavutil") for name in names)


def test_codec_does_not_pull_in_asyncio() -> None:
    """Importing the codec (what the mock and the tests share) loads no event loop."""
    code = (
        "import sys, convoy_mav.mavlink.codec, convoy_mav.mavlink.connection;"
        "print(sorted({'asyncio', 'socket'} & set(sys.modules)))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
