#!/usr/bin/env python3
"""The three views an artist looks at a terrain through (issue 25): a 1:1 hillshade (the
whole terrain up to 1024 cells a side, else a 1024-cell window at its centre), the whole
terrain downsampled to at most 1024 px with an elevation tint, and a 3D view with 2x
vertical exaggeration, rendered here by column ray casting so that no GPU or browser is
needed (the web page has the interactive WebGL view).

usage: scripts/views.py TERRAIN.tif OUT_PREFIX [--cell METRES] [--exaggeration X]
       [--azimuth DEG] [--window X,Y]
writes OUT_PREFIX-hillshade.png, OUT_PREFIX-whole.png and OUT_PREFIX-3d.png.
needs numpy, pillow and tifffile (scripts/test.sh installs them in target/pyenv).
"""
import argparse
import numpy as np
import tifffile
from PIL import Image


def shade(h, cell, azimuth=315.0, altitude=45.0):
    """Lambertian hillshade in [0, 1] of heights `h` on `cell`-metre cells."""
    gy, gx = np.gradient(h.astype(np.float64), cell)
    az, alt = np.radians(azimuth), np.radians(altitude)
    # light direction: from the azimuth (clockwise from north, y grows southwards)
    lx, ly, lz = np.sin(az) * np.cos(alt), -np.cos(az) * np.cos(alt), np.sin(alt)
    n = np.sqrt(gx * gx + gy * gy + 1.0)
    return np.clip((-gx * lx - gy * ly + lz) / n, 0.0, 1.0)


# low green, mid brown, high grey-white: a hypsometric ramp on the terrain's own range
RAMP = np.array([[0.00, 70, 110, 60], [0.35, 150, 150, 90], [0.65, 140, 110, 80],
                 [0.85, 170, 160, 150], [1.00, 245, 245, 245]], np.float64)


def tint(h, lo, hi):
    t = np.clip((h - lo) / max(hi - lo, 1e-6), 0.0, 1.0)
    return np.stack([np.interp(t, RAMP[:, 0], RAMP[:, c]) for c in (1, 2, 3)], -1)


