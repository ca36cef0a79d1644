"""Self-contained HTML report of one or several run directories.

Everything comes from the run directory alone (summary.json, config.toml,
history.csv, cracks.csv, figures/*.png), so a report can be made on any
machine long after the run. Figures are embedded as base64 PNG; no network.
With several runs the page opens with side-by-side tables and overlaid
pressure curves (e.g. the HS-only vs hybrid comparison of paper Fig. 17).
"""

from __future__ import annotations

import base64
import csv
import html
import io
import json
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from grainfrac.errors import GrainfracError  # noqa: E402
from grainfrac.io.files import write_text  # noqa: E402

KEY_ROWS = [
    ("breakdown pressure (MPa)", "breakdown_pressure_MPa", "{:.2f}"),
    ("breakdown time (ms)", "breakdown_time_s", "ms"),
    ("peak well pressure (MPa)", "peak_well_pressure_MPa", "{:.2f}"),
    ("peak expansive pressure (MPa)", "peak_expansive_pressure_MPa", "{:.1f}"),
    ("radial fractures", "n_radial_fractures", "{}"),
    ("radial fractures, mid-plane (3D)", "n_radial_fractures_mid", "{}"),
    ("fracture extent (mm)", "fracture_extent_mm", "{:.1f}"),
    ("cracks", "n_cracks", "{}"),
    ("tensile cracks", "n_tensile_cracks", "{}"),
    ("shear cracks", "n_shear_cracks", "{}"),
    ("T/S ratio", "tensile_shear_ratio", "{:.2f}"),
    ("tortuosity", "tortuosity", "{:.3f}"),
    ("tensile strain energy released (J)", "energy_tensile_J", "{:.3e}"),
    ("shear strain energy released (J)", "energy_shear_J", "{:.3e}"),
    ("frictional work (J)", "energy_friction_J", "{:.3e}"),
    ("injected volume (ml)", "injected_volume_ml", "{:.4f}"),
    ("injection stopped by", "injection_stop_reason", "{}"),
    ("grains / elements / contacts", None, None),
    ("seed", "seed", "{}"),
    ("wall time (s)", "wall_time_s", "{:.1f}"),
]
# Rows left out where no run has a value (3D-only keys, keys older runs lack).
OPTIONAL_KEYS = {"n_radial_fractures_mid", "injection_stop_reason"}


@dataclass
class RunRecord:
    """What the report reads from one run directory."""

    path: Path
    name: str
    summary: dict
    config_text: str
    history: list[dict]
    cracks: list[dict]
    figures: dict[str, bytes]


def read_run(path: str | Path) -> RunRecord:
    """Read a run directory; raise a clear error if it is not one."""
    path = Path(path)
    summary_file = path / "summary.json"
    if not summary_file.is_file():
        raise GrainfracError(f"{path} is not a finished run directory (no summary.json)")
    summary = json.loads(summary_file.read_text())

    def rows(name: str) -> list[dict]:
        f = path / name
        return list(csv.DictReader(f.open())) if f.is_file() else []

    figures = {f.stem: f.read_bytes() for f in sorted((path / "figures").glob("*.png"))}
    config = path / "config.toml"
    return RunRecord(path, summary.get("scenario") or path.name, summary,
                     config.read_text() if config.is_file() else "", rows("history.csv"),
                     rows("cracks.csv"), figures)


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", bbox_inches="tight", dpi=130)
    plt.close(fig)
    return buf.getvalue()


def _img(data: bytes, alt: str) -> str:
    b64 = base64.b64encode(data).decode("ascii")
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{b64}">' \
           f'<figcaption>{html.escape(alt)}</figcaption></figure>'


def energy_figure(runs: list[RunRecord]) -> bytes:
    """Bars of released tensile/shear strain energy and frictional work per run."""
    keys = [("energy_tensile_J", "tensile"), ("energy_shear_J", "shear"),
            ("energy_friction_J", "friction")]
    fig, ax = plt.subplots(figsize=(6.0, 3.2))
    width = 0.8 / len(runs)
    x = np.arange(len(keys))
    for i, r in enumerate(runs):
        vals = [float(r.summary.get(k) or 0.0) * 1e3 for k, _ in keys]
        ax.bar(x + i * width, vals, width, label=r.name)
    ax.set_xticks(x + 0.4 - width / 2, [label for _, label in keys])
    ax.set_ylabel("energy (mJ)")
    ax.legend(fontsize=8, frameon=False)
    ax.grid(True, axis="y", alpha=0.3)
    return _png(fig)


def contact_fraction_figure(run: RunRecord) -> bytes:
    """Fractions of contact types among all (T) and failed (C) contacts (paper Fig. 14e)."""
    total = run.summary.get("contact_fraction_total") or {}
    failed = run.summary.get("contact_fraction_failed") or {}
    pairs = list(total)
    fig, ax = plt.subplots(figsize=(6.0, 3.2))
    x = np.arange(len(pairs))
    ax.bar(x - 0.2, [100 * total[p] for p in pairs], 0.4, label="T: all contacts")
    ax.bar(x + 0.2, [100 * failed.get(p, 0.0) for p in pairs], 0.4, label="C: failed contacts")
    ax.set_xticks(x, pairs)
    ax.set_ylabel("fraction (%)")
    ax.legend(fontsize=8, frameon=False)
    ax.grid(True, axis="y", alpha=0.3)
    ax.set_title(run.name, fontsize=9)
    return _png(fig)


