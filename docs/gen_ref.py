"""Generate the reference and validation pages of the documentation from the code.

``mkdocs build`` runs this file through the mkdocs-gen-files plugin (see
``mkdocs.yml``). Nothing it writes is kept in the repository: every page below
is rebuilt from the installed ``grainfrac`` package on every build, so a field,
command or module added to the code appears in the docs without anyone typing it.

Pages written:

``reference/configuration.md``
    every field of every pydantic schema of the package (found by walking the
    package, not from a list), with type, unit, default, allowed range and
    description;
``reference/cli.md``
    every command and option of the ``grainfrac`` command (typer/click
    introspection of the console script named in the package metadata);
``reference/api/**``
    one mkdocstrings page per module, the module list discovered from the
    package directory at build time;
``validation/*.md``
    tables and figures appended to the hand-written validation pages from the
    JSON under ``docs/data/`` (written by ``docs/scripts/update_validation.py``);
``changelog.md``
    a copy of ``CHANGELOG.md``.

The functions are importable (``tests/test_docs.py`` uses them); only
:func:`main` touches mkdocs-gen-files.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import importlib.util
import inspect
import io
import json
import math
import types
import typing
from collections.abc import Iterator
from pathlib import Path
from typing import Any

PACKAGE = "grainfrac"
DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
DATA = DOCS / "data"

# --------------------------------------------------------------------------- discovery


def package_dir() -> Path:
    """Directory of the installed package (no import of its modules)."""
    spec = importlib.util.find_spec(PACKAGE)
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError(f"{PACKAGE} is not importable: pip install -e . first")
    return Path(next(iter(spec.submodule_search_locations)))


def package_modules() -> list[str]:
    """Dotted names of every public module and package under ``grainfrac``, sorted.

    Found by walking the package directory, so moving or adding a module needs no
    change here. Private modules (a path part starting with ``_`` other than
    ``__init__``) and ``__main__`` are left out.
    """
    base = package_dir()
    names = []
    for path in sorted(base.rglob("*.py")):
        rel = path.relative_to(base).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        if any(p.startswith("_") for p in parts):
            continue
        if any(not p.isidentifier() for p in parts):
            continue
        names.append(".".join([PACKAGE, *parts]))
    return sorted(set(names))


def import_all() -> list[types.ModuleType]:
    """Import every module of the package (for the schema walk)."""
    return [importlib.import_module(name) for name in package_modules()]


def schema_models() -> list[type]:
    """Every pydantic model defined in the package that has fields, in a stable order."""
    from pydantic import BaseModel

    found: dict[str, type] = {}
    for module in import_all():
        for _, obj in inspect.getmembers(module, inspect.isclass):
            if (issubclass(obj, BaseModel) and obj.__module__.startswith(PACKAGE + ".")
                    and obj.model_fields):
                found[f"{obj.__module__}.{obj.__qualname__}"] = obj
    return [found[k] for k in sorted(found)]


# --------------------------------------------------------------------------- configuration


# File kinds users write, in the order of the page; any other model that nothing
# else uses becomes a section of its own after these.
FILE_SCHEMAS = {
    "Scenario": "Scenario file: `grainfrac run SCENARIO.toml`",
    "SpecimenConfig": "Specimen file: `grainfrac specimen SPEC.toml`",
    "RockRecipe": "Rock recipe: a preset name, a TOML file or an inline `[rock]` table",
    "ScdaRecipe": "SCDA material: a preset name, a TOML file or an inline table",
    "LabTestConfig": "Lab test: `grainfrac labtest` and `grainfrac.run_labtest`",
    "CalibrationConfig": "Calibration targets file: `grainfrac calibrate TARGETS.toml`",
    "SweepConfig": "Sweep file: `grainfrac sweep SWEEP.toml`",
}

# Units spelled in field names (longest suffix first).
UNIT_SUFFIXES = (
    ("_MPa_sqrt_m", "MPa m<sup>1/2</sup>"),
    ("_GPa_per_m", "GPa/m"),
    ("_J_per_m2", "J/m<sup>2</sup>"),
    ("_ml_per_min", "ml/min"),
    ("_mm_per_s", "mm/s"),
    ("_kg_m3", "kg/m<sup>3</sup>"),
    ("_Pa_s", "Pa s"),
    ("_per_GPa", "1/GPa"),
    ("_per_s", "1/s"),
    ("_minutes", "min"),
    ("_percent", "%"),
    ("_MPa", "MPa"),
    ("_GPa", "GPa"),
    ("_deg", "degree"),
    ("_mm", "mm"),
    ("_ms", "ms"),
    ("_ml", "ml"),
    ("_m2", "m<sup>2</sup>"),
    ("_m", "m"),
    ("_s", "s"),
    ("_J", "J"),
)
DIMENSIONLESS_WORDS = ("ratio", "fraction", "factor", "tolerance", "poisson")


def field_unit(name: str, description: str | None) -> str:
    """The unit of a field: from its name's suffix, else a trailing ``[unit]`` in its
    description, else ``-`` for ratios and factors, else an empty string."""
    for suffix, unit in UNIT_SUFFIXES:
        if name.endswith(suffix):
            return unit
    text = (description or "").strip()
    if text.endswith("]") and "[" in text:
        unit = text[text.rindex("[") + 1:-1].strip()
        return "-" if unit in ("-", "") else unit
    if any(word in DIMENSIONLESS_WORDS for word in name.split("_")):
        return "-"
    return ""


def _anchor(model: type) -> str:
    return model.__name__.lower()


def _is_model(tp: Any) -> bool:
    from pydantic import BaseModel

    return inspect.isclass(tp) and issubclass(tp, BaseModel)


def type_text(tp: Any, link: bool = True) -> str:
    """A user's (TOML) name for a type annotation, linking nested schemas."""
    origin = typing.get_origin(tp)
    args = typing.get_args(tp)
    if tp is type(None):
        return "none"
    if tp is Any:
        return "any"
    if origin is typing.Annotated:
        return type_text(args[0], link)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(dict.fromkeys(type_text(a, link) for a in args))
    if origin is typing.Literal:
        return " or ".join(f'`"{a}"`' if isinstance(a, str) else f"`{a}`" for a in args)
    if origin in (list, tuple, set, frozenset):
        inner = type_text(args[0], link) if args else "any"
        return f"list of {inner}"
    if origin is dict:
        key, value = (type_text(a, link) for a in args) if args else ("any", "any")
        return f"table of {key} to {value}"
    if _is_model(tp):
        return f"[{tp.__name__}](#{_anchor(tp)})" if link else tp.__name__
    return {float: "number", int: "integer", str: "string", bool: "boolean",
            Path: "path"}.get(tp, getattr(tp, "__name__", str(tp)))


