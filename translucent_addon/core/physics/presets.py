"""Measured material coefficients (Jensen et al. 2001, Fig. 5), in mm^-1.

The CSV ships inside the extension (``translucent_addon/data``) so a user's
machine needs nothing else. Coefficients are RGB; ``eta`` is the relative index
of refraction.
"""
from __future__ import annotations

import csv
import dataclasses
import functools
import math
from pathlib import Path

from ..data import DATA

PRESETS_CSV = DATA / "materials_jensen2001.csv"


@dataclasses.dataclass(frozen=True)
class Material:
    """Optical coefficients of a homogeneous medium, in mm^-1."""

    name: str
    sigma_a: tuple[float, float, float]
    sigma_s_prime: tuple[float, float, float]
    eta: float
    g: float = 0.0

    @property
    def sigma_t_prime(self) -> tuple[float, float, float]:
        """Reduced extinction sigma_t' = sigma_a + sigma_s' (Jensen 2001)."""
        return tuple(a + s for a, s in zip(self.sigma_a, self.sigma_s_prime))

    @property
    def sigma_s(self) -> tuple[float, float, float]:
        """Scattering coefficient sigma_s = sigma_s' / (1 - g)."""
        return tuple(s / (1.0 - self.g) for s in self.sigma_s_prime)


class CoefficientError(ValueError):
    """Coefficients that no physical medium has (negative, zero or not finite)."""


def validate_coefficients(sigma_a: tuple[float, float, float], sigma_s_prime: tuple[float, float, float],
                          eta: float, g: float = 0.0, name: str = "material") -> None:
    """Raise CoefficientError with a one-line reason if the medium is not physical.

    sigma_a may be 0 (no absorption, e.g. spectralon); sigma_s' must be > 0, since
    a non-scattering medium has no diffusion; eta >= 1 (the profiles, the Fresnel terms and the twin
    assume a medium denser than air; a file can hold less than the setting's minimum); -1 < g < 1.
    """
    for label, values, allow_zero in (("sigma_a", sigma_a, True), ("sigma_s_prime", sigma_s_prime, False)):
        for channel, v in zip("RGB", values):
            if not math.isfinite(v):
                raise CoefficientError(f"{name}: {label}.{channel} is {v}, not a finite number")
            if v < 0 or (v == 0 and not allow_zero):
                need = ">= 0" if allow_zero else "> 0"
                raise CoefficientError(f"{name}: {label}.{channel} = {v} mm^-1, must be {need}")
    if not (math.isfinite(eta) and eta >= 1.0):
        raise CoefficientError(f"{name}: eta = {eta}, must be an index of refraction of at least 1 "
                               f"(a medium denser than the air around it)")
    if not (-1.0 < g < 1.0):
        raise CoefficientError(f"{name}: g = {g}, must lie in (-1, 1)")


@functools.lru_cache(maxsize=1)
def load_presets(path: Path = PRESETS_CSV) -> dict[str, Material]:
    """Read the preset table; lines starting with '#' are comments."""
    with open(path, newline="") as f:
        rows = [line for line in f if not line.startswith("#")]
    presets = {}
    for row in csv.DictReader(rows):
        name = row["name"].strip()
        mat = Material(
            name=name,
            sigma_a=tuple(float(row[f"sigma_a_{c}"]) for c in "rgb"),
            sigma_s_prime=tuple(float(row[f"sigma_s_prime_{c}"]) for c in "rgb"),
            eta=float(row["eta"]),
        )
        validate_coefficients(mat.sigma_a, mat.sigma_s_prime, mat.eta, name=name)
        presets[name] = mat
    return presets


# -- user presets: the artist's own materials, in a JSON file of Blender's user configuration --------
USER_PREFIX = "USER:"


def load_user_presets(path: Path | str, problems: list[str] | None = None) -> dict[str, Material]:
    """User presets from a JSON file ({name: {sigma_a, sigma_s_prime, eta, g}}); none when it is absent.
    Read entry by entry: one that is not a physical medium is skipped, and a file that is not such an object
    at all gives none, each with a line in ``problems`` (a hand-edited file must not break the list, whose
    built-in presets come first)."""
    path = Path(path)
    if not path.is_file():
        return {}
    try:
        data = _read_user_file(path)
    except PresetFileError as err:
        if problems is not None:
            problems.append(str(err))
        return {}
    out = {}
    for name, entry in data.items():
        try:
            mat = Material(str(name), tuple(float(x) for x in entry["sigma_a"]),
                           tuple(float(x) for x in entry["sigma_s_prime"]), float(entry["eta"]),
                           float(entry.get("g", 0.0)))
            if len(mat.sigma_a) != 3 or len(mat.sigma_s_prime) != 3:
                raise ValueError("sigma_a and sigma_s_prime need three values (R, G, B)")
            validate_coefficients(mat.sigma_a, mat.sigma_s_prime, mat.eta, mat.g, name=mat.name)
        except (KeyError, TypeError, ValueError, AttributeError) as err:
            if problems is not None:
                why = f"no {err}" if isinstance(err, KeyError) else str(err)
                problems.append(f"user preset '{name}' in {path} skipped: {why}")
            continue
        out[mat.name] = mat
    return out


class PresetFileError(ValueError):
    """The user presets file cannot be read as presets (not JSON, not an object of entries)."""


def _read_user_file(path: Path) -> dict:
    import json

    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as err:
        raise PresetFileError(f"user presets file {path} cannot be read ({err}): fix or remove it") from None
    if not isinstance(data, dict):
        raise PresetFileError(f"user presets file {path} is not a set of named presets: fix or remove it")
    return data


def save_user_preset(path: Path | str, mat: Material) -> None:
    """Add or replace one user preset (validated first: CoefficientError says why not)."""
    import json

    if not mat.name.strip():
        raise CoefficientError("a preset needs a name")
    validate_coefficients(mat.sigma_a, mat.sigma_s_prime, mat.eta, mat.g, name=mat.name)
    path = Path(path)
    data = _read_user_file(path) if path.is_file() else {}  # a damaged file is refused, not overwritten
    data[mat.name] = {"sigma_a": list(mat.sigma_a), "sigma_s_prime": list(mat.sigma_s_prime), "eta": mat.eta,
                      "g": mat.g}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2, sort_keys=True))


def remove_user_preset(path: Path | str, name: str) -> bool:
    import json

    path = Path(path)
    data = _read_user_file(path) if path.is_file() else {}
    if name not in data:
        return False
    del data[name]
    path.write_text(json.dumps(data, indent=2, sort_keys=True))
    return True
