"""A render read back as NumPy channels, against the closed form of the march."""

import math

import numpy as np

import felt


def test_a_render_reads_back_as_its_closed_form(session, tmp_path):
    # An orthographic camera looks down z through a slab 1 unit thick of density 1 that emits
    # (1, 2, 3) per unit length with kappa = 1: every pixel is emission (1 - e^-1) and alpha
    # 1 - e^-1, exactly (the march integrates a constant sample exactly).
    path = tmp_path / "slab.exr"
    session.run(
        "camera cam = camera((0, 0, 5), (0, 0, 0), (0, 1, 0), 40, ortho = 1);\n"
        "domain slab((-2, -2, -0.5), (4, 4, 1), (0, 0, 0));\n"
        f'render("{path}", density = scalarfield(1.0), emission = vectorfield((1, 2, 3)),\n'
        "       camera = cam, kappa = 1.0, width = 8, height = 6, bounds = slab,\n"
        '       aovs = {"depth"});\n'
    )
    channels = felt.read_image(path)
    assert {"R", "G", "B", "A", "depth.Z"} <= set(channels)
    for name, scale in (("R", 1), ("G", 2), ("B", 3)):
        assert channels[name].shape == (6, 8)
        assert channels[name].dtype == np.float32
        np.testing.assert_allclose(channels[name], scale * (1 - math.exp(-1)), rtol=1e-5)
    np.testing.assert_allclose(channels["A"], 1 - math.exp(-1), rtol=1e-5)


def test_a_missing_image_is_an_os_error(tmp_path):
    try:
        felt.read_image(tmp_path / "none.exr")
    except OSError as error:
        assert "none.exr" in str(error)
    else:
        raise AssertionError("reading a missing image did not fail")
