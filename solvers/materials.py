"""Linear isotropic elastic materials with Rayleigh damping (SPEC section 1).

Units: E in Pa, rho in kg/m^3, Rayleigh alpha in 1/s, Rayleigh beta in s.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

from tissuebench.core.errors import UserError
from tissuebench.meshes.benchmark import LARGEST, SMALLEST, WHY_RANGE

MAX_NAME = 64  # characters of a material name (it labels files, figures and tables)

# the range of E, rho and the load scale and the bound of alpha and beta: see meshes/benchmark.py
UNITS = {"E": "Pa", "rho": "kg/m^3", "alpha": "1/s", "beta": "s"}


class MaterialError(UserError):
    """A material that the SPEC does not allow, or a material file that cannot be read."""


@dataclass(frozen=True)
class Material:
    name: str
    E: float  # Young's modulus, Pa
    nu: float  # Poisson's ratio, -
    rho: float  # density, kg/m^3
    alpha: float = 0.0  # Rayleigh mass coefficient, 1/s
    beta: float = 0.0  # Rayleigh stiffness coefficient, s

    def __post_init__(self):
        if (
            not isinstance(self.name, str)
            or not 0 < len(self.name) <= MAX_NAME
            or not self.name.isprintable()
        ):
            shown = repr(self.name)[:40] + ("..." if len(repr(self.name)) > 40 else "")
            raise MaterialError(
                f"material name must be printable text of 1 to {MAX_NAME} characters, got {shown}"
            )
        for field in ("E", "nu", "rho", "alpha", "beta"):
            value = getattr(self, field)
            try:
                finite = (
                    not isinstance(value, bool)
                    and isinstance(value, (int, float))
                    and math.isfinite(value)
                )
            except OverflowError:  # an integer beyond the float range
                finite = False
            if not finite:
                shown = repr(value) if len(repr(value)) <= 40 else repr(value)[:40] + "..."
                raise MaterialError(
                    f"material {self.name}: {field} must be a finite number, got {shown}"
                )
            object.__setattr__(self, field, float(value))
        if self.E <= 0:
            raise MaterialError(f"material {self.name}: E must be > 0 Pa, got {self.E}")
        if not -1 < self.nu < 0.5:
            raise MaterialError(
                f"material {self.name}: nu must satisfy -1 < nu < 0.5, got {self.nu}"
            )
        if self.rho <= 0:
            raise MaterialError(f"material {self.name}: rho must be > 0 kg/m^3, got {self.rho}")
        if self.alpha < 0:
            raise MaterialError(f"material {self.name}: alpha must be >= 0 1/s, got {self.alpha}")
        if self.beta < 0:
            raise MaterialError(f"material {self.name}: beta must be >= 0 s, got {self.beta}")
        for field in ("E", "rho"):
            value = getattr(self, field)
            if not SMALLEST <= value <= LARGEST:
                raise MaterialError(
                    f"material {self.name}: {field} must be within {SMALLEST:g} to {LARGEST:g} "
                    f"{UNITS[field]} ({WHY_RANGE}), got {value:g}"
                )
        for field in ("alpha", "beta"):
            value = getattr(self, field)
            if value > LARGEST:
                raise MaterialError(
                    f"material {self.name}: {field} must be at most {LARGEST:g} {UNITS[field]} "
                    f"({WHY_RANGE}), got {value:g}"
                )

    @property
    def mu(self) -> float:
        """Shear modulus mu = E / (2(1 + nu)), Pa."""
        return self.E / (2 * (1 + self.nu))

    @property
    def lmbda(self) -> float:
        """Lame's first parameter lambda = E nu / ((1 + nu)(1 - 2 nu)), Pa."""
        return self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))

    def lame(self, plane: str = "strain") -> tuple[float, float]:
        """(mu, lambda) in Pa; in 2D plane stress lambda* = 2 mu lambda / (lambda + 2 mu)."""
        if plane == "strain":
            return self.mu, self.lmbda
        if plane == "stress":
            return self.mu, 2 * self.mu * self.lmbda / (self.lmbda + 2 * self.mu)
        raise MaterialError(f"plane must be 'strain' or 'stress', got {plane!r}")


MATERIALS = {
    "MP1": Material("MP1", E=200.0, nu=0.47, rho=2000.0, alpha=1.0, beta=0.1),
    "MP2": Material("MP2", E=60_000.0, nu=0.495, rho=1140.0, alpha=1.0, beta=0.1),
    "MP3": Material("MP3", E=7000.0, nu=0.2, rho=10_000.0, alpha=1.0, beta=0.1),
}

FIELDS = ("E", "nu", "rho", "alpha", "beta")
MAX_FILE = 64 * 1024  # bytes of a material file


def material_from_toml(path: str | Path) -> Material:
    """Read a user material from a TOML file with keys name (optional), E, nu, rho, alpha, beta.

    Example:
        name = "liver"
        E = 640.0      # Pa
        nu = 0.45
        rho = 1060.0   # kg/m^3
        alpha = 1.0    # 1/s
        beta = 0.1     # s
    """
    path = Path(path)
    if not path.is_file():
        raise MaterialError(f"material file {path} does not exist")
    if path.stat().st_size > MAX_FILE:
        raise MaterialError(
            f"material file {path} is {path.stat().st_size:,} bytes; a material takes at most "
            f"{MAX_FILE:,}"
        )
    try:
        data = tomllib.loads(path.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise MaterialError(f"material file {path} is not valid TOML: {err}") from None
    except RecursionError:
        raise MaterialError(f"material file {path} is nested too deeply to be a material") from None
    except OSError as err:
        raise MaterialError(
            f"material file {path} cannot be read ({err.strerror or err})"
        ) from None
    unknown = set(data) - set(FIELDS) - {"name"}
    if unknown:
        raise MaterialError(f"material file {path}: unknown key(s) {', '.join(sorted(unknown))}")
    missing = [f for f in ("E", "nu", "rho") if f not in data]
    if missing:
        raise MaterialError(f"material file {path}: missing {', '.join(missing)}")
    name = data.get("name", path.stem)
    if not isinstance(name, str):
        raise MaterialError(f"material file {path}: name must be text, got a {type(name).__name__}")
    return Material(name=name, **{f: data[f] for f in FIELDS if f in data})


def get_material(spec: "str | Path | Material") -> Material:
    """A Material from a name (MP1, MP2, MP3), a TOML file path, or a Material."""
    if isinstance(spec, Material):
        return spec
    spec = str(spec)
    if spec in MATERIALS:
        return MATERIALS[spec]
    if spec.endswith(".toml") or Path(spec).exists():
        return material_from_toml(spec)
    raise MaterialError(
        f"unknown material {spec!r}: use one of {', '.join(MATERIALS)} or a .toml file"
    )
