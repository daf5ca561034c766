"""Checked fields for the TOML inputs (joint parameters, scenarios, campaigns), on pydantic v2.

Each field type says what it accepts and, in words, what is allowed (`number(0, 1, "s")` accepts a
finite number in 0..1 and says "a number in 0..1 s"); pydantic walks a file's tables and arrays of
tables with these, forbids unknown keys, and fills the defaults the schema declares. `first_problem`
turns pydantic's first error into where it is (the path of keys and indices in the file), the
value, why it is refused and what is allowed: the parts of the one-line message each loader writes
in its own file's wording. Only numbers, whole numbers, choices, strings and booleans need these;
tables, arrays and maps are plain pydantic.
"""

from __future__ import annotations

import math
import tomllib
import types
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, Literal, NamedTuple, Union, get_args, get_origin

from pydantic import BeforeValidator, ConfigDict, ValidationError
from pydantic_core import PydanticCustomError

from twin_plumbing.paths import input_problem

MISSING = "<missing>"  # the value of a field the file does not give
TABLE = ConfigDict(extra="forbid")  # every table refuses keys it does not know


class Allowed(NamedTuple):
    """What a field allows, in words (kept in the field's Annotated metadata)."""

    text: str


class Problem(NamedTuple):
    """The first thing wrong with a file: where (keys and indices), the value, why, what is allowed."""

    loc: tuple[str | int, ...]
    value: object  # MISSING when the field is absent
    why: str  # "is missing", "is not a known field", "is not a number", ...
    allowed: str


def refuse(why: str, allowed: str, value: object = MISSING) -> PydanticCustomError:
    """The error a field's check raises: why the value is refused and what is allowed (`value`: the
    part of the input to quote, e.g. one pair of a list; by default the whole input)."""
    ctx = {"why": why, "allowed": allowed} | ({} if value is MISSING else {"value": value})
    return PydanticCustomError("not_allowed", "{why}; allowed: {allowed}", ctx)


def range_text(low: float, high: float, unit: str = "", above: bool = False, integer: bool = False) -> str:
    """What a range allows, in words: "a number in 0..45 deg", "a whole number > 0 and <= 256",
    "a finite number >= 0" (no upper bound)."""
    kind = "a whole number" if integer else "a number"
    u = f" {unit}" if unit else ""
    lo = str(int(low)) if integer else f"{low:g}"
    if math.isinf(high):
        return f"a finite {kind[2:]} {'>' if above else '>='} {lo}{u}"
    hi = str(int(high)) if integer else f"{high:g}"
    return f"{kind} > {lo}{u} and <= {hi}{u}" if above else f"{kind} in {lo}..{hi}{u}"


def number_check(
    low: float, high: float, unit: str = "", integer: bool = False
) -> tuple[Callable[[object], float], str]:
    """The check of a finite number in low..high (booleans are not numbers; with `integer` a whole
    one, 4 or 4.0) and its allowed text."""
    allowed = range_text(low, high, unit, integer=integer)

    def check(value: object) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise refuse("is not a number", allowed)
        if not math.isfinite(value) or not low <= value <= high:
            raise refuse("is outside the allowed range", allowed)
        if integer and value != round(value):
            raise refuse("is not a whole number", allowed)
        return float(value)

    return check, allowed


def number(low: float, high: float, unit: str = "", integer: bool = False) -> Any:
    """A finite number in low..high (with `integer` a whole one), read as a float."""
    check, allowed = number_check(low, high, unit, integer)
    return Annotated[float, BeforeValidator(check), Allowed(allowed)]


def whole(low: int, high: int) -> Any:
    """A whole number in low..high (a TOML integer, not 1.0 nor true)."""
    allowed = f"a whole number in {low}..{high}"

    def check(value: object) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise refuse("is not allowed", allowed)
        return value

    return Annotated[int, BeforeValidator(check), Allowed(allowed)]


def choice(*options: str, why: str = "is not allowed") -> Any:
    """One of `options` (strings), quoted in the message as 'a' | 'b'; `why` says what else is."""
    allowed = " | ".join(repr(o) for o in options)

    def check(value: object) -> object:
        if value not in options:
            raise refuse(why, allowed)
        return value

    return Annotated[Literal[options], BeforeValidator(check), Allowed(allowed)]


