"""The documentation: the site builds with warnings as errors, its generated reference
covers every schema field, command and module, and no file cites a document that is
not in the project."""

from __future__ import annotations

import html
import importlib.util
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOC_TOOLS = ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers.python",
             "mkdocs_gen_files", "mkdocs_literate_nav")
QUICK_START = (
    'python3 -m venv .venv && . .venv/bin/activate && pip install -e . && grainfrac demo '
    '--out demo',
    'python3 -m venv .venv && . .venv/bin/activate && pip install -e ".[test]" && pytest',
)


def _gen_ref():
    spec = importlib.util.spec_from_file_location("gen_ref", ROOT / "docs" / "gen_ref.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _have_doc_tools() -> bool:
    try:
        return all(importlib.util.find_spec(name) is not None for name in DOC_TOOLS)
    except ModuleNotFoundError:
        return False


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site built the documented way: ``mkdocs build --strict`` (about 10 s)."""
    if not _have_doc_tools():
        pytest.skip("docs tooling not installed (pip install -e '.[docs]')")
    out = tmp_path_factory.mktemp("site")
    env = {**os.environ, "DISABLE_MKDOCS_2_WARNING": "true", "NO_MKDOCS_2_WARNING": "1"}
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "-f", str(ROOT / "mkdocs.yml"),
         "-d", str(out)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stderr[-6000:]}"
    return out


def _text(path: Path) -> str:
    return path.read_text(encoding="utf-8")


def _cells(row_html: str) -> str:
    """The text of an HTML table row, cells separated by ``|``."""
    return html.unescape(re.sub(r"<[^>]+>", "|", row_html))


def _section(page: str, anchor: str) -> str:
    """HTML from the heading with ``id=anchor`` to the next heading of level <= 3."""
    start = page.index(f'id="{anchor}"')
    match = re.compile(r"<h[123][ >]").search(page, start + 1)
    return page[start:match.start() if match else len(page)]


def test_site_builds_strict_with_every_page(site):
    for page in ("index.html", "outputs/index.html", "reference/configuration/index.html",
                 "reference/cli/index.html", "validation/verification/index.html",
                 "validation/paper-claims/index.html", "changelog/index.html",
                 "decisions/index.html"):
        assert (site / page).is_file(), page


def test_field_reference_lists_every_field_of_every_schema(site):
    """Each schema of the package (found by walking it) has a section listing all its fields."""
    gen = _gen_ref()
    page = _text(site / "reference" / "configuration" / "index.html")
    models = gen.schema_models()
    assert len(models) >= 20, [m.__name__ for m in models]
    for name in ("Scenario", "SpecimenConfig", "RockRecipe", "SweepConfig",
                 "CalibrationConfig", "LabTestConfig"):
        assert name in {m.__name__ for m in models}, name
    missing = []
    for model in models:
        section = _section(page, model.__name__.lower())
        for field in model.model_fields:
            if f"<code>{field}</code>" not in section:
                missing.append(f"{model.__name__}.{field}")
    assert not missing, f"fields missing from the generated reference: {missing}"


def test_field_reference_states_type_unit_default_and_range(site):
    page = _text(site / "reference" / "configuration" / "index.html")
    row = re.search(r"<code>rate_ml_per_min</code>.*?</tr>", _section(page, "injectstage"), re.S)
    cells = _cells(row.group(0))
    assert "number" in cells and "ml/min" in cells and "required" in cells and "> 0" in cells
    row = re.search(r"<code>fraction</code>.*?</tr>", _section(page, "fissurespec"), re.S)
    assert ">= 0 and < 1" in _cells(row.group(0))


def test_cli_reference_lists_every_command_and_option(site):
    gen = _gen_ref()
    page = _text(site / "reference" / "cli" / "index.html")
    root = gen.cli_command()
    assert len(root.commands) >= 10
    for name, command in root.commands.items():
        assert f"grainfrac {name}" in page, name
        for param in command.params:
            for opt in getattr(param, "opts", []):
                if opt.startswith("--") and opt != "--help":
                    assert opt in page, f"grainfrac {name} {opt}"


def test_api_reference_has_a_page_per_module(site):
    gen = _gen_ref()
    modules = gen.package_modules()
    assert "grainfrac.scenario" in modules and len(modules) > 30
    api = site / "reference" / "api"
    for name in modules:
        parts = name.split(".")[1:]
        candidates = [api.joinpath(*parts, "index.html")]
        assert any(c.is_file() for c in candidates), f"no API page for {name}"
    # mkdocstrings rendered the docstrings, not just the heading.
    assert "load_scenario" in _text(api / "scenario" / "index.html")


def test_validation_pages_are_generated_from_data(site):
    page = _text(site / "validation" / "verification" / "index.html")
    if (ROOT / "docs" / "data" / "verification.json").is_file():
        assert "grainfrac verify kirsch" in page and "relative error" in page
        assert (site / "validation" / "verification-errors.png").stat().st_size > 1000
    else:
        assert "Not generated yet" in page


# --------------------------------------------------------------------------- project files


def _project_files() -> list[Path]:
    """Files of the project: tracked by git, or the source tree when git is unavailable."""
    try:
        listed = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=ROOT,
                                capture_output=True, text=True, check=True).stdout.split()
        return [ROOT / p for p in listed if (ROOT / p).is_file()]
    except (OSError, subprocess.CalledProcessError):
        skip = {".git", ".venv", "build", "site", "__pycache__"}
        return [p for p in ROOT.rglob("*") if p.is_file()
                and not skip & set(p.relative_to(ROOT).parts)
                and ".egg-info" not in str(p)]


def test_no_file_cites_a_document_outside_the_project():
    """Internal design notes, style guides and paths outside the repository are not
    shipped; nothing in the project may send a user there."""
    outside = [name + ".md" for name in ("DESIGN", "STYLE", "STACK-NOTES")]
    outside += [".." + "/shared", "/work" + "/shared"]
    offenders = []
    for path in _project_files():
        if path.suffix in (".png", ".npz", ".vtu", ".h5", ".parquet"):
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except (UnicodeDecodeError, OSError):
            continue
        for needle in outside:
            for lineno, line in enumerate(text.splitlines(), 1):
                if needle in line:
                    offenders.append(f"{path.relative_to(ROOT)}:{lineno}: {needle}")
    assert not offenders, "cites a document that is not in the project:\n" + "\n".join(offenders)


def test_readme_is_short_and_keeps_the_quick_start():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert len(readme.splitlines()) <= 200
    for command in QUICK_START:
        assert f"```bash\n{command}\n```" in readme, command


def test_readme_links_point_to_files_in_the_project():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", readme):
        if re.match(r"[a-z]+://", target):
            continue
        assert (ROOT / target).exists(), f"README links to a missing file: {target}"
