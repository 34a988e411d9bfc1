"""The stream script's schema: its JSON read safely and checked before the stream controller sees it.

:func:`load` reads a script (a regular file of at most :data:`mjmotion.caps.MAX_JSON_BYTES`,
UTF-8 JSON; NaN, infinities and numbers too long to be one are refused), :func:`validate`
checks its shape — types, ranges, lengths, known keys — and every message names the key path
(``s.json: script.commands[2].weights.walk: expected a number ≥ 0, got "abc"``). What needs the
clips (names that exist, weights that sum to 1, times within the memory limit) is
:func:`mjmotion.stream.parse_script`'s to check.

The schema is data (:data:`SCRIPT`), so tests and tools can walk it.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from typing import Any

from .caps import MAX_JSON_BYTES
from .errors import MjmotionError
from .inputs import DuplicateKey, once, read_text


@dataclass(frozen=True)
class Num:
    """A finite JSON number ≥ ``lo`` (``> lo`` with ``lo_open``)."""

    lo: float = 0.0
    lo_open: bool = False


@dataclass(frozen=True)
class Str:
    """A JSON string of ``1..max_len`` printable characters."""

    max_len: int = 4096


@dataclass(frozen=True)
class Const:
    """Exactly this JSON value."""

    value: Any


@dataclass(frozen=True)
class Arr:
    """A JSON array of ``min_len..max_len`` items of one schema."""

    item: Any
    min_len: int = 0
    max_len: int = 10_000


@dataclass(frozen=True)
class Map:
    """A JSON object of ``min_len..max_len`` entries: printable names → values of one schema."""

    value: Any
    min_len: int = 0
    max_len: int = 256


@dataclass(frozen=True)
class Obj:
    """A JSON object with these ``fields`` (name → schema), the ``required`` ones present, no others."""

    fields: dict[str, Any]
    required: frozenset[str] = field(default_factory=frozenset)


@dataclass(frozen=True)
class Tagged:
    """A JSON object that is one of ``kinds``: the first key of ``kinds`` it holds picks the schema."""

    kinds: dict[str, Obj]


_CLIP = Obj({"file": Str(), "frames": Str(64)}, frozenset({"file"}))
_COMMAND = Tagged(
    {
        "weights": Obj({"time": Num(), "weights": Map(Num(), 1, 64), "ramp": Num()}, frozenset({"time", "weights"})),
        "play": Obj({"time": Num(), "play": Str(256), "blend": Num()}, frozenset({"time", "play"})),
        "return": Obj({"time": Num(), "return": Const(True), "blend": Num()}, frozenset({"time", "return"})),
    }
)
#: The schema of a stream script (see :mod:`mjmotion.stream`).
SCRIPT = Obj(
    {
        "duration": Num(0.0, lo_open=True),
        "fps": Num(0.0, lo_open=True),
        "loop_blend": Num(),
        "clips": Map(_CLIP, 1, 256),
        "locomotion": Arr(Str(256), 1, 64),
        "commands": Arr(_COMMAND, 1, 10_000),
    },
    frozenset({"duration", "clips", "locomotion", "commands"}),
)


def _key(where: str, name: str) -> str:
    return f"{where}.{name}" if name.isidentifier() else f"{where}[{_show(name)}]"


def _show(value: Any) -> str:
    """A value as the message quotes it: JSON, shortened, escaped."""
    try:
        text = json.dumps(value, ensure_ascii=True)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 40 else text[:40] + "…"


def _kind(value: Any) -> str:
    if isinstance(value, bool):
        return "true/false"
    return {dict: "an object", list: "a list", str: "a string", type(None): "null"}.get(type(value), "a number")


def validate(data: Any, schema: Any = SCRIPT, where: str = "script") -> Any:
    """``data`` if it fits ``schema``; else an :class:`MjmotionError` naming the key path ``where…``."""
    if isinstance(schema, Num):
        ok = isinstance(value := data, (int, float)) and not isinstance(data, bool) and math.isfinite(value)
        if not ok or not (data > schema.lo if schema.lo_open else data >= schema.lo):
            bound = f"{'>' if schema.lo_open else '≥'} {schema.lo:g}"
            raise MjmotionError(f"{where}: expected a finite number {bound}, got {_show(data)}")
    elif isinstance(schema, Str):
        if not isinstance(data, str) or not data or len(data) > schema.max_len or not data.isprintable():
            raise MjmotionError(f"{where}: expected a string of 1 to {schema.max_len} printable characters, got {_show(data)}")
    elif isinstance(schema, Const):
        if type(data) is not type(schema.value) or data != schema.value:
            raise MjmotionError(f"{where}: expected {_show(schema.value)}, got {_show(data)}")
    elif isinstance(schema, Arr):
        if not isinstance(data, list) or not schema.min_len <= len(data) <= schema.max_len:
            got = f"{len(data)} items" if isinstance(data, list) else _kind(data)
            raise MjmotionError(f"{where}: expected a list of {schema.min_len} to {schema.max_len} items, got {got}")
        for i, item in enumerate(data):
            validate(item, schema.item, f"{where}[{i}]")
    elif isinstance(schema, Map):
        if not isinstance(data, dict) or not schema.min_len <= len(data) <= schema.max_len:
            got = f"{len(data)} entries" if isinstance(data, dict) else _kind(data)
            raise MjmotionError(f"{where}: expected an object of {schema.min_len} to {schema.max_len} named entries, got {got}")
        for name, item in data.items():
            if not name or len(name) > 256 or not name.isprintable():
                raise MjmotionError(f"{where}: the name {_show(name)} is not 1 to 256 printable characters")
            validate(item, schema.value, _key(where, name))
    elif isinstance(schema, Obj):
        if not isinstance(data, dict):
            raise MjmotionError(f"{where}: expected an object, got {_kind(data)}")
        unknown = [k for k in data if k not in schema.fields]
        if unknown:
            known = ", ".join(schema.fields)
            raise MjmotionError(f"{where}: unknown field(s) {', '.join(_show(k) for k in sorted(unknown))}; expected {known}")
        for name in schema.fields:
            if name in data:
                validate(data[name], schema.fields[name], _key(where, name))
            elif name in schema.required:
                raise MjmotionError(f"{where}: missing field {name!r}")
    elif isinstance(schema, Tagged):
        if not isinstance(data, dict):
            raise MjmotionError(f"{where}: expected an object, got {_kind(data)}")
        kind = next((k for k in schema.kinds if k in data), None)
        if kind is None:
            raise MjmotionError(f"{where}: expected one of {', '.join(schema.kinds)}")
        validate(data, schema.kinds[kind], where)
    else:  # pragma: no cover - a schema bug
        raise TypeError(f"unknown schema {schema!r}")
    return data


#: Longest integer literal read as an integer (Python refuses to convert 4300+ digits).
_MAX_INT_DIGITS = 30


def _int_or_float(text: str) -> int | float:
    return int(text) if len(text) <= _MAX_INT_DIGITS else float(text)  # a 5000-digit number: inf, refused by validate


def load(path: str | os.PathLike[str]) -> dict:
    """A script's JSON from ``path``, checked against :data:`SCRIPT`; messages name the file."""
    return load_json(path, SCRIPT, "a JSON stream script", "script")


def load_json(path: str | os.PathLike[str], schema: Any, what: str, root: str) -> Any:
    """Any small JSON input (a joint-weight file: ``Map(Num(), 1, MAX_JOINTS)``) read safely and
    checked against ``schema``; messages are ``FILE: ROOT.key[i]: expected …``."""
    p = os.fspath(path)
    text = read_text(p, MAX_JSON_BYTES, what)
    try:
        data = json.loads(text, parse_int=_int_or_float, parse_constant=float, object_pairs_hook=once)  # NaN → refused by validate, with its key
    except DuplicateKey as e:
        raise MjmotionError(f"{p}: {e.key!r} is given twice in one object; give each key once") from None
    except json.JSONDecodeError as e:
        raise MjmotionError(f"{p}:{e.lineno}: not valid JSON ({e.msg})") from None
    except RecursionError:
        raise MjmotionError(f"{p}: JSON nested too deeply; expected {what}") from None
    try:
        return validate(data, schema, root)
    except MjmotionError as e:
        raise MjmotionError(f"{p}: {e}") from None