def nested_models(tp: Any) -> list[type]:
    """Pydantic models named anywhere inside a type annotation."""
    if _is_model(tp):
        return [tp]
    out: list[type] = []
    for arg in typing.get_args(tp):
        out += nested_models(arg)
    return out


def _number(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def allowed_text(field: Any) -> str:
    """The range the schema enforces on a field (constraints in its metadata)."""
    import annotated_types as at

    lower = upper = ""
    parts = []
    for item in field.metadata:
        if isinstance(item, at.Gt):
            lower = f"> {_number(item.gt)}"
        elif isinstance(item, at.Ge):
            lower = f">= {_number(item.ge)}"
        elif isinstance(item, at.Lt):
            upper = f"< {_number(item.lt)}"
        elif isinstance(item, at.Le):
            upper = f"<= {_number(item.le)}"
        elif isinstance(item, at.MinLen):
            parts.append(f"at least {item.min_length} item{'s' * (item.min_length != 1)}")
        elif isinstance(item, at.MaxLen):
            parts.append(f"at most {item.max_length} items")
    if lower and upper:
        parts.insert(0, f"{lower} and {upper}")
    elif lower or upper:
        parts.insert(0, lower or upper)
    literal = _literal_values(field.annotation)
    if literal:
        parts.append("one of " + ", ".join(f"`{v}`" for v in literal))
    return "; ".join(parts)


def _literal_values(tp: Any) -> list[Any]:
    if typing.get_origin(tp) is typing.Literal:
        return list(typing.get_args(tp))
    if typing.get_origin(tp) in (typing.Union, types.UnionType):
        out: list[Any] = []
        for arg in typing.get_args(tp):
            if typing.get_origin(arg) is typing.Literal:
                out += list(typing.get_args(arg))
        return out
    return []


def default_text(field: Any) -> str:
    """The default of a field as a user writes it; ``required`` when there is none."""
    from pydantic import BaseModel
    from pydantic_core import PydanticUndefined

    if field.default_factory is not None:
        try:
            value = field.default_factory()
        except TypeError:  # a factory that takes the validated data
            return "computed"
    elif field.default is PydanticUndefined:
        return "**required**"
    else:
        value = field.default
    if isinstance(value, BaseModel):
        cls = type(value)
        plain = _plain(cls)
        changed = {k: getattr(value, k) for k in cls.model_fields
                   if (k in value.model_fields_set if plain is None
                       else getattr(value, k) != getattr(plain, k))}
        if not changed:
            return f"[{cls.__name__}](#{_anchor(cls)}) defaults"
        inner = ", ".join(f"{k} = {_toml(v)}" for k, v in changed.items())
        return f"[{cls.__name__}](#{_anchor(cls)}) with `{inner}`"
    if value is None:
        return "none"
    return f"`{_toml(value)}`"


def _plain(cls: type) -> Any:
    try:
        return cls()
    except Exception:  # a model with required fields: nothing to compare with
        return None


def _toml(value: Any) -> str:
    from pydantic import BaseModel

    if isinstance(value, BaseModel):
        return type(value).__name__
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}" if math.isfinite(value) else str(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + "}"
    return str(value)


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _summary(model: type) -> str:
    doc = inspect.getdoc(model) or ""
    return doc.split("\n\n")[0].replace("\n", " ").strip()


