"""The coupling's compiled kernels give the numpy expressions they replace, bit for bit."""

import numpy as np
import scipy.sparse as sp

from grainfrac.physics.coupling_kernels import (
    contact_openings,
    laplacian_data,
    mean_hydraulic_apertures,
    on_loose_grain,
)
from grainfrac.physics.pressure_system import _converted_laplacian, _LaplacianPattern


def test_contact_openings_match_numpy_in_both_dimensions():
    rng = np.random.default_rng(1)
    for d in (2, 3):
        u = rng.normal(size=(500, d)) * 1e-6
        nodes = rng.integers(0, 500, (800, 2))
        normal = rng.normal(size=(800, d))
        reference = np.sum((u[nodes[:, 1]] - u[nodes[:, 0]]) * normal, axis=1)
        assert np.array_equal(contact_openings(u, nodes, normal), reference)


def test_mean_hydraulic_apertures_cap_and_keep_nan():
    rng = np.random.default_rng(2)
    aperture = rng.uniform(1e-6, 1e-4, 300)
    aperture[7] = np.nan  # a blown-up opening must stay visible, not be capped away
    pipe_contacts = rng.integers(0, 300, (1000, 2))
    pipe_index = rng.choice(1000, 600, replace=False)
    cap = 5e-5
    hydraulic = np.minimum(aperture, cap)
    ends = pipe_contacts[pipe_index]
    reference = 0.5 * (hydraulic[ends[:, 0]] + hydraulic[ends[:, 1]])
    got = mean_hydraulic_apertures(aperture, cap, pipe_contacts, pipe_index)
    assert np.array_equal(got, reference, equal_nan=True)
    assert np.isnan(got).any()


def test_laplacian_of_a_kept_pattern_is_scipys_conversion():
    rng = np.random.default_rng(3)
    n = 200
    ends = rng.integers(0, n, (900, 2))
    ends = ends[ends[:, 0] != ends[:, 1]]
    pattern = _LaplacianPattern(n, ends)
    assert pattern.exact
    cond = rng.uniform(1e-15, 1e-9, len(ends))
    mine, reference = pattern.matrix(cond), _converted_laplacian(n, ends, cond)
    for part in ("indptr", "indices", "data"):
        assert np.array_equal(getattr(mine, part), getattr(reference, part))
    # Rows sum to zero to round-off: flow leaves one node as it enters the other.
    assert np.abs(sp.csr_matrix(mine) @ np.ones(n)).max() <= 1e-12 * cond.max()


def test_laplacian_data_adds_in_entry_order():
    cond = np.array([1.0, 1e-17])
    # Both pipes' diagonal entries into slot 0, then their negatives into slot 1.
    order = np.array([0, 1, 2, 3, 4, 5, 6, 7])
    slot = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    data = laplacian_data(cond, order, slot, 2)
    assert data[0] == ((1.0 + 1e-17) + 1.0) + 1e-17
    assert data[1] == -data[0]


def test_on_loose_grain_matches_numpy():
    rng = np.random.default_rng(4)
    n_grains = 40
    pairs = rng.integers(0, n_grains, (600, 2))
    for bonded_fraction in (0.0, 0.02, 0.5, 1.0):
        bonded = rng.random(600) < bonded_fraction
        held = np.zeros(n_grains, dtype=bool)
        held[pairs[bonded, 0]] = True
        held[pairs[bonded, 1]] = True
        reference = ~held[pairs[:, 0]] | ~held[pairs[:, 1]]
        assert np.array_equal(on_loose_grain(pairs, bonded, n_grains), reference)
