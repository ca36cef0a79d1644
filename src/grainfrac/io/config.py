"""Config plumbing shared by every user-facing schema.

Schemas are pydantic models in the field's units (MPa, GPa, mm). They are
strict (unknown keys are errors) and frozen. Validation failures become a
one-line :class:`~grainfrac.errors.ConfigError` that names the field and the
allowed range, raised before any compute.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError

from grainfrac.errors import ConfigError

M = TypeVar("M", bound=BaseModel)


class StrictModel(BaseModel):
    """Base of all config schemas: unknown keys rejected, instances immutable."""

    model_config = ConfigDict(extra="forbid", frozen=True)


# A model validator names the field it checks by starting its message "field: ...".
_NAMED = re.compile(r"^([A-Za-z_][\w.]*): (.*)$", re.S)


def _field_path(loc: tuple[Any, ...]) -> str:
    # pydantic puts the union member's type name into the location of errors in
    # a plain union (``rock.RockRecipe.minerals``); those tags are not fields.
    parts = [str(p) for i, p in enumerate(loc)
             if not (isinstance(p, str) and i < len(loc) - 1
                     and (p == "str" or re.fullmatch(r"[A-Z][A-Za-z0-9]*", p)))]
    return ".".join(parts) or "<root>"


def _describe(error: dict[str, Any]) -> str:
    ctx = error.get("ctx") or {}
    kind = error.get("type", "")
    bounds = {"greater_than": "> {gt}", "greater_than_equal": ">= {ge}",
              "less_than": "< {lt}", "less_than_equal": "<= {le}"}
    if kind in bounds:
        text = "must be " + bounds[kind].format(**ctx)
    else:
        text = str(error.get("msg", "invalid value"))
        if text.startswith("Value error, "):
            text = text[len("Value error, "):]
    if "input" in error and kind not in ("missing", "extra_forbidden"):
        value = error["input"]
        if not isinstance(value, dict | list):
            text += f" (got {value!r})"
    return text


def config_error_from(exc: ValidationError) -> ConfigError:
    """Turn a pydantic ValidationError into a one-line ConfigError.

    Of several errors (a union reports one per member) the deepest is the most
    specific: ``rock.minerals.0.youngs_modulus_GPa`` rather than ``rock``.
    """
    errors = exc.errors()
    first = max(errors, key=lambda e: len(e["loc"]))
    field, message = _field_path(first["loc"]), _describe(first)
    named = _NAMED.match(message)
    if named:
        prefix = "" if field == "<root>" else field + "."
        field, message = prefix + named.group(1), named.group(2)
    return ConfigError(field, message)


def validate(model: type[M], data: Any, *, prefix: str = "") -> M:
    """Validate ``data`` against ``model``; raise :class:`ConfigError` on failure."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        err = config_error_from(exc)
        if prefix:
            raise ConfigError(f"{prefix}.{err.field}", err.message) from None
        raise err from None


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file, turning syntax errors into :class:`ConfigError`."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError(str(path), "file not found")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(str(path), f"invalid TOML: {exc}") from None


def load_toml(model: type[M], path: str | Path) -> M:
    """Load and validate a TOML file into ``model``."""
    return validate(model, read_toml(path))


def source_path(source: str, base_dir: Path | None = None) -> Path | None:
    """The file a config's ``preset-or-file`` value names, or None for a preset name.

    A relative path is looked up beside the config file (``base_dir``) first.
    """
    candidate = Path(source)
    if base_dir is not None and not candidate.is_absolute() and (base_dir / candidate).is_file():
        candidate = base_dir / candidate
    if candidate.suffix == ".toml" or candidate.is_file():
        return candidate
    return None
