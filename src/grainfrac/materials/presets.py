"""Recipe loading: the presets shipped in ``grainfrac/presets/*.toml``, TOML files,
and the one-mineral homogeneous recipe of the verification cases.
"""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path
from typing import Any, Literal

from grainfrac.errors import ConfigError
from grainfrac.io.config import load_toml, validate
from grainfrac.materials.recipes import RockRecipe, ScdaRecipe

__all__ = [
    "homogeneous_recipe",
    "load_recipe",
    "load_scda",
    "preset_names",
]


def _preset_dir():
    return resources.files("grainfrac").joinpath("presets")


def _preset_data() -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {}
    directory = _preset_dir()
    if not directory.is_dir():
        return out
    for entry in directory.iterdir():
        if entry.name.endswith(".toml") and entry.is_file():
            stem = entry.name[: -len(".toml")]
            try:
                out[stem] = tomllib.loads(entry.read_text(encoding="utf-8"))
            except tomllib.TOMLDecodeError as exc:
                raise ConfigError(f"presets/{entry.name}", f"invalid TOML: {exc}") from None
    return out


def preset_names(kind: Literal["rock", "scda"] = "rock") -> list[str]:
    """Names of the packaged presets, sorted.

    Parameters
    ----------
    kind : {"rock", "scda"}
        ``"rock"`` (default) lists :class:`RockRecipe` presets (for
        :func:`load_recipe`), ``"scda"`` lists :class:`ScdaRecipe` presets (for
        :func:`load_scda`).

    Returns
    -------
    list of str
    """
    key = "minerals" if kind == "rock" else "contact"
    return sorted(name for name, data in _preset_data().items() if key in data)


def _load(model: type, source: str | Path, kind: Literal["rock", "scda"], field: str):
    if isinstance(source, str):
        presets = preset_names(kind)
        if source in presets:
            return validate(model, _preset_data()[source], prefix=f"presets/{source}.toml")
        looks_like_path = source.endswith(".toml") or "/" in source or "\\" in source
        if not looks_like_path and not Path(source).is_file():
            raise ConfigError(field, f"unknown preset {source!r}; presets: {', '.join(presets)} "
                              "(or give the path of a .toml file)")
    return load_toml(model, Path(source))


def load_recipe(source: str | Path) -> RockRecipe:
    """Load a rock recipe from a preset name or a TOML file.

    Parameters
    ----------
    source : str or Path
        A preset name (see :func:`preset_names`, e.g. ``"strathbogie-granite"``)
        or the path of a TOML file with the :class:`RockRecipe` schema.

    Returns
    -------
    RockRecipe

    Raises
    ------
    ConfigError
        Unknown preset (the message lists the presets), missing file, invalid
        TOML or a value out of range (the field is named).
    """
    return _load(RockRecipe, source, "rock", "recipe")


def load_scda(source: str | Path = "scda") -> ScdaRecipe:
    """Load the SCDA material from a preset name (default ``"scda"``) or a TOML file.

    Parameters
    ----------
    source : str or Path
        Preset name (see ``preset_names("scda")``) or path of a TOML file with
        the :class:`ScdaRecipe` schema.

    Returns
    -------
    ScdaRecipe

    Raises
    ------
    ConfigError
        As :func:`load_recipe`.
    """
    return _load(ScdaRecipe, source, "scda", "scda")


def homogeneous_recipe(
    mineral: str = "quartz",
    stiffness_factor: float = 100.0,
    unbreakable: bool = True,
    base: str = "strathbogie-granite",
) -> RockRecipe:
    """A one-mineral rock without scatter, for verification against continuum solutions.

    Parameters
    ----------
    mineral
        Mineral of every grain (its Table 2 properties are used).
    stiffness_factor
        Multiplier on the like-pair contact stiffnesses, so the contacts add
        negligible compliance to the grains.
    unbreakable
        Give the contacts strengths far above any stress a test applies.
    base
        Preset the mineral and contact properties are taken from.
    """
    source = load_recipe(base)
    chosen = source.minerals[source.mineral_index(mineral)]
    code = chosen.code
    contact = source.contact(f"{code}-{code}")
    strength = 1.0e9 if unbreakable else None  # MPa
    props = contact.model_dump()
    props["normal_stiffness_GPa_per_m"] *= stiffness_factor
    props["shear_stiffness_GPa_per_m"] *= stiffness_factor
    if strength is not None:
        props["cohesion_MPa"] = strength
        props["tensile_strength_MPa"] = strength
    return RockRecipe.model_validate({
        "name": f"homogeneous-{mineral}",
        "minerals": [{**chosen.model_dump(), "volume_percent": 100.0}],
        "contacts": {f"{code}-{code}": props},
        "weibull": {"enabled": False},
    })
