"""The joint parameter files: every real file loads; a bad one is refused with a message that
names the file, the field, the value and what is allowed (STYLE rule 7).

Each bad file is the real assets/joints/wrist_pitch.toml with exactly one edit.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import assets
from pneumatics import JointParams, load_joint_params
from pneumatics.params import SPEC
from twin_plumbing.errors import ParameterError

REAL = assets.joint_param_path("wrist_pitch")
TEXT = REAL.read_text()


@pytest.mark.parametrize("joint", assets.JOINTS)
def test_every_real_file_loads(joint: str) -> None:
    params = load_joint_params(assets.joint_param_path(joint))
    assert isinstance(params, JointParams)
    for field, value in zip(JointParams._fields, params, strict=True):
        assert SPEC[field].low <= value <= SPEC[field].high, field


def test_wrist_file_holds_the_papers_numbers() -> None:
    p = load_joint_params(REAL)
    assert p.ratio == 120  # paper: LHS-17-120
    assert p.n_vanes == 4  # paper: 4 vanes
    assert p.valve_time_constant_s == 0.1  # paper Sec. IV
    assert p.k_u_per_pa == pytest.approx(0.1959e-5)  # paper k_u = 0.1959 per bar


def _set_line(field: str, new_line: str) -> str:
    """TEXT with the line that assigns `field` replaced (comment and all)."""
    pattern = re.compile(rf"^{field}\s*=.*$", re.M)
    assert len(pattern.findall(TEXT)) == 1, field
    return pattern.sub(new_line, TEXT)


BAD = {
    # name: (file text, words the message must hold besides the path)
    "missing": (_set_line("ratio", ""), ["ratio", "missing", "1..10000"]),
    "negative": (_set_line("coulomb_nm", "coulomb_nm = -15.0"), ["coulomb_nm", "-15", "0..10000"]),
    "out_of_range": (_set_line("n_vanes", "n_vanes = 40"), ["n_vanes", "40", "2..12"]),
    "too_small": (_set_line("inlet_area_m2", "inlet_area_m2 = 5.0e-12"), ["inlet_area_m2", "5e-12", "1e-08..0.001"]),
    "non_number": (_set_line("ratio", 'ratio = "120"'), ["ratio", "'120'", "not a number", "1..10000"]),
    "boolean": (_set_line("hose_loss", "hose_loss = true"), ["hose_loss", "True", "not a number", "0..1"]),
    "nan": (_set_line("viscous_nm_s", "viscous_nm_s = nan"), ["viscous_nm_s", "nan", "0..10000"]),
    "vanes_not_whole": (
        _set_line("n_vanes", "n_vanes = 4.5"),
        ["[motor] n_vanes", "4.5", "not a whole number", "a whole number in 2..12 vanes"],
    ),
    "hose_loss_half": (_set_line("hose_loss", "hose_loss = 0.5"), ["hose_loss", "0.5", "0 or 1"]),
    "brake_fed_half": (
        _set_line("brake_fed_by_motor", "brake_fed_by_motor = 0.5"),
        ["brake_fed_by_motor", "0.5", "0 or 1"],
    ),
    "brake_band_inverted": (
        _set_line("brake_release_start_gauge_pa", "brake_release_start_gauge_pa = 6.0e5"),
        ["brake_release_start_gauge_pa", "600000", "brake_release_gauge_pa", "must not exceed"],
    ),
    "rotor_not_inside_stator": (
        _set_line("rotor_radius_m", "rotor_radius_m = 0.012"),
        ["rotor_radius_m", "0.012", "stator_radius_m"],
    ),
    "unknown_field": (
        TEXT.replace("[motor]\n", "[motor]\ncolour = 3\n"),
        ["colour", "not a known field", "stator_radius_m"],
    ),
    "field_in_wrong_table": (
        _set_line("ratio", "").replace("[motor]\n", "[motor]\nratio = 120\n"),
        ["ratio", "[motor]", "not a known field"],
    ),
    "unknown_table": (TEXT + "\n[gearbox]\nratio = 120\n", ["[gearbox]", "unknown table", "motor", "effects"]),
    "effects_out_of_range": (TEXT + "\n[effects]\npolytropic_n = 1.6\n", ["polytropic_n", "1.6", "1..1.4"]),
    "backlash_negative": (
        TEXT + "\n[effects]\nreducer_backlash_rad = -1\n",
        ["[effects] reducer_backlash_rad", "-1", "0..0.2 rad"],
    ),
    "compliance_too_large": (
        TEXT + "\n[effects]\nreducer_compliance_rad_per_nm = 0.5\n",
        ["reducer_compliance_rad_per_nm", "0.5", "0..0.1"],
    ),
    "compliant_gear_without_rotor": (
        _set_line("rotor_inertia_kg_m2", "rotor_inertia_kg_m2 = 0.0")
        + "\n[effects]\nreducer_compliance_rad_per_nm = 1e-3\n",
        ["rotor_inertia_kg_m2 = 0", "reducer_compliance_rad_per_nm = 0.001", "rotor inertia > 0"],
    ),
    "not_toml": (TEXT.replace("ratio = 120", "ratio = = 120"), ["not valid TOML"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_file_is_refused_naming_path_field_value_and_allowed(case: str, tmp_path: Path) -> None:
    text, words = BAD[case]
    path = tmp_path / f"{case}.toml"
    path.write_text(text)
    with pytest.raises(ParameterError) as info:
        load_joint_params(path)
    message = str(info.value)
    assert str(path) in message
    for word in words:
        assert word in message, f"{word!r} not in {message!r}"


def test_missing_file_is_refused_with_its_path(tmp_path: Path) -> None:
    path = tmp_path / "nowhere.toml"
    with pytest.raises(ParameterError, match=re.escape(str(path))):
        load_joint_params(path)


def test_the_unedited_copy_loads(tmp_path: Path) -> None:
    # so that each refusal above is due to its one edit
    path = tmp_path / "copy.toml"
    path.write_text(TEXT)
    assert load_joint_params(path) == load_joint_params(REAL)


def test_reducer_fields_default_to_the_rigid_reducer_and_load_when_given(tmp_path: Path) -> None:
    assert load_joint_params(REAL).reducer_backlash_rad == 0.0  # the paper's eq. 6
    assert load_joint_params(REAL).reducer_compliance_rad_per_nm == 0.0
    path = tmp_path / "worn.toml"
    path.write_text(TEXT + "\n[effects]\nreducer_backlash_rad = 0.02\nreducer_compliance_rad_per_nm = 2e-4\n")
    p = load_joint_params(path)
    assert (p.reducer_backlash_rad, p.reducer_compliance_rad_per_nm) == (0.02, 2e-4)
