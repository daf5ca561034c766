"""Kinds as registries: one row per kind (a fault, a criterion), looked up by its name.

A scenario file names a kind by a string; the registry is the one place that string is defined, with
everything the kind needs (its checks, how it acts or is measured). `registry` builds one from its
rows; `kind_of` is the schema's field type for a name in it, checked when the file is read, so a row
added is a kind the files may use (and its refusal lists it).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Annotated, Any, Protocol, TypeVar

from pydantic import BeforeValidator

from twin_plumbing.fields import Allowed, refuse


class Named(Protocol):
    name: str


R = TypeVar("R", bound=Named)


def registry(*rows: R) -> dict[str, R]:
    """The rows by name, in the order given (the order refusals list them); a name given twice is refused."""
    out = {row.name: row for row in rows}
    if len(out) != len(rows):
        raise ValueError(f"a kind named twice among {', '.join(row.name for row in rows)}")
    return out


def names_text(kinds: Mapping[str, object]) -> str:
    """The kinds as a refusal lists them: 'a' | 'b'."""
    return " | ".join(repr(name) for name in kinds)


def kind_of(kinds: Mapping[str, object]) -> Any:
    """A field holding the name of one of `kinds` (a string), checked against them as they are when
    a file is read."""

    def check(value: object) -> str:
        if not isinstance(value, str) or value not in kinds:
            raise refuse("is not allowed", names_text(kinds))
        return value

    return Annotated[str, BeforeValidator(check), Allowed(names_text(kinds))]
