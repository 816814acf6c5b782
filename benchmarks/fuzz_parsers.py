"""Coverage-guided fuzzing of the pure parsers with atheris (a long run, not a test).

    .venv/bin/pip install atheris
    .venv/bin/python benchmarks/fuzz_parsers.py codec -runs=200000
    .venv/bin/python benchmarks/fuzz_parsers.py mqtt -max_total_time=300

Targets: ``codec`` (MAVLink bytes), ``tracks`` (CSV, GPX, tlog), ``config`` (a TOML
document), ``mqtt`` (the inbound payloads). Each must return a result or refuse
with its own typed error; anything else is a crash atheris reports with its input.
The hypothesis versions of the same checks run in CI (``tests/unit/test_fuzz_parsers.py``).
"""

from __future__ import annotations

import contextlib
import sys
import tomllib
from collections.abc import Callable

import atheris

with atheris.instrument_imports():
    from convoy_mav.config import parse_config
    from convoy_mav.errors import ConfigError
    from convoy_mav.mavlink.codec import MavCodec
    from convoy_mav.publish import topics
    from convoy_mav.tracks.csvfile import parse_csv_track
    from convoy_mav.tracks.gpx import parse_gpx_track
    from convoy_mav.tracks.tlog import parse_tlog_track


def codec(data: bytes) -> None:
    c = MavCodec()
    c.feed_datagram(data)
    c.feed(data)


def tracks(data: bytes) -> None:
    parsers: list[Callable[[], object]] = [
        lambda: parse_csv_track(data.decode("utf-8", "replace").splitlines(), "f.csv"),
        lambda: parse_gpx_track(data, "f.gpx"),
        lambda: parse_tlog_track(data, "f.tlog"),
    ]
    for parse in parsers:
        with contextlib.suppress(ValueError):
            parse()


def config(data: bytes) -> None:
    try:
        doc = tomllib.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError):
        return
    with contextlib.suppress(ConfigError):
        parse_config(doc)


def mqtt(data: bytes) -> None:
    for parse in (topics.parse_convoy_position, topics.parse_command, topics.parse_convoy_route):
        with contextlib.suppress(topics.BadPayload):
            parse(data)


TARGETS: dict[str, Callable[[bytes], None]] = {
    "codec": codec, "tracks": tracks, "config": config, "mqtt": mqtt,
}  # fmt: skip


def main() -> None:
    if len(sys.argv) < 2 or sys.argv[1] not in TARGETS:
        sys.exit(f"usage: fuzz_parsers.py {{{','.join(TARGETS)}}} [libFuzzer options]")
    target = TARGETS[sys.argv.pop(1)]
    atheris.Setup(sys.argv, target)
    atheris.Fuzz()


if __name__ == "__main__":
    main()
