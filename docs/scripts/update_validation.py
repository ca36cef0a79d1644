"""Regenerate the data behind the validation pages (docs/data/*.json).

The validation pages are built from these files by ``docs/gen_ref.py``; nothing on
them is typed by hand. Three sources, one subcommand each::

    python docs/scripts/update_validation.py verify            # grainfrac verify --json
    python docs/scripts/update_validation.py verify --kgd      # ... and the KGD cases (~5 min)
    python docs/scripts/update_validation.py verify --3d       # ... and the 3D cases (~70 min)
    python docs/scripts/update_validation.py verify --3d --only penny   # rerun one case
    python docs/scripts/update_validation.py verify --3d --only "penny --zone-size 2"
    python docs/scripts/update_validation.py claims            # the slow paper-claim tests
    python docs/scripts/update_validation.py study DIR         # a `grainfrac study paper` run

``verify`` runs ``grainfrac verify CASE --json`` for each case (``--jobs N`` at a time)
and writes ``docs/data/verification.json``. ``claims`` runs ``pytest -m slow
tests/test_paper_claims.py`` (tens of minutes on 2 cores; its sweeps are kept in
``--cache``, so a second call computes only what is missing) and writes
``docs/data/paper-claims.json``. ``study`` copies the verdicts of a finished
``grainfrac study paper --out DIR`` (its ``claims.json`` and per-run values) into
``docs/data/study-claims.json``. Rebuild the site afterwards (``mkdocs build --strict``).
"""

from __future__ import annotations

import argparse
import concurrent.futures
import csv
import datetime
import json
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "docs" / "data"
FAST_CASES = (("kirsch",), ("lame",), ("cubic-law",))
KGD_CASES = (("kgd",), ("kgd-toughness",))
# The 3D cases; kirsch3d at its 2 mm zones and with 1 mm zones at the wall, and in
# plane strain (the discretisation alone) with 0.8 mm zones at the wall; the penny at
# its 1 mm zones and at 2 mm, the zones of the paper's grain models (its radius at 1 ms
# is read off rings of grain faces a zone wide: decision record 0018).
CASES_3D = (("kirsch3d-plane-strain", "--wall-zone-size", "0.8"),
            ("kirsch3d",), ("kirsch3d", "--wall-zone-size", "2"),
            ("penny", "--zone-size", "1"), ("penny", "--zone-size", "2"),
            ("lame3d",), ("patch3d",), ("cubic-law3d",))
ALL_CASES = {*FAST_CASES, *KGD_CASES, *CASES_3D}


def _version() -> str:
    import grainfrac

    return grainfrac.__version__


def verify(kgd: bool, three_d: bool, jobs: int = 1, only: tuple[str, ...] = ()) -> Path:
    """Run the verification cases through the command line and keep their JSON rows.

    ``only``: rerun just the cases of these names (each with its options), or of these
    whole commands (``"penny --zone-size 2"``), and keep the other cases' rows of the
    existing file (rows of cases no longer in the lists are dropped); each case records
    the day it was run."""
    cases = [*FAST_CASES, *(KGD_CASES if kgd else ()), *(CASES_3D if three_d else ())]
    path = DATA / "verification.json"
    kept: list[dict] = []
    if only:
        unknown = set(only) - {c[0] for c in cases} - {" ".join(c) for c in cases}
        if unknown:
            raise SystemExit(f"--only: no such case among those selected: {sorted(unknown)}")
        kept = [c for c in json.loads(path.read_text())["cases"]
                if (c["case"], *c["options"]) in ALL_CASES]
        cases = [c for c in cases if c[0] in only or " ".join(c) in only]
    with concurrent.futures.ThreadPoolExecutor(max_workers=jobs) as pool:
        out = list(pool.map(_verify_case, cases))
    fresh = {(c["case"], tuple(c["options"])): c for c in out}
    if kept:
        out = [fresh.pop((c["case"], tuple(c["options"])), c) for c in kept] + list(
            fresh.values())
    flags = (" --kgd" if kgd else "") + (" --3d" if three_d else "")
    _write(path, {"command": f"python docs/scripts/update_validation.py verify{flags}",
                  "generated": datetime.date.today().isoformat(),
                  "grainfrac_version": _version(), "cases": out})
    return path