def _typed(kind: type | tuple[type, ...], allowed: str) -> Any:
    def check(value: object) -> object:
        if not isinstance(value, kind) or (kind is not bool and isinstance(value, bool)):
            raise refuse("is not allowed", allowed)
        return value

    return Annotated[kind if isinstance(kind, type) else float, BeforeValidator(check), Allowed(allowed)]


TEXT = _typed(str, "a string")
REAL = _typed((int, float), "a number")  # any int or float, nan and inf included: checked by its user
FLAG = _typed(bool, "true or false")  # strict: TOML's true/false, not 1 or "yes"

# what pydantic's own structural errors mean in a TOML file
_STRUCTURE = {
    "model_type": "a table",
    "dataclass_type": "a table",
    "dict_type": "a table",
    "list_type": "an array",
    "tuple_type": "an array",
    "too_short": "more entries",
}
_UNKNOWN = ("extra_forbidden", "unexpected_keyword_argument")


def first_problem(error: ValidationError, schema: type) -> Problem:
    """Where, what, why and what is allowed, from the first of pydantic's errors on `schema`."""
    e = error.errors(include_url=False)[0]
    loc, kind = tuple(e["loc"]), e["type"]
    if kind == "not_allowed":
        return Problem(loc, e["ctx"].get("value", e["input"]), e["ctx"]["why"], e["ctx"]["allowed"])
    if kind in ("missing", "missing_argument"):
        return Problem(loc, MISSING, "is missing", _allowed_of(_fields(_type_at(schema, loc[:-1]))[loc[-1]]))
    if kind in _UNKNOWN:
        return Problem(loc, e["input"], "is not a known field", ", ".join(_fields(_type_at(schema, loc[:-1]))))
    return Problem(loc, e["input"], "is not allowed", _STRUCTURE.get(kind, e["msg"]))


def _fields(tp: type) -> dict[str, Any]:
    """The fields of a pydantic model or dataclass by name ({} for anything else)."""
    return getattr(tp, "__pydantic_fields__", {})


def _bare(tp: Any) -> Any:
    """`tp` without Annotated and without `| None`."""
    while get_origin(tp) is Annotated:
        tp = get_args(tp)[0]
    if get_origin(tp) in (Union, types.UnionType):
        tp = next(a for a in get_args(tp) if a is not type(None))
    return tp


def _type_at(schema: type, loc: tuple[str | int, ...]) -> Any:
    """The type that the value at `loc` has in `schema` (a table, an item of an array, a map's value)."""
    tp = schema
    for key in loc:
        if isinstance(key, int):
            tp = get_args(tp)[0]  # list[X], tuple[X, ...]
        elif _fields(tp):
            tp = _fields(tp)[key].annotation
        else:
            tp = get_args(tp)[-1]  # dict[str, X]
        tp = _bare(tp)
    return tp


def _allowed_of(field: Any) -> str:
    for meta in field.metadata:
        if isinstance(meta, Allowed):
            return meta.text
    return "a table" if _fields(_bare(field.annotation)) else str(field.annotation)


def read_toml(path: Path, error: type[Exception], what: str) -> tuple[dict, str]:
    """The TOML document at `path` and its text; `error` (one line naming the path) if it is
    missing, unreadable or not TOML."""
    problem = input_problem(path)
    if problem:
        raise error(f"{path}: {problem}; allowed: a readable {what} on disk")
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark at the start allowed (an editor's)
    except FileNotFoundError:
        raise error(f"{path}: no such {what}") from None
    except (UnicodeDecodeError, IsADirectoryError, PermissionError) as e:
        raise error(f"{path}: cannot be read as a text file ({e})") from None
    except OSError as e:
        raise error(f"{path}: cannot be read ({e.strerror or e})") from None
    return parse_toml(text, str(path), error), text


def parse_toml(text: str, source: str, error: type[Exception]) -> dict:
    """The TOML document in `text`; `error` naming `source` if it is not TOML."""
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise error(f"{source}: not valid TOML: {e}") from None