def _uses(models: list[type]) -> dict[type, list[str]]:
    """For every model, the ``Model.field`` places that contain it."""
    uses: dict[type, list[str]] = {m: [] for m in models}
    for model in models:
        for name, field in model.model_fields.items():
            for inner in nested_models(field.annotation):
                if inner in uses and inner is not model:
                    uses[inner].append(f"{model.__name__}.{name}")
    return uses


def model_section(model: type, level: int, uses: list[str]) -> str:
    """One schema: heading (anchored by class name), summary, where used, field table."""
    out = [f"{'#' * level} {model.__name__} {{ #{_anchor(model)} }}", ""]
    summary = _summary(model)
    if summary:
        out += [summary, ""]
    if uses:
        out += ["Used as " + ", ".join(f"`{u}`" for u in sorted(set(uses))) + ".", ""]
    out += ["| field | type | unit | default | allowed | description |",
            "|---|---|---|---|---|---|"]
    for name, field in model.model_fields.items():
        desc = field.description or ""
        out.append("| " + " | ".join(_cell(x) for x in (
            f"`{name}`", type_text(field.annotation), field_unit(name, desc),
            default_text(field), allowed_text(field), desc)) + " |")
    return "\n".join(out) + "\n"


def configuration_page(models: list[type] | None = None) -> str:
    """The field reference: every schema, grouped by the file that holds it."""
    models = schema_models() if models is None else models
    by_name = {m.__name__: m for m in models}
    uses = _uses(models)
    roots = [by_name[n] for n in FILE_SCHEMAS if n in by_name]
    roots += [m for m in models if not uses[m] and m not in roots]
    done: set[type] = set()
    lines = [
        "# Configuration reference",
        "",
        "Every field of every input file, generated from the pydantic schemas of the "
        "installed package at build time (`docs/gen_ref.py`). Units are those of the "
        "field's name (`_MPa`, `_mm`, `_ml_per_min`, ...); inside the code everything is SI. "
        "In-situ stresses are compressive magnitudes. *allowed* is what validation "
        "enforces field by field; checks across fields (for example `min_edge_mm < "
        "max_edge_mm`) are stated in the description or in the error message, which names "
        "the field and the allowed range before any compute:",
        "",
        "```text",
        "config error at grains: min_edge_mm must be < max_edge_mm (8), got 9",
        "```",
        "",
        "Unknown keys are errors. A `config.toml` in a run directory has every default "
        "filled in and loads back to the same scenario.",
        "",
    ]
    for root in roots:
        if root in done:
            continue
        title = FILE_SCHEMAS.get(root.__name__, f"{root.__name__} (`{root.__module__}`)")
        lines += [f"## {title}", ""]
        queue = [root]
        first = True
        while queue:
            model = queue.pop(0)
            if model in done:
                continue
            done.add(model)
            lines.append(model_section(model, 3, [] if first else uses[model]))
            first = False
            for field in model.model_fields.values():
                for inner in nested_models(field.annotation):
                    if inner not in done and inner not in roots:
                        queue.append(inner)
    return "\n".join(lines)


