"""What a log stores about where it came from: the scenario text, the seed, the versions."""

from __future__ import annotations

from importlib import metadata

PACKAGES = ("pneumatic-arm-twin", "mujoco", "pin", "numpy", "scipy", "numba", "rerun-sdk", "mcap")


def package_versions() -> dict[str, str]:
    out = {}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def run_metadata(scenario) -> dict:
    """Metadata of a scenario run: its name, path, seed, overrides, file text and package versions."""
    return {
        "scenario_name": scenario.name,
        "scenario_path": str(scenario.path),
        "seed": int(scenario.seed),
        "overrides": dict(scenario.overrides),
        "scenario_text": scenario.text,
        "versions": package_versions(),
    }
