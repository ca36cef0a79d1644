"""Config plumbing shared by every user-facing schema.

Schemas are pydantic models in the field's units (MPa, GPa, mm). They are
strict (unknown keys are errors) and frozen. Validation failures become a
one-line :class:`~grainfrac.errors.ConfigError` that names the field and the
allowed range, raised before any compute.
"""

from __future__ import annotations

import difflib
import re
import tomllib
from pathlib import Path
from typing import Any, TypeVar, get_args

from pydantic import BaseModel, ConfigDict, ValidationError

from grainfrac.errors import ConfigError

M = TypeVar("M", bound=BaseModel)


class StrictModel(BaseModel):
    """Base of all config schemas: unknown keys rejected, instances immutable, numbers
    finite (``inf`` and ``nan`` are refused: a size or duration of ``inf`` hung a run)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


# A model validator names the field it checks by starting its message "field: ...".
_NAMED = re.compile(r"^([A-Za-z_][\w.]*): (.*)$", re.S)


_ABSENT = object()


def _child(node: Any, part: Any) -> Any:
    """``node[part]`` of an input (dicts, lists, models already validated), or _ABSENT."""
    if isinstance(node, dict):
        return node.get(part, _ABSENT)
    if isinstance(node, list | tuple) and isinstance(part, int):
        return node[part] if -len(node) <= part < len(node) else _ABSENT
    if isinstance(node, BaseModel) and isinstance(part, str) and part in type(node).model_fields:
        return getattr(node, part)
    return _ABSENT


def _is_tag(part: Any) -> bool:
    # Without the input: pydantic's tags of plain unions are type names.
    return isinstance(part, str) and (part == "str" or re.fullmatch(r"[A-Z][A-Za-z0-9]*", part)
                                      is not None)


def _field_parts(loc: tuple[Any, ...], data: Any) -> list[str]:
    """The parts of ``loc`` that are keys or indices of ``data``.

    pydantic puts a union member's tag into the location of its errors
    (``specimen.slab.width_mm``, ``rock.RockRecipe.minerals``, ``rock.str``);
    those are no keys of the input, so walking the input drops them. The last
    part is kept as it is (a missing field is not in the input either).
    """
    parts: list[str] = []
    node = data if data is not None else _ABSENT
    for i, part in enumerate(loc):
        last = i == len(loc) - 1
        child = _child(node, part) if node is not _ABSENT else _ABSENT
        if child is not _ABSENT:
            node = child
        elif (not last and (node is not _ABSENT or _is_tag(part))) or (last and _is_tag(part)):
            continue  # a union tag
        parts.append(str(part))
    return parts


def _union_member(loc: tuple[Any, ...], data: Any) -> tuple[tuple[str, ...], str] | None:
    """``(path to the union, member tag)`` of an error inside a union member, else None."""
    node = data if data is not None else _ABSENT
    for i, part in enumerate(loc):
        child = _child(node, part) if node is not _ABSENT else _ABSENT
        if child is not _ABSENT:
            node = child
        elif _is_tag(part) or (i < len(loc) - 1 and node is not _ABSENT):
            return tuple(str(p) for p in loc[:i]), str(part)
    return None


def _models_in(annotation: Any) -> list[type[BaseModel]]:
    """The pydantic models an annotation can hold (through unions, lists, Annotated)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    found: list[type[BaseModel]] = []
    for arg in get_args(annotation):
        found += _models_in(arg)
    return found


def _allowed_keys(model: type[BaseModel], loc: tuple[Any, ...]) -> list[str]:
    """The keys the models at ``loc[:-1]`` (raw pydantic location) allow."""
    models = [model]
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        inner = [m for m in models if part in m.model_fields]
        if inner:
            models = [x for m in inner for x in _models_in(m.model_fields[part].annotation)]
            continue
        # A union tag: the member named so (class name or discriminator value).
        tagged = [m for m in models if m.__name__ == part or any(
            get_args(f.annotation) == (part,) for f in m.model_fields.values())]
        models = tagged or models
    return sorted({key for m in models for key in m.model_fields})


