"""The diagnosis's kinds, one row each: its verdicts (and what each one counts as) and the effects'
families (the parts of the joint, or of the arm, a user would inspect). Both are `StrEnum`s: a
member is its text, so diagnosis.json, bench.json and the reports read as they did when these
were plain strings, and a verdict read back from JSON is `Verdict(text)`. A new verdict or family
is one row here.
"""

from __future__ import annotations

from enum import StrEnum


class Verdict(StrEnum):
    """What the diagnosis says of a campaign (rules: gap.verdict.Judge.call; the whole arm's:
    gap.arm_diagnose). Per row: its text, then
    - `alarm`: a gap was found (counted as a false alarm on a campaign with nothing hidden);
    - `explained`: catalogue candidates explain it (a top candidate the bench scores);
    - `tied`: several do, and the withheld runs do not tell them apart (its rivals are named);
    - `names_family`: the answer is also a family (the family call: gap.verdict.Judge.family_call),
      among every family where no candidate explains, among the candidates' where they are tied."""

    alarm: bool
    explained: bool
    tied: bool
    names_family: bool

    def __new__(cls, text: str, alarm: bool, explained: bool, tied: bool, names_family: bool):
        member = str.__new__(cls, text)
        member._value_ = text
        member.alarm, member.explained, member.tied, member.names_family = alarm, explained, tied, names_family
        return member

    #                text                     alarm  explained tied   names_family
    NO_GAP = "no significant gap", False, False, False, False
    EXPLAINED = "explained", True, True, False, False
    AMBIGUOUS = "ambiguous", True, True, True, True
    OUTSIDE = "outside the catalogue", True, False, False, True


class Family(StrEnum):
    """The part of the joint (or of the whole arm) an effect is in: what the family call names
    where no catalogue form fits (gap.effects explains why the valves are one part)."""

    # the one joint's (gap.effects.CATALOGUE)
    HOSE = "hose"  # the hoses between the valve and the motor's ports
    LEAKAGE = "leakage"  # air lost past the vanes or out of the lines
    FRICTION = "friction"  # the motor's and the joint's friction
    VALVE = "valve"  # the direction valve and the proportional valve, on the operator's platform
    THERMAL = "thermal"  # the chambers' heat exchange
    SUPPLY = "supply"  # the supply pressure as it reaches the valve (the whole arm's shared line too)
    LOAD = "load"  # the rig's inertia and static loads on the joint
    BRAKE = "brake"  # the spring-applied brake's release and engagement
    REDUCER = "reducer"  # the gear between motor and joint
    # the whole arm's (gap.arm_effects.ARM_CATALOGUE)
    PAYLOAD = "payload"  # the tool's payload: its mass and centre of mass
    LINKS = "links"  # the links' masses
    MOUNTING = "mounting"  # how the arm's base is mounted (tilt)
