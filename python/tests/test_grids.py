"""Caches and sampled fields as NumPy arrays, and NumPy arrays into caches."""

import numpy as np
import pytest

import felt

# A linear field: its samples at cell centres have a closed form, and a trilinear read of a
# cache of it reproduces it exactly (up to float32 rounding).
LINEAR = "vectorfield p = identity();\nscalarfield f = p.x + 2 * p.y + 3 * p.z;\n"


def centres(origin, cell, shape):
    i, j, k = np.meshgrid(*(np.arange(n) for n in shape), indexing="ij")
    return (
        origin[0] + (i + 0.5) * cell,
        origin[1] + (j + 0.5) * cell,
        origin[2] + (k + 0.5) * cell,
    )


def test_a_sampled_field_is_its_closed_form_at_cell_centres(session):
    session.run(LINEAR)
    grid = session.sample("f", ((-1.0, 0.0, 0.5), (2.0, 1.5, 1.0), 0.125))
    assert grid.values.shape == (16, 12, 8)
    assert grid.values.dtype == np.float32
    assert grid.origin == (-1.0, 0.0, 0.5)
    assert grid.cell == (0.125, 0.125, 0.125)
    x, y, z = centres(grid.origin, 0.125, grid.values.shape)
    np.testing.assert_allclose(grid.values, x + 2 * y + 3 * z, rtol=0, atol=1e-6)


def test_an_expression_over_globals_can_be_sampled(session):
    session.run(LINEAR + "domain box((0,0,0), (1,1,1), (0,0,0), 0.25);\n")
    grid = session.sample("f * f - 1", "box")
    x, y, z = centres((0, 0, 0), 0.25, (4, 4, 4))
    np.testing.assert_allclose(grid.values, (x + 2 * y + 3 * z) ** 2 - 1, rtol=1e-6, atol=1e-6)


def test_a_vector_field_has_a_component_axis(session):
    session.run("vectorfield p = identity();\nvectorfield v = (p.y, -p.x, 2.0);")
    grid = session.sample("v", ((0, 0, 0), (1, 1, 1), 0.5))
    assert grid.values.shape == (2, 2, 2, 3)
    x, y, _ = centres((0, 0, 0), 0.5, (2, 2, 2))
    np.testing.assert_allclose(grid.values[..., 0], y, atol=1e-7)
    np.testing.assert_allclose(grid.values[..., 1], -x, atol=1e-7)
    np.testing.assert_array_equal(grid.values[..., 2], 2.0)


def test_a_cache_global_is_read_into_numpy(session):
    # 20 cells along x: not a whole number of 8-cell bricks, so the edge bricks are cut.
    session.run(
        LINEAR
        + "domain d((0,0,0), (2.5,1,0.5), (0,0,0), 0.125);\n"
        + "scalarcache c(d);\ncachewrite(c, f);\n"
    )
    grid = session.get("c")
    assert grid.values.shape == (20, 8, 4)
    # x fastest, felt's own order, so NumPy views the buffer felt filled (no second copy).
    assert grid.values.flags.f_contiguous and grid.values.flags.owndata is False
    x, y, z = centres((0, 0, 0), 0.125, (20, 8, 4))
    np.testing.assert_allclose(np.asarray(grid), x + 2 * y + 3 * z, atol=1e-6)


def test_an_array_handed_in_reads_back_bit_for_bit(session):
    rng = np.random.default_rng(7)
    values = rng.random((11, 9, 17), dtype=np.float32)
    session.set_cache("density", values, origin=(1.0, -2.0, 0.0), cell=0.1)
    session.run("float middle = probe(cacheread(density), (1.0 + 3.5 * 0.1, -2.0 + 4.5 * 0.1, 8.5 * 0.1));")
    # A read at a cell centre is that cell's value (the centre's position is rounded, and
    # neighbouring values differ by about 0.3, so 1e-6 tells the cell apart).
    assert session.get("middle") == pytest.approx(float(values[3, 4, 8]), abs=1e-6)
    back = session.get("density")
    np.testing.assert_array_equal(back.values, values)
    assert back.origin == (1.0, -2.0, 0.0)


def test_a_script_computes_with_a_vector_array_handed_in(session):
    values = np.zeros((4, 4, 4, 3))
    values[..., 0] = 1.0
    values[..., 2] = np.arange(4)[None, None, :]
    session.set_cache("vel", values, origin=(0, 0, 0), cell=0.25)
    session.run("vector at = probe(cacheread(vel), (0.125, 0.125, 0.375));")
    assert session.get("at") == (1.0, 0.0, 1.0)


def test_non_finite_values_are_refused(session):
    values = np.ones((2, 2, 2), dtype=np.float32)
    values[1, 0, 1] = np.nan
    with pytest.raises(ValueError, match="not finite"):
        session.set_cache("bad", values, origin=(0, 0, 0), cell=1.0)
    with pytest.raises(ValueError):
        session.set_cache("flat", np.ones((4, 4)), origin=(0, 0, 0), cell=1.0)


def test_a_script_cannot_redeclare_a_cache_handed_in(session):
    session.set_cache("density", np.ones((2, 2, 2)), origin=(0, 0, 0), cell=1.0)
    with pytest.raises(felt.FeltError) as raised:
        session.run("float density = 1;")
    assert raised.value.diagnostics[0].line == 1


def test_a_frustum_cache_is_refused_as_a_grid(session):
    # Its cells follow the camera's rays, so no box of equal cells holds them.
    session.run(
        "camera cam = camera((0, 0, 0), (0, 0, -1), (0, 1, 0), 40);\n"
        + "scalarcache c = frustumcache(cam, 0.5, 4, 8, 6, 8);\n"
        + "cachewrite(c, scalarfield(1.0));\n"
    )
    with pytest.raises(ValueError, match="frustum"):
        session.get("c")
