#!/usr/bin/env python3
"""Writes a dense float grid for OpenVDB AX to fill.

usage: make_dense.py OUT.vdb [CELLS] [NAME]

The grid covers the box [-1, 1]^3 with CELLS^3 voxels (default 256) of size 2/CELLS, voxel
(i, j, k) centred at -1 + (i + 1/2) * 2/CELLS on each axis, as a felt domain's cell (i, j, k)
is. Every voxel is stored in a leaf and active (no tiles): the values vary from voxel to voxel
and none equals the background 0, so neither the array copy nor pruning can collapse a leaf
into a tile, and AX visits exactly CELLS^3 voxels. Prints the active voxel and leaf counts.
"""
import sys

import numpy as np
import pyopenvdb as vdb


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    out = sys.argv[1]
    cells = int(sys.argv[2]) if len(sys.argv) > 2 else 256
    name = sys.argv[3] if len(sys.argv) > 3 else "density"
    voxel = 2.0 / cells
    i = np.arange(cells, dtype=np.float32)
    # 1 + a ramp over all three indices: never 0, never constant across a leaf.
    values = 1.0 + (i[:, None, None] + 2.0 * i[None, :, None] + 3.0 * i[None, None, :]) * 1e-4
    grid = vdb.FloatGrid(0.0)
    grid.copyFromArray(values.astype(np.float32), ijk=(0, 0, 0), tolerance=0.0)
    grid.name = name
    grid.gridClass = vdb.GridClass.FOG_VOLUME
    corner = -1.0 + 0.5 * voxel
    grid.transform = vdb.createLinearTransform(
        [[voxel, 0, 0, 0], [0, voxel, 0, 0], [0, 0, voxel, 0], [corner, corner, corner, 1]]
    )
    first = grid.transform.indexToWorld((0, 0, 0))
    if abs(first[0] - corner) > 1e-12:
        sys.exit(f"transform puts voxel 0 at {first}, expected {corner}")
    leaves = grid.leafCount()
    vdb.write(out, grids=[grid])
    print(f"active voxels {grid.activeVoxelCount()} leaves {leaves} voxel size {voxel}")


if __name__ == "__main__":
    main()