def downsample(h, side):
    """Block mean down to at most `side` cells a side (integer factor)."""
    f = max(1, int(np.ceil(max(h.shape) / side)))
    hh, ww = h.shape[0] // f * f, h.shape[1] // f * f
    return h[:hh, :ww].reshape(hh // f, f, ww // f, f).mean(axis=(1, 3)), f


def render_3d(h, cell, exaggeration, azimuth, width=1600, height=900):
    """Column ray casting ("voxel space"): the camera stands beyond the terrain's side
    the light comes from, far and high enough to see all of it, and looks across its
    centre, 25 degrees down; each screen column marches front to back and a row takes
    the colour of the first sample whose projection reaches it."""
    n_y, n_x = h.shape
    z = h * exaggeration
    lo, hi = float(z.min()), float(z.max())
    col = tint(h, float(h.min()), float(h.max())) * (0.35 + 0.65 * shade(h, cell / exaggeration)[..., None])
    size = max(n_x, n_y) * cell
    a = np.radians(azimuth + 180.0)
    fwd = np.array([np.sin(a), -np.cos(a)])            # ground direction the camera looks along
    right = np.array([-fwd[1], fwd[0]])
    centre = np.array([n_x * cell / 2, n_y * cell / 2])
    dist = 1.45 * size
    cam = centre - fwd * dist
    pitch = np.tan(np.radians(25))
    cam_z = (lo + hi) / 2 + dist * pitch
    focal = width / 2 / np.tan(np.radians(30))        # 60-degree horizontal field of view
    horizon = 0.36 * height - pitch * focal
    u = (np.arange(width) - width / 2) / focal          # column's ray slope sideways
    steps = np.linspace(dist - 0.75 * size, dist + 0.75 * size, 3 * max(n_x, n_y))
    ytop = np.full((len(steps), width), np.inf)
    base = np.full(width, -np.inf)                      # the terrain's near edge, per column
    rgb = np.empty((len(steps), width, 3))
    sky = np.array([200.0, 215.0, 230.0])
    for i, d in enumerate(steps):
        p = cam[None, :] + d * (fwd[None, :] + u[:, None] * right[None, :])
        gx, gy = p[:, 0] / cell - 0.5, p[:, 1] / cell - 0.5
        inside = (gx >= 0) & (gx < n_x - 1) & (gy >= 0) & (gy < n_y - 1)
        ix = np.clip(gx.astype(int), 0, n_x - 2)
        iy = np.clip(gy.astype(int), 0, n_y - 2)
        fx, fy = np.clip(gx - ix, 0, 1), np.clip(gy - iy, 0, 1)
        zz = ((z[iy, ix] * (1 - fx) + z[iy, ix + 1] * fx) * (1 - fy)
              + (z[iy + 1, ix] * (1 - fx) + z[iy + 1, ix + 1] * fx) * fy)
        ytop[i] = np.where(inside, horizon + (cam_z - zz) / d * focal, np.inf)
        first = inside & np.isinf(base)
        base[first] = horizon + (cam_z - lo) / d * focal
        fog = 0.5 * (d - steps[0]) / (steps[-1] - steps[0])
        rgb[i] = col[iy, ix] * (1 - fog) + sky * fog
    # the first sample (front to back) whose running-minimum top reaches a row colours it;
    # rows below the terrain's near edge show its side as a dark band, then the ground
    run_min = np.minimum.accumulate(ytop, axis=0)
    img = np.empty((height, width, 3))
    backdrop = np.linspace(0, 1, height)[:, None] * np.array([60, 50, 30]) + np.array([150, 180, 215])
    rows = np.arange(height) + 0.5
    for c in range(width):
        first = np.searchsorted(-run_min[:, c], -rows, side="left")
        hit = (first < len(steps)) & (rows <= base[c])
        img[:, c] = np.where(hit[:, None], rgb[np.minimum(first, len(steps) - 1), c], backdrop)
    return np.clip(img, 0, 255).astype(np.uint8)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("terrain")
    ap.add_argument("out")
    ap.add_argument("--cell", type=float, default=90.0, help="cell size in metres (default 90)")
    ap.add_argument("--exaggeration", type=float, default=2.0)
    ap.add_argument("--azimuth", type=float, default=315.0, help="light and view azimuth, degrees")
    ap.add_argument("--window", help="X,Y: the 1:1 window's top-left cell (default: centred)")
    a = ap.parse_args()
    try:
        h = tifffile.imread(a.terrain).astype(np.float64)
    except (OSError, ValueError) as e:
        raise SystemExit(f"{a.terrain}: cannot read a GeoTIFF of heights ({e})")
    if h.ndim != 2:
        raise SystemExit(f"{a.terrain}: expected one band of heights, got shape {h.shape}")
    lo, hi = float(h.min()), float(h.max())
    n_y, n_x = h.shape
    w = min(1024, n_x), min(1024, n_y)
    if a.window:
        x0, y0 = (int(v) for v in a.window.split(","))
    else:
        x0, y0 = (n_x - w[0]) // 2, (n_y - w[1]) // 2
    win = h[y0:y0 + w[1], x0:x0 + w[0]]
    Image.fromarray((255 * shade(win, a.cell, a.azimuth)).astype(np.uint8)).save(a.out + "-hillshade.png")
    small, f = downsample(h, 1024)
    whole = tint(small, lo, hi) * (0.35 + 0.65 * shade(small, a.cell * f, a.azimuth)[..., None])
    Image.fromarray(np.clip(whole, 0, 255).astype(np.uint8)).save(a.out + "-whole.png")
    Image.fromarray(render_3d(small, a.cell * f, a.exaggeration, a.azimuth)).save(a.out + "-3d.png")
    print(f"{a.terrain}: {n_x}x{n_y}, {lo:.0f} to {hi:.0f} m; 1:1 window at ({x0}, {y0}); "
          f"whole and 3D at 1/{f}; wrote {a.out}-hillshade.png, -whole.png, -3d.png")


if __name__ == "__main__":
    main()
