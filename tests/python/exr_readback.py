"""Reads a terrain written as OpenEXR with the OpenEXR project's own Python reader
and the same job's float TIFF with tifffile, and checks they hold the same metres bit
for bit (issue 28: an EXR another reader reads back exactly).

usage: exr_readback.py TERRAIN.exr TERRAIN.tif
"""

import sys

import numpy as np
import OpenEXR
import tifffile


def main(exr_path: str, tif_path: str) -> int:
    with OpenEXR.File(exr_path) as f:
        channels = f.channels()
        if "Y" not in channels:
            print(f"{exr_path}: no Y channel (channels: {sorted(channels)})")
            return 1
        exr = np.asarray(channels["Y"].pixels)
        cell = f.header().get("cellSizeMetres")
    tif = tifffile.imread(tif_path)
    if exr.dtype != np.float32 or exr.shape != tif.shape:
        print(f"{exr_path}: {exr.dtype} {exr.shape}, the TIFF holds {tif.dtype} {tif.shape}")
        return 1
    same = np.array_equal(exr.view(np.uint32), tif.astype(np.float32).view(np.uint32))
    print(f"{exr_path}: {exr.shape[1]} x {exr.shape[0]} float32, cell {cell} m, "
          f"{'bit for bit equal to' if same else 'DIFFERENT from'} {tif_path}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:3]))
