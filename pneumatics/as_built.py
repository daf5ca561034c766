"""The as-built arm: what the real joint has that the controller's nominal model lacks.

An as-built file (assets/as_built/<joint>.toml) lists, per joint, effects on top of the nominal
parameter file (assets/joints/<joint>.toml): each a JointParams field with its value, its source
and the basis of the number,

    [effects.reducer_compliance_rad_per_nm]
    value = 2.9e-4
    source = "datasheet"          # datasheet | literature | assumed | calibrated
    basis = "Harmonic Drive CSF-17: K1 = 3.4e3 N·m/rad"

Reality (the plant of scenarios and of `twin paper`) is the nominal parameters with these applied;
the predictor keeps the nominal ones (DESIGN rule 7: reality and predictor share no more than the
nominal model). A bad file is refused with its path, the field, the value and what is allowed.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

from pydantic import BaseModel, Field, ValidationError

from pneumatics.params import SPEC, JointParams, check_value, validated
from twin_plumbing.errors import ParameterError
from twin_plumbing.fields import MISSING, TABLE, TEXT, choice, first_problem, read_toml

SOURCES = ("datasheet", "literature", "assumed", "calibrated")


class AsBuiltEffect(NamedTuple):
    field: str
    value: float
    source: str
    basis: str


class _Entry(BaseModel):
    """One [effects.<field>] table; the value is checked against its field's range afterwards."""

    model_config = TABLE

    value: object  # checked against its field's range (check_value) once the field is known
    source: choice(*SOURCES)
    basis: TEXT = Field(min_length=1)


_ALLOWED = {
    "value": "a number in the range of the JointParams field the table names",
    "basis": "a non-empty string: where the number comes from",
}


class _AsBuiltFile(BaseModel):
    model_config = TABLE
    effects: dict[choice(*SPEC), _Entry] = {}


def _message(path: Path, e: ValidationError) -> str:
    """The one-line refusal of an as-built file: `<file>: [effects.<field>] key = value ...; allowed: ...`."""
    p = first_problem(e, _AsBuiltFile)
    if p.loc[0] != "effects":
        return f"{path}: unknown table [{p.loc[0]}]; allowed: [effects.<JointParams field>]"
    if len(p.loc) == 1:
        return f"{path}: effects = {p.value!r}; allowed: tables [effects.<JointParams field>]"
    if p.loc[-1] == "[key]":
        return f"{path}: [effects.{p.loc[1]}] is not a JointParams field; allowed: {', '.join(SPEC)}"
    if len(p.loc) == 2:
        return f"{path}: [effects.{p.loc[1]}] = {p.value!r}; allowed: a table with value, source, basis"
    where = f"{path}: [effects.{p.loc[1]}] {p.loc[2]}"
    allowed = _ALLOWED.get(p.loc[2], p.allowed) if p.why != "is not a known field" else p.allowed
    if p.value is MISSING or p.why == "is not a known field":
        return f"{where} {p.why}; allowed: {allowed}"
    return f"{where} = {p.value!r} {p.why}; allowed: {allowed}"


def load_as_built_effects(path: str | Path) -> tuple[AsBuiltEffect, ...]:
    """The effects of one as-built file, checked field by field (ParameterError on bad input)."""
    path = Path(path)
    doc, _ = read_toml(path, ParameterError, "as-built file")
    try:
        entries = _AsBuiltFile.model_validate(doc).effects
    except ValidationError as e:
        raise ParameterError(_message(path, e)) from None
    return tuple(
        AsBuiltEffect(field, check_value(str(path), field, e.value), e.source, e.basis) for field, e in entries.items()
    )


def as_built(nominal: JointParams, effects: tuple[AsBuiltEffect, ...], source: str = "<as-built>") -> JointParams:
    """The nominal parameters with the as-built effects applied, checked as a whole."""
    return validated(nominal._replace(**{e.field: e.value for e in effects}), source)


def load_as_built(nominal: JointParams, path: str | Path) -> JointParams:
    """Nominal parameters + the as-built file at `path`."""
    return as_built(nominal, load_as_built_effects(path), str(path))
