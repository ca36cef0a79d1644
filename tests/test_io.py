"""Snapshots, crack catalogue, atomic writes."""

from __future__ import annotations

import csv
import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

from grainfrac.assembly import SpecimenConfig, build_assembly
from grainfrac.io.config import validate
from grainfrac.io.files import atomic_path, write_csv
from grainfrac.io.snapshots import SnapshotSeries
from grainfrac.io.vtk import write_assembly
from grainfrac.physics.cracks import crack_catalogue
from grainfrac.physics.kernels import SHEAR, TENSILE
from grainfrac.physics.kinematics import contact_opening


@pytest.fixture(scope="module")
def ucs():
    cfg = validate(SpecimenConfig, {"specimen": {"shape": "rectangle"}})
    return build_assembly(cfg, cfg.recipe())


def test_assembly_vtu_round_trip(ucs, tmp_path):
    grains, contacts = write_assembly(ucs, tmp_path)
    g = meshio.read(grains)
    c = meshio.read(contacts)
    assert g.cells_dict["triangle"].shape == ucs.mesh.element_nodes.shape
    np.testing.assert_array_equal(g.cell_data["grain_id"][0], ucs.mesh.element_grain)
    np.testing.assert_allclose(g.cell_data["youngs_modulus_Pa"][0], ucs.element_youngs_modulus)
    assert c.cells_dict["line"].shape == (ucs.mesh.n_contacts, 2)
    for key in ("contact_type", "tensile_strength_Pa", "fissure"):
        assert len(c.cell_data[key][0]) == ucs.mesh.n_contacts


def test_snapshot_series(ucs, tmp_path):
    n, m, c = ucs.mesh.n_nodes, ucs.mesh.n_elements, ucs.mesh.n_contacts
    rng = np.random.default_rng(0)
    series = SnapshotSeries(tmp_path / "snapshots")
    for k in range(2):
        u = rng.normal(size=(n, 2)) * 1e-6
        status = np.zeros(c, dtype=np.int64)
        status[:3] = TENSILE
        pressure = rng.uniform(0, 1e7, size=c)
        aperture = rng.uniform(2e-7, 3e-5, size=c)
        series.write(ucs, time=0.1 * k, u=u, stress=rng.normal(size=(m, 4)),
                     sigma_n=rng.normal(size=c), tau=rng.normal(size=c), status=status,
                     pressure=pressure, aperture=aperture)
    grains = meshio.read(tmp_path / "snapshots" / "grains_0001.vtu")
    np.testing.assert_allclose(grains.point_data["displacement_m"][:, :2], u)
    assert grains.cell_data["stress_compression_positive_Pa"][0].shape == (m, 6)
    contacts = meshio.read(tmp_path / "snapshots" / "contacts_0001.vtu")
    np.testing.assert_allclose(contacts.cell_data["opening_m"][0], contact_opening(ucs, u))
    assert contacts.cell_data["failed"][0][:3].tolist() == [1, 1, 1]
    np.testing.assert_allclose(contacts.cell_data["pressure_Pa"][0], pressure)
    np.testing.assert_allclose(contacts.cell_data["aperture_m"][0], aperture)
    root = ET.parse(tmp_path / "snapshots" / "series.pvd").getroot()
    files = [d.get("file") for d in root.iter("DataSet")]
    assert files == ["grains_0000.vtu", "contacts_0000.vtu", "grains_0001.vtu",
                     "contacts_0001.vtu"]
    assert all((tmp_path / "snapshots" / f).is_file() for f in files)


def test_background_snapshots_are_the_files_of_their_moment(ucs, tmp_path):
    """Written by the worker thread, each snapshot holds the arrays as they were when it
    was taken (the caller changes them right after) and is byte for byte the file the
    caller's own thread writes; a write's error comes out of ``wait``."""
    n, m, c = ucs.mesh.n_nodes, ucs.mesh.n_elements, ucs.mesh.n_contacts
    rng = np.random.default_rng(1)
    u, stress = rng.normal(size=(n, 2)) * 1e-6, rng.normal(size=(m, 4))
    sigma_n, tau, pressure = rng.normal(size=c), rng.normal(size=(c, 1)), np.ones(c)
    status = np.zeros(c, dtype=np.int64)
    fields = dict(u=u, stress=stress, sigma_n=sigma_n, tau=tau[:, 0], status=status,
                  pressure=pressure, aperture=2e-6 * pressure)
    series = {kind: SnapshotSeries(tmp_path / kind, background=kind == "background")
              for kind in ("foreground", "background")}
    for k in range(3):
        for s in series.values():
            s.write(ucs, time=0.1 * k, **fields)
        for array in (u, stress, sigma_n, tau, status, pressure):
            array += 1  # the run goes on while the worker writes
    series["background"].wait()
    names = sorted(p.name for p in (tmp_path / "foreground").iterdir())
    assert len(names) == 7  # two files a snapshot and the index
    for name in names:
        assert ((tmp_path / "background" / name).read_bytes()
                == (tmp_path / "foreground" / name).read_bytes()), name
    blocked = SnapshotSeries(tmp_path / "in-the-way", background=True)
    (tmp_path / "in-the-way").write_text("a file where the directory should be")
    blocked.write(ucs, time=0.0, **fields)
    with pytest.raises(OSError):
        blocked.wait()
    blocked.wait()  # the error is reported once


def test_crack_catalogue_rows(ucs, tmp_path):
    contacts = [4, 9]
    cat = crack_catalogue(ucs, contacts, [1e-3, 2e-3], [TENSILE, SHEAR], [1e-6, 2e-6])
    assert (cat.n_tensile, cat.n_shear, len(cat)) == (1, 1, 2)
    rows = cat.rows(ucs.pair_names)
    assert rows[0]["mode"] == "tensile" and rows[1]["mode"] == "shear"
    assert rows[0]["x_mm"] == pytest.approx(ucs.mesh.contact_xy[4, 0] * 1e3)
    assert rows[1]["contact_type"] == ucs.pair_names[ucs.contact_view("pair")[9]]
    path = write_csv(tmp_path / "cracks.csv", rows, list(rows[0]))
    with open(path) as fh:
        back = list(csv.DictReader(fh))
    assert [r["mode"] for r in back] == ["tensile", "shear"]


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "summary.json"
    with pytest.raises(RuntimeError), atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("killed")
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []
