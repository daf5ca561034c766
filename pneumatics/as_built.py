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

import tomllib
from pathlib import Path
from typing import NamedTuple

from pneumatics.params import SPEC, JointParams, ParameterError, check_value, validated

SOURCES = ("datasheet", "literature", "assumed", "calibrated")
KEYS = {"value", "source", "basis"}


class AsBuiltEffect(NamedTuple):
    field: str
    value: float
    source: str
    basis: str


def load_as_built_effects(path: str | Path) -> tuple[AsBuiltEffect, ...]:
    """The effects of one as-built file, checked field by field (ParameterError on bad input)."""
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ParameterError(f"{path}: no such as-built file") from None
    except tomllib.TOMLDecodeError as e:
        raise ParameterError(f"{path}: not valid TOML: {e}") from None
    unknown = sorted(set(doc) - {"effects"})
    if unknown:
        raise ParameterError(f"{path}: unknown table [{unknown[0]}]; allowed: [effects.<JointParams field>]")
    out = []
    for field, table in doc.get("effects", {}).items():
        where = f"{path}: [effects.{field}]"
        if field not in SPEC:
            raise ParameterError(f"{where} is not a JointParams field; allowed: {', '.join(SPEC)}")
        if not isinstance(table, dict) or set(table) - KEYS or "value" not in table:
            raise ParameterError(f"{where} = {table!r}; allowed: a table with value, source, basis")
        source = table.get("source")
        if source not in SOURCES:
            raise ParameterError(f"{where} source = {source!r}; allowed: {' | '.join(SOURCES)}")
        basis = table.get("basis", "")
        if not isinstance(basis, str) or not basis:
            raise ParameterError(f"{where} basis = {basis!r}; allowed: a non-empty string: where the number comes from")
        out.append(AsBuiltEffect(field, check_value(str(path), field, table["value"]), source, basis))
    return tuple(out)


def as_built(nominal: JointParams, effects: tuple[AsBuiltEffect, ...], source: str = "<as-built>") -> JointParams:
    """The nominal parameters with the as-built effects applied, checked as a whole."""
    return validated(nominal._replace(**{e.field: e.value for e in effects}), source)


def load_as_built(nominal: JointParams, path: str | Path) -> JointParams:
    """Nominal parameters + the as-built file at `path`."""
    return as_built(nominal, load_as_built_effects(path), str(path))