# --------------------------------------------------------------------------- CLI


def cli_command() -> Any:
    """The click command behind the ``grainfrac`` console script (package metadata)."""
    import typer

    (entry,) = [e for e in importlib.metadata.entry_points(group="console_scripts")
                if e.name == PACKAGE]
    app = entry.load()
    return typer.main.get_command(app) if isinstance(app, typer.Typer) else app


def _param_type(param: Any) -> str:
    descriptor = getattr(param, "type_descriptor", None)
    if descriptor is not None and getattr(descriptor, "annotation", None) is not None:
        return type_text(descriptor.annotation, link=False)
    ptype = getattr(param, "type", None)
    choices = getattr(ptype, "choices", None)
    if choices:
        return " or ".join(f"`{c}`" for c in choices)
    return getattr(ptype, "name", "") or ""


def _param_rows(command: Any) -> list[str]:
    """One table row per argument and option (duck-typed: click or typer's own click)."""
    rows = []
    for param in command.params:
        if param.name == "help":
            continue
        if param.param_type_name == "argument":
            name = f"`{param.name.upper()}`"
            kind = "argument"
        else:
            opts = [*param.opts, *getattr(param, "secondary_opts", [])]
            name = ", ".join(f"`{o}`" for o in opts)
            kind = "flag" if getattr(param, "is_flag", False) else "option"
        kind += ", required" if param.required else ""
        default = param.default
        if getattr(param, "is_flag", False):
            default_text = "on" if default else "off"
        elif default is None or callable(default) or default in ((), []):
            default_text = ""
        else:
            default_text = f"`{default}`"
        help_text = getattr(param, "help", None) or ""
        if getattr(param, "multiple", False) or getattr(param, "nargs", 1) == -1:
            help_text += " (may be repeated)" if kind.startswith("option") else ""
        rows.append("| " + " | ".join(_cell(x) for x in (
            name, kind, _param_type(param), default_text, help_text)) + " |")
    return rows


def _usage(command: Any, path: str) -> str:
    pieces = [path]
    if any(p.param_type_name == "option" and p.name != "help" for p in command.params):
        pieces.append("[OPTIONS]")
    for p in command.params:
        if p.param_type_name != "argument":
            continue
        word = p.name.upper() + ("..." if getattr(p, "nargs", 1) == -1 else "")
        pieces.append(word if p.required else f"[{word}]")
    return " ".join(pieces)


def cli_page() -> str:
    """The CLI reference: every command with its usage, help and parameters."""
    root = cli_command()
    lines = ["# Command-line reference", "",
             "Generated from the `grainfrac` command itself (typer/click introspection) at "
             "build time. `grainfrac COMMAND --help` prints the same in a terminal. "
             "Errors in input files stop a command with exit code 2 and one line naming the "
             "field; `grainfrac verify` exits 1 when a compared quantity is out of tolerance.",
             ""]
    if root.help:
        lines += [inspect.cleandoc(root.help), ""]

    def walk(command: Any, path: str) -> Iterator[tuple[str, Any]]:
        if getattr(command, "commands", None):
            for name, sub in command.commands.items():
                if not getattr(sub, "hidden", False):
                    yield from walk(sub, f"{path} {name}")
        else:
            yield path, command

    for path, command in walk(root, PACKAGE):
        lines += [f"## `{path}`", ""]
        if command.help:
            lines += [inspect.cleandoc(command.help).replace("\b\n", ""), ""]
        lines += ["```text", _usage(command, path), "```", ""]
        rows = _param_rows(command)
        if rows:
            lines += ["| parameter | kind | type | default | help |", "|---|---|---|---|---|",
                      *rows, ""]
    return "\n".join(lines)


# --------------------------------------------------------------------------- API


