"""Reads a georeferenced terrain and its tiles with rasterio (GDAL) and checks each
has the CRS asked for and the transform of where it lies: the terrain's top-left
corner at the origin, each tile shifted by its offset in cells times the cell size
(issue 28: GeoTIFFs GDAL and rasterio place, not NotGeoreferenced at 0,0).

usage: geotiff_readback.py TILES_INDEX.json EPSG X Y
"""

import json
import os
import sys
import warnings

import rasterio


def main(index_path: str, epsg: str, x: str, y: str) -> int:
    warnings.simplefilter("error")  # NotGeoreferencedWarning fails the check
    folder = os.path.dirname(index_path)
    with open(index_path) as f:
        index = json.load(f)
    terrain = index_path.replace("_tiles.json", ".tif")
    x0, y0 = float(x), float(y)
    bad = 0
    with rasterio.open(terrain) as t:
        cell = t.res[0]
        ok = t.crs.to_epsg() == int(epsg) and (t.transform.c, t.transform.f) == (x0, y0) and t.res == (cell, cell)
        print(f"{terrain}: {t.crs}, origin ({t.transform.c}, {t.transform.f}), cell {t.res}: {'ok' if ok else 'WRONG'}")
        bad += not ok
        whole = t.read(1)
    for tile in index["tiles"]:
        with rasterio.open(os.path.join(folder, tile["file"])) as d:
            want = (x0 + tile["x0"] * cell, y0 - tile["y0"] * cell)
            got = (d.transform.c, d.transform.f)
            part = d.read(1)[: tile["valid_height"], : tile["valid_width"]]
            same = (part == whole[tile["y0"] : tile["y0"] + part.shape[0], tile["x0"] : tile["x0"] + part.shape[1]]).all()
            ok = d.crs.to_epsg() == int(epsg) and got == want and same
            bad += not ok
            if not ok:
                print(f"{tile['file']}: {d.crs}, origin {got}, want {want}, samples {'equal' if same else 'differ'}")
    print(f"{len(index['tiles'])} tiles placed where they lie in EPSG:{epsg}" if not bad else f"{bad} wrong")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:5]))