def rose_figure(run: RunRecord, bin_deg: float = 15.0) -> bytes:
    """Rose diagram of crack directions seen from the well (crack count per sector)."""
    x = np.array([float(c["x_mm"]) for c in run.cracks])
    y = np.array([float(c["y_mm"]) for c in run.cracks])
    theta = np.arctan2(y, x) % (2 * np.pi)
    edges = np.radians(np.arange(0.0, 360.0 + bin_deg, bin_deg))
    counts, _ = np.histogram(theta, bins=edges)
    fig = plt.figure(figsize=(3.6, 3.6))
    ax = fig.add_subplot(projection="polar")
    ax.bar(edges[:-1], counts, width=np.radians(bin_deg), align="edge", color="#2c7bb6",
           edgecolor="white")
    ax.set_title(f"{run.name}: crack directions", fontsize=9)
    return _png(fig)


def _injection_curve(run: RunRecord) -> tuple[np.ndarray, np.ndarray]:
    rows = [r for r in run.history if r["stage"] == "inject"]
    if not rows:
        return np.zeros(0), np.zeros(0)
    t = np.array([float(r["time_s"]) for r in rows])
    p = np.array([float(r["well_pressure_MPa"]) for r in rows])
    return (t - t[0]) * 1e3, p


def overlay_figure(runs: list[RunRecord]) -> bytes:
    """Well pressure during injection of every run on one axis (time since injection)."""
    fig, ax = plt.subplots(figsize=(6.4, 3.6))
    for r in runs:
        t, p = _injection_curve(r)
        if len(t):
            ax.plot(t, p, lw=1.6, label=r.name)
    ax.set_xlabel("time since injection start (ms)")
    ax.set_ylabel("well pressure (MPa)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, frameon=False)
    return _png(fig)


def _fmt(summary: dict, key: str | None, spec: str | None) -> str:
    if key is None:
        return (f"{summary.get('n_grains')} / {summary.get('n_elements')} / "
                f"{summary.get('n_contacts')}")
    value = summary.get(key)
    if value is None:
        return "&ndash;"
    if spec == "ms":
        return f"{1e3 * value:.2f}"
    return html.escape(spec.format(value))


def _table(runs: list[RunRecord]) -> str:
    head = "".join(f"<th>{html.escape(r.name)}</th>" for r in runs)
    body = "".join(
        f"<tr><td>{html.escape(label)}</td>"
        + "".join(f"<td>{_fmt(r.summary, key, spec)}</td>" for r in runs) + "</tr>"
        for label, key, spec in KEY_ROWS
        if key not in OPTIONAL_KEYS or any(r.summary.get(key) is not None for r in runs)
    )
    return f"<table><thead><tr><th>quantity</th>{head}</tr></thead><tbody>{body}</tbody></table>"


_STYLE = """
body{font-family:system-ui,sans-serif;margin:2em auto;max-width:1100px;color:#222}
h1{font-size:1.5em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em}
table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ddd;padding:.3em .7em}
td:not(:first-child){text-align:right}th{background:#f4f4f4}
figure{display:inline-block;margin:.5em;vertical-align:top}img{max-width:520px}
figcaption{font-size:.85em;color:#555}pre{background:#f7f7f7;padding:1em;overflow:auto;
font-size:.8em;max-height:30em}
"""

# Records how many embedded images decoded, so a headless browser test can check.
_CHECK = """
<script>
window.addEventListener('load', function () {
  var imgs = Array.prototype.slice.call(document.images);
  var ok = imgs.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  document.body.setAttribute('data-images', String(imgs.length));
  document.body.setAttribute('data-images-loaded', String(ok));
});
</script>
"""


def build_report(run_dirs: list[str | Path], out: str | Path) -> Path:
    """Write a self-contained HTML report of ``run_dirs`` to ``out``."""
    runs = [read_run(p) for p in run_dirs]
    names = [r.name for r in runs]
    if len(set(names)) < len(names):  # same scenario name twice: use directory names
        for r in runs:
            r.name = r.path.name
    parts = [f"<h1>grainfrac report: {html.escape(', '.join(r.name for r in runs))}</h1>"]
    if len(runs) > 1:
        parts.append("<h2>Comparison</h2>")
        parts.append(_table(runs))
        parts.append(_img(overlay_figure(runs), "well pressure during injection, all runs"))
        parts.append(_img(energy_figure(runs), "strain energy released and frictional work"))
        # 2D runs draw fractures.png, 3D runs fractures3d.png.
        patterns = [(r, r.figures.get("fractures", r.figures.get("fractures3d")))
                    for r in runs]
        parts.append("<div>" + "".join(
            _img(data, f"{r.name}: fracture pattern")
            for r, data in patterns if data is not None) + "</div>")
    for r in runs:
        parts.append(f"<h2>{html.escape(r.name)}</h2><p>run directory: "
                     f"<code>{html.escape(str(r.path))}</code></p>")
        parts.append(_table([r]))
        for stem, data in r.figures.items():
            parts.append(_img(data, f"{r.name}: {stem.replace('_', ' ')}"))
        if r.cracks:
            parts.append(_img(rose_figure(r), f"{r.name}: rose diagram of crack directions"))
        if r.summary.get("contact_fraction_total"):
            parts.append(_img(contact_fraction_figure(r),
                              f"{r.name}: contact types among all (T) and failed (C)"))
        if len(runs) == 1:
            parts.append(_img(energy_figure([r]), f"{r.name}: energies"))
        parts.append("<details><summary>resolved configuration (config.toml)</summary>"
                     f"<pre>{html.escape(r.config_text)}</pre></details>")
    page = ("<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
            f"<title>grainfrac report</title><style>{_STYLE}</style></head><body>"
            + "\n".join(parts) + _CHECK + "</body></html>")
    return write_text(out, page)
