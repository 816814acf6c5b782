"""Which event loop the service flies on, and how an operator overrides it."""

from __future__ import annotations

import asyncio
import sys

import pytest
import uvloop

from convoy_mav.cli import main
from convoy_mav.errors import ConfigError
from convoy_mav.eventloop import LOOP_ENV, loop_factory, loop_name, run


async def _which() -> str:
    return loop_name(asyncio.get_running_loop())


def test_uvloop_is_picked_when_installed(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(LOOP_ENV, raising=False)
    assert loop_factory() is uvloop.new_event_loop
    assert run(_which()) == "uvloop"


@pytest.mark.parametrize(("env", "expected"), [("asyncio", "asyncio"), (" UVLOOP ", "uvloop")])
def test_the_environment_chooses(monkeypatch: pytest.MonkeyPatch, env: str, expected: str) -> None:
    monkeypatch.setenv(LOOP_ENV, env)
    assert run(_which()) == expected


def test_an_explicit_choice_beats_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(LOOP_ENV, "uvloop")
    assert run(_which(), choice="asyncio") == "asyncio"


def test_without_uvloop_auto_falls_back_and_uvloop_is_a_clear_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(sys.modules, "uvloop", None)  # import uvloop -> ImportError
    assert loop_factory("auto") is asyncio.new_event_loop
    with pytest.raises(ConfigError, match=f"{LOOP_ENV} = 'uvloop': uvloop is not installed"):
        loop_factory("uvloop")


def test_an_unknown_loop_names_the_variable_and_the_value(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv(LOOP_ENV, "trio")
    with pytest.raises(ConfigError, match=f"{LOOP_ENV} = 'trio': must be auto, uvloop or asyncio"):
        loop_factory()


def test_the_command_line_reports_a_bad_loop_and_exits_2(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv(LOOP_ENV, "trio")
    assert main(["demo", "--duration", "10"]) == 2
    assert f"{LOOP_ENV} = 'trio'" in capsys.readouterr().err
