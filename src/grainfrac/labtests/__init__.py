"""Virtual laboratory: UCS, BTS, NSCB and constant-head permeability tests (paper Sect. 3).

::

    from grainfrac.labtests import lab_test_config, run_labtest
    summary = run_labtest(lab_test_config("bts", seed=1), "runs/bts")
    summary["bts_MPa"]
"""

from grainfrac.labtests.config import (
    TEST_KINDS,
    LabTestConfig,
    lab_test_config,
    load_lab_test_config,
)
from grainfrac.labtests.run import measure, run_labtest

__all__ = ["TEST_KINDS", "LabTestConfig", "lab_test_config", "load_lab_test_config", "measure",
           "run_labtest"]
