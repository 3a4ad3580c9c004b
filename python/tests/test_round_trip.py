"""A TD's round trip: Python sets params, runs the smoke simulation frame by frame, gets its
density as NumPy, and the USD layer the simulation wrote names every frame's cache (checked
with Pixar's library where usd-core is installed)."""

import shutil

import numpy as np
import pytest

from conftest import ROOT


def test_a_simulation_round_trip_through_numpy_and_usd(session, tmp_path):
    script = tmp_path / "smoke_frames.felt"
    shutil.copy(ROOT / "examples" / "smoke_frames.felt", script)
    frames = 3
    means = []
    for frame in range(1, frames + 1):
        session.run_file(script, params={"frame": frame, "res": 16, "width": 16, "height": 12})
        density = session.get("state")
        assert density.values.shape == (16, 16, 16)
        assert np.isfinite(density.values).all() and density.values.min() >= 0
        means.append(float(density.values.mean()))
        # What the script printed agrees with the array: its mean over the cells.
        printed = float(session.output.split("mean ")[1].split()[0])
        assert printed == pytest.approx(means[-1], rel=1e-5)
    # Each frame starts from the last one's cache and adds a puff: the density grows.
    assert means[0] < means[1] < means[2]
    for frame in range(1, frames + 1):
        assert (tmp_path / f"smoke_cache.{frame:04d}.vdb").is_file()

    pytest.importorskip("pxr")
    from pxr import Usd, UsdVol

    stage = Usd.Stage.Open(str(tmp_path / "smoke.usda"))
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (1, frames)
    volume = next(UsdVol.Volume(p) for p in stage.Traverse() if p.IsA(UsdVol.Volume))
    fields = volume.GetFieldPaths()
    assert list(fields) == ["density"]
    asset = UsdVol.OpenVDBAsset(stage.GetPrimAtPath(fields["density"]))
    assert asset.GetFieldNameAttr().Get() == "density"
    samples = asset.GetFilePathAttr().GetTimeSamples()
    assert samples == [float(f) for f in range(1, frames + 1)]
