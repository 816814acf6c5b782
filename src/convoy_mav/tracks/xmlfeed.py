"""Feeding expat the GPX and KML readers' bytes, its errors as theirs.

Both readers use expat, the parser ``xml.etree`` itself uses, because it reports
the line of each element for their messages; this is the part they share. Pure.
"""

from __future__ import annotations

from typing import BinaryIO
from xml.parsers import expat

__all__ = ["feed_xml"]


def feed_xml(
    parser: expat.XMLParserType, data: bytes | str | BinaryIO, name: str, what: str
) -> None:
    """Parse ``data`` whole (a file object in chunks, never held whole).

    Raises:
        ValueError: ``name:line: not well-formed WHAT: reason``; what a handler
            raises passes through as it is.
    """
    try:
        if isinstance(data, bytes | str):
            parser.Parse(data, True)
        else:
            parser.ParseFile(data)
    except expat.ExpatError as e:
        reason = expat.ErrorString(e.code)
        raise ValueError(f"{name}:{e.lineno}: not well-formed {what}: {reason}") from None