def _describe(error: dict[str, Any], model: type[BaseModel] | None = None) -> str:
    ctx = error.get("ctx") or {}
    kind = error.get("type", "")
    bounds = {"greater_than": "> {gt}", "greater_than_equal": ">= {ge}",
              "less_than": "< {lt}", "less_than_equal": "<= {le}"}
    if kind in bounds:
        text = "must be " + bounds[kind].format(**ctx)
    elif kind == "extra_forbidden":
        key = str(error["loc"][-1])
        allowed = _allowed_keys(model, error["loc"]) if model is not None else []
        # A key cut short ("rate" for "rate_ml_per_min") is too short for difflib.
        close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6) or [
            a for a in allowed if len(key) >= 3 and a.startswith(key)][:1]
        text = f"unknown key {key!r}"
        if close:
            text += f"; did you mean {close[0]!r}?"
        if allowed:
            text += " (allowed: " + ", ".join(allowed) + ")"
        return text
    elif kind == "missing":
        return "required, missing"
    elif kind == "finite_number":
        text = "must be a finite number"
    else:
        text = str(error.get("msg", "invalid value"))
        if text.startswith("Value error, "):
            text = text[len("Value error, "):]
    if "input" in error and kind != "missing":
        value = error["input"]
        if not isinstance(value, dict | list):
            text += f" (got {value!r})"
    return text


def config_error_from(exc: ValidationError, data: Any = None,
                      model: type[BaseModel] | None = None) -> ConfigError:
    """Turn a pydantic ValidationError into a :class:`ConfigError` of every problem.

    Each problem names the field, says what is allowed and what was given. A
    union reports one error per member; of those, only the member with the
    deepest error counts (``rock.minerals.0.youngs_modulus_GPa`` rather than
    ``rock: should be a string``). ``data`` (the input) lets the union tags be
    told from field names; ``model`` lets an unknown key be matched with the
    allowed ones ("did you mean").
    """
    errors = exc.errors()
    best: dict[tuple[str, ...], tuple[int, str]] = {}
    for e in errors:
        member = _union_member(e["loc"], data)
        if member is not None:
            depth = len(e["loc"])
            if depth > best.get(member[0], (-1, ""))[0]:
                best[member[0]] = (depth, member[1])
    problems: list[tuple[str, str]] = []
    for e in errors:
        member = _union_member(e["loc"], data)
        if member is not None and best[member[0]][1] != member[1]:
            continue
        field = ".".join(_field_parts(e["loc"], data)) or "<root>"
        for line in _describe(e, model).split("\n"):
            named = _NAMED.match(line)
            f, message = field, line
            if named:
                f = named.group(1) if field == "<root>" else field + "." + named.group(1)
                message = named.group(2)
            if (f, message) not in problems:
                problems.append((f, message))
    return ConfigError(problems[0][0], problems[0][1], problems[1:])


def validate(model: type[M], data: Any, *, prefix: str = "") -> M:
    """Validate ``data`` against ``model``; raise :class:`ConfigError` on failure."""
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        err = config_error_from(exc, data, model)
        if prefix:
            problems = [(f"{prefix}.{f}", m) for f, m in err.problems]
            raise ConfigError(*problems[0], problems[1:]) from None
        raise err from None


def read_toml(path: str | Path) -> dict[str, Any]:
    """Read a TOML file; a missing, unreadable, non-UTF-8 or invalid file is a
    one-line :class:`ConfigError` naming it."""
    path = Path(path)
    if not path.exists():
        raise ConfigError(str(path), "file not found")
    if not path.is_file():
        raise ConfigError(str(path), "not a file")
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError(str(path), f"not UTF-8 text (byte {exc.object[exc.start]:#04x} at "
                                     f"offset {exc.start}); save the file as UTF-8") from None
    except OSError as exc:
        raise ConfigError(str(path), f"cannot be read ({exc.strerror})") from None
    try:
        return tomllib.loads(text)
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