def _verify_case(case: tuple[str, ...]) -> dict:
    """``grainfrac verify NAME [OPTIONS] --json`` in its own process, and its rows."""
    name, *options = case
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "grainfrac.cli", "verify", name, *options,
                           "--json"], capture_output=True, text=True, cwd=ROOT)
    if proc.returncode not in (0, 1):  # 1: ran, some quantity out of tolerance
        raise SystemExit(f"grainfrac verify {' '.join(case)} failed:\n{proc.stderr}")
    rows = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    wall = time.perf_counter() - start
    print(f"{' '.join(case)}: {sum(r['passed'] for r in rows)} of {len(rows)} passed "
          f"({wall:.0f} s)", flush=True)
    return {"case": name, "options": options, "wall_time_s": wall,
            "run_on": datetime.date.today().isoformat(), "rows": rows}


def claims(cache: Path) -> Path:
    """Run the slow claim tests, which write their verdicts to docs/data/paper-claims.json."""
    path = DATA / "paper-claims.json"
    env = {**os.environ, "GRAINFRAC_CLAIMS_DIR": str(cache.resolve()),
           "GRAINFRAC_CLAIMS_JSON": str(path)}
    proc = subprocess.run([sys.executable, "-m", "pytest", "-m", "slow", "-q",
                           "tests/test_paper_claims.py"], cwd=ROOT, env=env)
    if not path.is_file():
        raise SystemExit("the claim tests wrote no verdicts")
    if proc.returncode:
        print("some claims did not hold; the page shows which", file=sys.stderr)
    return path


def study(directory: Path, options: str = "") -> Path:
    """Verdicts and per-run values of a finished ``grainfrac study paper --out DIR``
    (``options``: the study's other command-line options, for the record)."""
    verdicts = json.loads((directory / "claims.json").read_text())
    rows = []
    for v in verdicts:
        values = _study_values(directory / v["study"], v["quantity"])
        rows.append({**v, "id": v["claim"], "threshold": None, "values": values})
    path = DATA / "study-claims.json"
    extra = f" {options}" if options else ""
    _write(path, {"command": f"grainfrac study paper{extra} --out {directory.name}; python "
                             f"docs/scripts/update_validation.py study {directory.name}",
                  "generated": datetime.date.today().isoformat(),
                  "grainfrac_version": _version(), "claims": rows})
    return path


def _study_values(sweep_dir: Path, quantity: str) -> dict[str, list[float | None]]:
    runs = sweep_dir / "runs.csv"
    if not runs.is_file():
        return {}
    values: dict[str, list[float | None]] = {}
    with open(runs, newline="") as fh:
        for row in csv.DictReader(fh):
            if row.get("status") != "done":
                continue
            cell = row.get(quantity, "")
            values.setdefault(row["point"], []).append(float(cell) if cell else None)
    return values


def _write(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1) + "\n")
    print(f"wrote {path.relative_to(ROOT)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="what", required=True)
    v = sub.add_parser("verify", help="grainfrac verify CASE --json for every case")
    v.add_argument("--kgd", action="store_true", help="include the KGD cases (~5 min)")
    v.add_argument("--3d", dest="three_d", action="store_true",
                   help="include the 3D cases (~70 min on one core)")
    v.add_argument("--jobs", type=int, default=1, help="cases run at the same time")
    v.add_argument("--only", action="append", default=[], metavar="CASE",
                   help="rerun only this case (repeatable); the others' rows are kept")
    c = sub.add_parser("claims", help="the slow paper-claim tests")
    c.add_argument("--cache", type=Path, default=ROOT / "build" / "claims",
                   help="where the claim sweeps are kept between calls")
    s = sub.add_parser("study", help="verdicts of a grainfrac study paper directory")
    s.add_argument("directory", type=Path)
    s.add_argument("--options", default="",
                   help="the study's command-line options, recorded with its verdicts "
                        "(e.g. '--dim 3 --realisations 2')")
    args = parser.parse_args()
    if args.what == "verify":
        verify(args.kgd, args.three_d, max(1, args.jobs), tuple(args.only))
    elif args.what == "claims":
        claims(args.cache)
    else:
        study(args.directory, args.options)


if __name__ == "__main__":
    main()