def api_pages() -> dict[str, str]:
    """``reference/api/<module path>.md`` -> mkdocstrings page, plus the nav SUMMARY.md."""
    pages: dict[str, str] = {}
    nav: list[str] = []
    for name in package_modules():
        parts = name.split(".")
        doc_path = "/".join(parts[1:]) or "index"
        if (package_dir() / Path(*parts[1:]) / "__init__.py").is_file() and len(parts) > 1:
            doc_path += "/index"
        page = f"{doc_path}.md"
        pages[page] = f"# `{name}`\n\n::: {name}\n"
        indent = "    " * (len(parts) - 1)
        label = parts[-1] if len(parts) > 1 else name
        nav.append(f"{indent}* [{label}]({page})")
    pages["SUMMARY.md"] = "\n".join(nav) + "\n"
    return pages


# --------------------------------------------------------------------------- validation


def load_json(name: str) -> Any | None:
    path = DATA / name
    return json.loads(path.read_text()) if path.is_file() else None


def _fmt(value: Any, digits: int = 4) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "**no**"
    if isinstance(value, float):
        if value == 0:
            return "0"
        if abs(value) < 1e-3 or abs(value) >= 1e5:
            return f"{value:.{digits - 1}e}"
        return f"{value:.{digits}g}"
    return str(value)


def verification_tables(data: dict[str, Any]) -> str:
    """Markdown tables of ``grainfrac verify --json`` rows, one per case."""
    lines = [f"Generated from `docs/data/verification.json` ({data.get('generated', '')}, "
             f"grainfrac {data.get('grainfrac_version', '?')}, command `{data['command']}`).",
             ""]
    for case in data["cases"]:
        rows = case["rows"]
        passed = sum(r["passed"] for r in rows)
        command = " ".join(["grainfrac verify", case["case"], *case.get("options", [])])
        about = [f"{case['wall_time_s'] / 60:.1f} min"] if case.get("wall_time_s") else []
        about += [f"run on {case['run_on']}"] if case.get("run_on") else []
        took = f" ({', '.join(about)})" if about else ""
        lines += [f"### `{command}`", "",
                  f"{passed} of {len(rows)} quantities within tolerance{took}.", "",
                  "| quantity | simulated | analytical | relative error | tolerance | passed |",
                  "|---|---|---|---|---|---|"]
        for r in rows:
            lines.append("| " + " | ".join(_cell(x) for x in (
                f"`{r['quantity']}`", _fmt(r["simulated"]), _fmt(r["analytical"]),
                _fmt(r["relative_error"], 2), _fmt(r["tolerance"], 2), _fmt(r["passed"]))) + " |")
        lines.append("")
    return "\n".join(lines)


