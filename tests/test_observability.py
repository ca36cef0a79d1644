"""Observable runs (issue "Safe, observable runs", second half): history.csv written as
the run goes, checkpoints every N steps, interruptible equilibration, explicit times,
the crack catalogue's columns, code tables and the SCDA plug in the snapshots, one sign
convention, and the size estimate of 3D specimens.

The runs here are a 30 x 30 mm slab at 2 mm zones, a few hundred steps per stage.
"""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from grainfrac.cli import app

runner = CliRunner()


# --------------------------------------------------------------------------- 3D size

SPEC_3D = """\
seed = 1
dimension = 3

[specimen]
shape = "slab"
width_mm = {w}
height_mm = {w}
thickness_mm = {t}
borehole_diameter_mm = 10.0

[grains]
min_edge_mm = 3.0
max_edge_mm = 8.0
zone_size_mm = {zone}
"""


@pytest.mark.parametrize(("w", "t", "zone", "field"), [
    (100.0, 100.0, 0.3, "grains.zone_size_mm"),  # the paper's cube at a fine zone
    (5000.0, 100.0, 2.0, "specimen.width_mm"),  # no zone the grains allow would do
])
def test_a_too_large_3d_specimen_is_refused_before_it_is_built(tmp_path, monkeypatch, w, t,
                                                              zone, field):
    from grainfrac import assembly

    def never(*args, **kwargs):
        raise AssertionError("the specimen was built")

    monkeypatch.setattr(assembly, "build_assembly", never)
    path = tmp_path / "cube.toml"
    path.write_text(SPEC_3D.format(w=w, t=t, zone=zone))
    result = runner.invoke(app, ["specimen", str(path), "--out", str(tmp_path / "out")])
    lines = [ln for ln in result.output.splitlines() if ln.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.output
    assert field in lines[0] and "tetrahedra" in lines[0] and "3D" in lines[0], lines[0]
    assert not (tmp_path / "out").exists()


def test_the_3d_estimate_is_close_to_what_meshing_makes():
    from grainfrac.assembly import SpecimenConfig
    from grainfrac.io.config import validate
    from grainfrac.scenario import TETS_PER_ZONE_VOLUME, check_size, estimated_elements

    config = validate(SpecimenConfig, {"dimension": 3, "specimen": {
        "shape": "slab", "width_mm": 30.0, "height_mm": 30.0, "thickness_mm": 20.0,
        "borehole_diameter_mm": 10.0}, "grains": {"zone_size_mm": 2.0}})
    # 17692 tetrahedra measured for this slab (seed-independent to a few %).
    assert 17692 <= estimated_elements(config) <= 17692 * 9.0 / 8.0
    assert TETS_PER_ZONE_VOLUME == 9.0
    assert check_size(config) is config  # a small 3D slab passes
