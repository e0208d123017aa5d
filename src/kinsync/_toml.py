"""The one TOML parser of kinsync's readers (mounts, INS configurations).

`toml_document` accepts a UTF-8 byte-order mark and names the line and column of a
syntax error, in plain words where Python's parser is terse; `kinsync.mount` exports
it.
"""

from __future__ import annotations

import re
import tomllib
from typing import Any

from kinsync.errors import InputError

__all__ = ["toml_document"]

_BOM = "\ufeff"
_TOML_END = " (at end of document)"
_TOML_WHERE = re.compile(r"^(?P<what>.*?) \(at line (?P<line>\d+), column (?P<col>\d+)\)$")


_TOML_TWICE = re.compile(r"^Cannot declare \((?P<key>.*?),?\) twice$")
_TOML_CLOSED = re.compile(r"^Cannot mutate immutable namespace \((?P<key>.*?),?\)$")


def _plain_toml_reason(reason: str, body: str, line_no: int) -> str | None:
    """The parser's message for a name given twice, in plain words (else None).

    tomllib says "Cannot overwrite a value" for a key written twice, naming no key; the
    key is read from the line it points at.
    """
    if reason == "Cannot overwrite a value":
        lines = body.split("\n")[:line_no]
        text = next((ln.strip() for ln in reversed(lines) if ln.strip()), "")
        key = text.split("=", 1)[0].strip() if "=" in text else text
        named = f" ({key})" if key else ""
        return (
            f"a key given twice in its table, or a key that is also a table{named}; "
            "keep one of the two"
        )
    if (m := _TOML_TWICE.match(reason)) is not None:
        lines = body.split("\n")
        header = lines[line_no - 1].split("#", 1)[0].strip() if line_no <= len(lines) else ""
        if not header.endswith("]"):  # tomllib checks the name before the bracket
            return f"malformed TOML: table header {header!r} lacks its closing ']'; add it"
        name = ".".join(part.strip().strip("'\"") for part in m["key"].split(","))
        return f"table [{name}] is declared twice; merge the two into one table"
    if (m := _TOML_CLOSED.match(reason)) is not None:
        name = ".".join(part.strip().strip("'\"") for part in m["key"].split(","))
        return (
            f"{name} was written as an inline table or array and is extended later; "
            "write all of its keys in one place"
        )
    return None


def toml_document(text: str, source: str) -> dict[str, Any]:
    """Parse a TOML document; the one TOML parser of kinsync's readers.

    Parameters
    ----------
    text : str
        The document; a leading UTF-8 byte-order mark (as some Windows editors write)
        is dropped.
    source : str
        Name used in error messages (usually the file path).

    Returns
    -------
    dict
        The parsed document.

    Raises
    ------
    InputError
        Malformed TOML: ``<source>: line L, column C: malformed TOML: <reason>``; a
        key or table given twice, or an inline table extended later (said in plain
        words, naming the key); an integer of more than 4300 digits; nesting too deep
        for the parser.
    """
    body = text.removeprefix(_BOM)
    try:
        doc: dict[str, Any] = tomllib.loads(body)
    except tomllib.TOMLDecodeError as err:
        where = _TOML_WHERE.match(str(err))
        if where is not None:
            place, reason = f"line {where['line']}, column {where['col']}: ", where["what"]
        elif str(err).endswith(_TOML_END):
            last = body.rsplit("\n", 1)[-1]
            line = body.count("\n") + 1
            place = f"line {line}, column {len(last) + 1} (end of document): "
            reason = str(err).removesuffix(_TOML_END)
        else:
            place, reason = "", str(err)
        line_no = int(where["line"]) if where is not None else body.count("\n") + 1
        plain = _plain_toml_reason(reason, body, line_no)
        if plain is not None:
            msg = f"{source}: {place}{plain}"
        else:
            msg = f"{source}: {place}malformed TOML: {reason}; fix the TOML syntax there"
        raise InputError(msg) from err
    except ValueError as err:  # tomllib's int() of more than 4300 digits
        reason = str(err).split(";")[0].split(":")[0]
        msg = f"{source}: malformed TOML: a number too long to read ({reason})"
        raise InputError(msg) from err
    except RecursionError as err:
        msg = f"{source}: malformed TOML: arrays or tables nested too deeply"
        raise InputError(msg) from err
    return doc