def verification_figure(data: dict[str, Any]) -> bytes:
    """Relative error over tolerance of every verified quantity (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels, ratios, colours = [], [], []
    for case in data["cases"]:
        for r in case["rows"]:
            err, tol = r["relative_error"], r["tolerance"]
            name = " ".join([case["case"], *case.get("options", [])])
            labels.append(f"{name}: {r['quantity']}")
            ratios.append(math.nan if err is None or not tol else err / tol)
            colours.append("tab:green" if r["passed"] else "tab:red")
    fig, ax = plt.subplots(figsize=(8, 0.28 * len(labels) + 1.2))
    y = range(len(labels))
    ax.barh(list(y), [0 if math.isnan(v) else v for v in ratios], color=colours)
    ax.axvline(1.0, color="k", lw=1, ls="--")
    ax.set_yticks(list(y), labels, fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("relative error / tolerance (passes below 1)")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    return buf.getvalue()


def claims_tables(data: dict[str, Any]) -> str:
    """Markdown table of claim verdicts (from the slow claim tests or a study)."""
    lines = [f"Generated from `docs/data/{data['file']}` ({data.get('generated', '')}, "
             f"grainfrac {data.get('grainfrac_version', '?')}, command `{data['command']}`).",
             ""]
    if data.get("note"):
        lines += [data["note"], ""]
    # A study's rows name their study (a 3D study's name ends in -3d).
    studies = any("study" in c for c in data["claims"])
    lines += [("| study " if studies else "")
              + "| claim | paper | grainfrac (mean [95 % CI] or count) | runs | verdict |",
              ("|---" if studies else "") + "|---|---|---|---|---|"]
    for c in data["claims"]:
        n = sum(len(v) for v in c.get("values", {}).values())
        cells = ([c.get("study", "")] if studies else []) + [
            c["statement"], c.get("paper", ""), c["estimate"], n or "-", f"**{c['verdict']}**"]
        lines.append("| " + " | ".join(_cell(x) for x in cells) + " |")
    lines.append("")
    return "\n".join(lines)


def claims_figure(data: dict[str, Any]) -> bytes | None:
    """Every run's value of every claim's quantity, per point (PNG)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    claims = [c for c in data["claims"] if c.get("values")]
    if not claims:
        return None
    cols = 3
    rows = math.ceil(len(claims) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3.1 * rows), squeeze=False)
    for ax, c in zip(axes.flat, claims, strict=False):
        for i, values in enumerate(c["values"].values()):
            vals = [v for v in values if v is not None and math.isfinite(v)]
            ax.plot([i] * len(vals), vals, "o", alpha=0.6, ms=4)
            if vals:
                ax.plot([i - 0.25, i + 0.25], [sum(vals) / len(vals)] * 2, "k-")
        ax.set_xticks(range(len(c["values"])), list(c["values"]), fontsize=7, rotation=20)
        ax.set_title(c["id"], fontsize=8)
        ax.set_ylabel(c["quantity"], fontsize=7)
        if c.get("threshold") is not None:
            ax.axhline(c["threshold"], color="tab:red", lw=1, ls="--")
    for ax in list(axes.flat)[len(claims):]:
        ax.axis("off")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    plt.close(fig)
    return buf.getvalue()


MISSING = ("!!! warning \"Not generated yet\"\n    `docs/data/{name}` is missing: run "
           "`{command}` and rebuild.\n")


# --------------------------------------------------------------------------- main


def main() -> None:
    """Write every generated page through mkdocs-gen-files."""
    import mkdocs_gen_files

    with mkdocs_gen_files.open("reference/configuration.md", "w") as fh:
        fh.write(configuration_page())
    with mkdocs_gen_files.open("reference/cli.md", "w") as fh:
        fh.write(cli_page())
    for page, text in api_pages().items():
        with mkdocs_gen_files.open(f"reference/api/{page}", "w") as fh:
            fh.write(text)

    verification = load_json("verification.json")
    with mkdocs_gen_files.open("validation/verification.md", "a") as fh:
        if verification is None:
            fh.write(MISSING.format(name="verification.json",
                                    command="python docs/scripts/update_validation.py verify"))
        else:
            fh.write("\n![Relative error over tolerance](verification-errors.png)\n\n")
            fh.write(verification_tables(verification))
            with mkdocs_gen_files.open("validation/verification-errors.png", "wb") as png:
                png.write(verification_figure(verification))

    with mkdocs_gen_files.open("validation/paper-claims.md", "a") as fh:
        for name, command, figure in (
                ("paper-claims.json", "python docs/scripts/update_validation.py claims",
                 "paper-claims.png"),
                ("study-claims.json", "python docs/scripts/update_validation.py study DIR",
                 "study-claims.png")):
            data = load_json(name)
            fh.write(f"\n## From `{name}`\n\n")
            if data is None:
                fh.write(MISSING.format(name=name, command=command))
                continue
            data["file"] = name
            fh.write(claims_tables(data))
            png = claims_figure(data)
            if png is not None:
                fh.write(f"\n![Every run of every claim]({figure})\n")
                with mkdocs_gen_files.open(f"validation/{figure}", "wb") as out:
                    out.write(png)

    with mkdocs_gen_files.open("changelog.md", "w") as fh:
        # Links from the repository root into docs/ become links within the site.
        fh.write((ROOT / "CHANGELOG.md").read_text().replace("](docs/", "]("))


def _in_mkdocs_build() -> bool:
    """True inside ``mkdocs build`` (outside, gen-files would write into docs/ itself)."""
    try:
        from mkdocs_gen_files.editor import FilesEditor
    except ImportError:
        return False
    return getattr(FilesEditor, "_current", None) is not None


if __name__ == "<run_path>" and _in_mkdocs_build():  # run by mkdocs-gen-files
    main()
