"""Tests of the Python package `ridgeline` (python/src), run by scripts/test.sh with
pytest on the wheel maturin built, installed into target/pyenv.

What they hold the package to: a float32 (height, width) array in metres; the same
inputs and seed give the same array whatever the thread count; a sketch as an array,
as a PNG path and through the command line (`target/release/ridgeline synth`) give the
same terrain, and so do strokes as dicts, as a document and as a .json file; progress
comes on the calling thread, stage by stage in order, done rising; a CancelToken from
another thread, a callback returning False and Ctrl-C each stop a job quickly; the GIL
is free while a job runs; bad inputs raise TypeError, ValueError or FileNotFoundError
naming the argument (on synthetic hills: no real data needed). The real DEMs and
sketches come from ../shared/data (or $RIDGELINE_SHARED_DATA): without them the tests
that need them skip, saying so, except under CI=true, where that is an error. Pillow
reads the PNGs and tifffile the command line's TIFFs.
"""
import _thread
import json
import os
import re
import signal
import subprocess
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import ridgeline

REPO = Path(__file__).resolve().parents[2]
DATA = Path(os.environ.get("RIDGELINE_SHARED_DATA", REPO.parent / "shared" / "data"))
CLI = REPO / "target" / "release" / "ridgeline"
IN_CI = os.environ.get("CI") == "true"


def need(path: Path, what: str) -> Path:
    """`path`, or a skip (an error under CI=true) saying what is missing."""
    if not path.exists():
        message = f"{what} not found at {path}"
        if IN_CI:
            pytest.fail(message + " (CI=true: missing data is an error)")
        pytest.skip(message)
    return path


@pytest.fixture(scope="module")
def rockies_png() -> Path:
    return need(DATA / "dems" / "rockies.png", "the shared DEMs (../shared/data/dems)")


@pytest.fixture(scope="module")
def sketch_png() -> Path:
    return need(DATA / "sketches" / "small-range-512.png", "the shared sketches (../shared/data/sketches)")


@pytest.fixture(scope="module")
def crops(rockies_png):
    """Two 256 x 256 crops of the Rockies DEM in metres (its samples are feet, 90 m cells)."""
    from PIL import Image

    feet = np.asarray(Image.open(rockies_png)).astype(np.float32)
    metres = feet * np.float32(0.3048)
    return {"rockies-nw": metres[:256, :256].copy(), "rockies-se": metres[-256:, -256:].copy()}


def synthetic_dem(side=128):
    """Smooth hills in metres, for the tests that need no real DEM (bad inputs)."""
    y, x = np.mgrid[0:side, 0:side].astype(np.float32)
    return {"hills": (1000 + 300 * np.sin(x / 7) * np.cos(y / 5) + 2 * x).astype(np.float32)}


def ridge_sketch(width=128, height=96):
    """A raster sketch: one ridge across, one valley below it."""
    s = np.full((height, width), 128, np.uint8)
    s[height // 3 : height // 3 + 3, 10 : width - 10] = 255
    s[2 * height // 3 : 2 * height // 3 + 3, 16 : width - 16] = 0
    return s


STROKES = [
    {"pen": "ridge", "width": 3, "points": [[12, 30], [64, 22], [116, 34]], "elevations": [2600, 3100, 2700]},
    {"pen": "valley", "width": 4.0, "points": [[16, 72], [112, 68]], "widths": [4, 6]},
]


def run_cli(*args):
    need(CLI, "the command line (target/release/ridgeline: cargo build --release)")
    subprocess.run([str(CLI), *map(str, args)], check=True, capture_output=True, timeout=300)


def read_tiff(path):
    import tifffile

    return tifffile.imread(path)


# --- results -------------------------------------------------------------------------


def test_result_is_float32_height_by_width_in_metres(crops):
    h = ridgeline.synthesize(ridge_sketch(128, 96), crops, cell_size=90, seed=3, threads=2)
    assert isinstance(h, np.ndarray)
    assert h.dtype == np.float32 and h.shape == (96, 128)
    assert h.flags["C_CONTIGUOUS"] and np.isfinite(h).all()
    lo = min(float(np.nanmin(c)) for c in crops.values())
    hi = max(float(np.nanmax(c)) for c in crops.values())
    # within the sources' range (the default), with relief
    assert lo - 1 <= h.min() < h.max() <= hi + 1 and h.max() - h.min() > 100


def test_same_seed_same_array_whatever_the_threads(crops, rockies_png):
    a = ridgeline.synthesize(ridge_sketch(), crops, cell_size=90, seed=11, threads=1)
    b = ridgeline.synthesize(ridge_sketch(), crops, cell_size=90, seed=11, threads=2)
    c = ridgeline.synthesize(ridge_sketch(), crops, cell_size=90, seed=11)
    assert np.array_equal(a, b) and np.array_equal(a, c)
    # a whole DEM offers enough near-equal candidates for the seed's jitter to choose
    a = ridgeline.synthesize(ridge_sketch(), rockies_png, seed=10, threads=1)
    b = ridgeline.synthesize(ridge_sketch(), rockies_png, seed=10, threads=2)
    other = ridgeline.synthesize(ridge_sketch(), rockies_png, seed=11, threads=2)
    assert np.array_equal(a, b) and not np.array_equal(a, other)


def test_array_sketch_png_path_and_the_command_line_agree(sketch_png, rockies_png, tmp_path):
    from PIL import Image

    image = np.asarray(Image.open(sketch_png))
    assert image.dtype == np.uint8 and image.ndim == 2
    from_path = ridgeline.synthesize(sketch_png, rockies_png, seed=4, threads=2)
    from_str = ridgeline.synthesize(str(sketch_png), str(rockies_png), seed=4, threads=1)
    from_array = ridgeline.synthesize(image, rockies_png, seed=4, threads=2)
    # a strided view of the same codes is read as the codes, not as its memory
    strided = np.asfortranarray(image)
    from_strided = ridgeline.synthesize(strided, rockies_png, seed=4, threads=2)
    run_cli("synth", "--sketch", sketch_png, "--exemplars", rockies_png, "--out", tmp_path / "t.tif",
            "--seed", 4, "--threads", 2, "--no-cache", "--gpu", "off")
    cli = read_tiff(tmp_path / "t.tif")
    assert cli.dtype == np.float32 and cli.shape == from_path.shape == (512, 512)
    for h in (from_str, from_array, from_strided):
        assert np.array_equal(h, from_path)
    assert np.array_equal(cli, from_path)


def test_in_memory_exemplars_as_dict_list_array_and_tuples(crops):
    sketch = ridge_sketch(96, 96)
    by_dict = ridgeline.synthesize(sketch, crops, cell_size=90, seed=2, threads=2)
    with_own_cells = ridgeline.synthesize(sketch, {k: (v, 90.0) for k, v in crops.items()}, cell_size=90, seed=2,
                                          threads=2)
    assert np.array_equal(by_dict, with_own_cells)
    by_list = ridgeline.synthesize(sketch, list(crops.values()), cell_size=90, seed=2, threads=2)
    one = ridgeline.synthesize(sketch, crops["rockies-nw"], cell_size=90, seed=2, threads=2)
    as_f64 = ridgeline.synthesize(sketch, crops["rockies-nw"].astype(np.float64), cell_size=90, seed=2, threads=2)
    assert by_list.shape == one.shape == (96, 96)
    assert np.array_equal(one, as_f64)
    # resampled: 90 m heights at 45 m output cells
    finer = ridgeline.synthesize(sketch, {k: (v, 90.0) for k, v in crops.items()}, cell_size=45, seed=2, threads=2)
    assert finer.shape == (96, 96) and np.isfinite(finer).all()


def test_options_reach_the_job(crops):
    sketch = ridge_sketch(96, 96)
    ranged = ridgeline.synthesize(sketch, crops, cell_size=90, seed=5, threads=2, elevation_range=(100.0, 900.0))
    assert 99 <= ranged.min() and ranged.max() <= 901 and ranged.max() - ranged.min() > 400
    sized = ridgeline.synthesize(sketch, crops, cell_size=90, seed=5, threads=2, size=(128, 80))
    assert sized.shape == (80, 128)
    base = ridgeline.synthesize(sketch, crops, cell_size=90, seed=5, threads=2)
    for kw in ({"large_scale": False}, {"fit_sketch": False}, {"erode": 1.0}, {"patch_size": 32}):
        other = ridgeline.synthesize(sketch, crops, cell_size=90, seed=5, threads=2, **kw)
        assert other.shape == base.shape and not np.array_equal(other, base), kw
    budget = ridgeline.synthesize(sketch, crops, cell_size=90, seed=5, threads=2, max_memory="4G")
    assert np.array_equal(budget, base)


def test_a_feature_cache_does_not_change_the_terrain(crops, tmp_path):
    sketch = ridge_sketch(96, 96)
    plain = ridgeline.synthesize(sketch, crops, cell_size=90, seed=8, threads=2)
    cold = ridgeline.synthesize(sketch, crops, cell_size=90, seed=8, threads=2, cache_dir=tmp_path / "cache")
    warm = ridgeline.synthesize(sketch, crops, cell_size=90, seed=8, threads=2, cache_dir=tmp_path / "cache")
    assert any((tmp_path / "cache").iterdir())
    assert np.array_equal(plain, cold) and np.array_equal(plain, warm)


def test_an_exemplar_smaller_than_a_patch_is_skipped_with_a_warning(crops):
    small = {"tiny": crops["rockies-nw"][:40, :40].copy(), **crops}
    with pytest.warns(RuntimeWarning, match="skipped.*tiny"):
        h = ridgeline.synthesize(ridge_sketch(96, 96), small, cell_size=90, seed=1, threads=2)
    assert h.shape == (96, 96)


# --- strokes -------------------------------------------------------------------------


def test_strokes_as_dicts_document_and_json_file_agree_with_the_command_line(rockies_png, tmp_path):
    as_list = ridgeline.synthesize(STROKES, rockies_png, size=(128, 96), seed=6, threads=2)
    assert as_list.shape == (96, 128) and as_list.dtype == np.float32
    doc = {"width": 128, "height": 96, "strokes": STROKES}
    as_doc = ridgeline.synthesize(doc, rockies_png, seed=6, threads=2)
    path = tmp_path / "strokes.json"
    path.write_text(json.dumps(doc))
    as_file = ridgeline.synthesize(path, rockies_png, seed=6, threads=2)
    with_arrays = [dict(s, points=np.asarray(s["points"], np.float64)) for s in STROKES]
    as_arrays = ridgeline.synthesize(with_arrays, rockies_png, size=(128, 96), seed=6, threads=2)
    assert np.array_equal(as_list, as_doc) and np.array_equal(as_list, as_file) and np.array_equal(as_list, as_arrays)
    run_cli("synth", "--sketch", path, "--exemplars", rockies_png, "--out", tmp_path / "s.tif", "--seed", 6,
            "--threads", 2, "--no-cache", "--gpu", "off")
    assert np.array_equal(read_tiff(tmp_path / "s.tif"), as_list)


def test_an_edit_keeps_every_cell_outside_its_mask_and_extend_keeps_the_old_cells(crops):
    sketch = ridge_sketch(96, 96)
    base = ridgeline.synthesize(sketch, crops, cell_size=90, seed=2, threads=2, patch_size=32)
    mask = np.zeros((96, 96), bool)
    mask[20:70, 40:90] = True
    edited = ridgeline.synthesize(sketch, crops, cell_size=90, seed=3, threads=2, patch_size=32, base=base, mask=mask)
    assert edited.shape == base.shape
    assert np.array_equal(edited[~mask].view(np.uint32), base[~mask].view(np.uint32))
    assert (edited[mask] != base[mask]).mean() > 0.5
    # grown: a sketch of the grown size (here without strokes)
    grown = ridgeline.synthesize({"width": 112, "height": 104, "strokes": []}, crops, cell_size=90, seed=3,
                                 threads=2, patch_size=32, base=base, extend=(16, 0, 0, 8))
    assert grown.shape == (104, 112)
    assert np.array_equal(grown[:96, 16:].view(np.uint32), base.view(np.uint32))
    with pytest.raises(ValueError, match="mask: the mask is 10 x 10 cells"):
        ridgeline.synthesize(sketch, crops, cell_size=90, base=base, mask=np.ones((10, 10), bool))
    with pytest.raises(ValueError, match="give it as base="):
        ridgeline.synthesize(sketch, crops, cell_size=90, mask=mask)


def test_a_tileable_terrain_meets_itself_across_its_borders(crops):
    sketch = ridge_sketch(128, 128)
    plain = ridgeline.synthesize(sketch, crops, cell_size=90, seed=4, threads=2, patch_size=32).astype(np.float64)
    wrapped = ridgeline.synthesize(sketch, crops, cell_size=90, seed=4, threads=2, patch_size=32, wrap=True).astype(np.float64)

    def jump(t):
        inside = np.percentile(np.abs(np.diff(t, axis=1)), 95)
        return np.percentile(np.abs(t[:, 0] - t[:, -1]), 95) / inside

    assert jump(wrapped) < 1.5 < 3 < jump(plain)


def test_regions_are_made_from_their_own_exemplars(crops):
    sketch = ridge_sketch(128, 128)
    labels = np.zeros((128, 128), np.uint8)
    labels[:, 64:] = 1
    regions = {"map": labels, "blend": 16,
               "regions": [{"name": "west", "exemplars": ["rockies-nw"]}, {"name": "east", "exemplars": ["rockies-se"]}]}
    made = ridgeline.synthesize(sketch, crops, cell_size=90, seed=4, threads=2, patch_size=32, regions=regions)
    both = ridgeline.synthesize(sketch, crops, cell_size=90, seed=4, threads=2, patch_size=32)
    assert made.shape == (128, 128) and np.isfinite(made).all()
    assert not np.array_equal(made, both)
    again = ridgeline.synthesize(sketch, crops, cell_size=90, seed=4, threads=1, patch_size=32, regions=regions)
    assert np.array_equal(made, again), "the same bytes on one thread"
    regions["regions"][1]["exemplars"] = ["gobi"]
    with pytest.raises(ValueError, match="'gobi' is no exemplar"):
        ridgeline.synthesize(sketch, crops, cell_size=90, patch_size=32, regions=regions)
    regions["regions"][1]["exemplars"] = ["rockies-se"]
    labels[3, 5] = 7
    with pytest.raises(ValueError, match=r"label 7 at \(5, 3\)"):
        ridgeline.synthesize(sketch, crops, cell_size=90, patch_size=32, regions={**regions, "map": labels})


def test_strokes_shape_the_terrain(crops):
    h = ridgeline.synthesize(STROKES, crops, size=(128, 96), cell_size=90, seed=6, threads=2)
    ridge = np.mean([h[int(y), int(x)] for x, y in STROKES[0]["points"]])
    valley = np.mean([h[int(y), int(x)] for x, y in STROKES[1]["points"]])
    assert ridge > valley + 50


# --- progress, cancellation, Ctrl-C, the GIL ------------------------------------------


def test_progress_comes_on_the_calling_thread_in_stage_order_done_rising(crops):
    events = []
    caller = threading.get_ident()

    def progress(stage, done, total):
        events.append((stage, done, total, threading.get_ident()))

    h = ridgeline.synthesize(ridge_sketch(), crops, cell_size=90, seed=3, threads=2, progress=progress)
    quiet = ridgeline.synthesize(ridge_sketch(), crops, cell_size=90, seed=3, threads=2)
    assert np.array_equal(h, quiet)
    assert events and all(t == caller for *_, t in events)
    stages = [e[0] for e in events]
    assert set(stages) <= set(ridgeline.STAGES)
    order = [ridgeline.STAGES.index(s) for s in stages]
    assert order == sorted(order), "stages out of order"
    for required in ("exemplars", "feature placement", "hole filling"):
        assert required in stages
    for stage in dict.fromkeys(stages):
        mine = [(d, t) for s, d, t, _ in events if s == stage]
        dones = [d for d, _ in mine]
        assert dones == sorted(dones), f"{stage}: done fell: {mine}"
        assert all(0 <= d <= t for d, t in mine), mine
        assert mine[-1][0] == mine[-1][1], f"{stage} did not finish: {mine}"


def big_job(side=2048, **kw):
    """A job seconds long (2048 x 2048): the one the stopping tests stop."""
    return ridgeline.synthesize(ridge_sketch(256, 256), need(DATA / "dems" / "rockies.png", "the shared DEMs"),
                                size=(side, side), seed=1, threads=2, **kw)


def when_hole_filling(started: threading.Event):
    """A progress callback that sets `started` once hole filling has begun."""

    def progress(stage, done, total):
        if stage == "hole filling" and done > 0:
            started.set()

    return progress


def test_a_cancel_token_from_another_thread_stops_the_job_quickly():
    token = ridgeline.CancelToken()
    assert not token.cancelled and "False" in repr(token)
    started, cancelled_at = threading.Event(), []

    def canceller():
        if started.wait(60):
            cancelled_at.append(time.monotonic())
            token.cancel()

    t = threading.Thread(target=canceller)
    t.start()
    with pytest.raises(ridgeline.Cancelled, match="cancelled"):
        big_job(progress=when_hole_filling(started), cancel=token)
    raised_at = time.monotonic()
    t.join()
    assert cancelled_at and token.cancelled
    assert raised_at - cancelled_at[0] < 1.5, f"took {raised_at - cancelled_at[0]:.2f} s to stop"
    # a cancelled token cancels the next job at once; a new one runs
    start = time.monotonic()
    with pytest.raises(ridgeline.Cancelled):
        big_job(cancel=token)
    assert time.monotonic() - start < 1.0
    h = ridgeline.synthesize(ridge_sketch(), need(DATA / "dems" / "rockies.png", "the shared DEMs"), seed=1,
                             cancel=ridgeline.CancelToken())
    assert h.shape == (96, 128)


def test_a_progress_callback_returning_false_cancels():
    calls_after = []
    declined = []

    def progress(stage, done, total):
        if declined:
            calls_after.append(stage)
        if stage == "hole filling" and done > 0:
            declined.append(time.monotonic())
            return False
        return None

    with pytest.raises(ridgeline.Cancelled, match="progress callback returned False"):
        big_job(progress=progress)
    assert declined and not calls_after
    assert time.monotonic() - declined[0] < 1.5
    assert issubclass(ridgeline.Cancelled, Exception)


def test_an_exception_in_the_callback_stops_the_job_and_is_raised():
    class Boom(Exception):
        pass

    def progress(stage, done, total):
        if stage == "feature placement":
            raise Boom(stage)

    start = time.monotonic()
    with pytest.raises(Boom, match="feature placement"):
        big_job(progress=progress)
    assert time.monotonic() - start < 3.0


def test_ctrl_c_stops_the_job_and_raises_keyboard_interrupt():
    started = threading.Event()
    interrupted_at = []

    def interrupter():
        if started.wait(60):
            interrupted_at.append(time.monotonic())
            _thread.interrupt_main()  # what Ctrl-C does: SIGINT's handler on the main thread

    # Python's own SIGINT handler, as in a terminal: a shell starts a background job
    # (`cmd &`, nohup) with SIGINT ignored, and then interrupt_main does nothing
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    t = threading.Thread(target=interrupter)
    t.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            big_job(progress=when_hole_filling(started))
        raised_at = time.monotonic()
    finally:
        t.join()
        signal.signal(signal.SIGINT, previous)
    assert interrupted_at and raised_at - interrupted_at[0] < 1.5


def test_the_gil_is_released_while_a_job_runs(crops):
    ticks, stop = [0], threading.Event()

    def ticker():
        while not stop.is_set():
            ticks[0] += 1
            time.sleep(0.001)

    t = threading.Thread(target=ticker)
    t.start()
    try:
        before = ticks[0]
        big_job(1024)
        during = ticks[0] - before
    finally:
        stop.set()
        t.join()
    assert during > 100, f"another Python thread ran only {during} times during a job"


# --- bad inputs ----------------------------------------------------------------------


def bad(exc, match, sketch=None, exemplars=None, **kw):
    return exc, match, sketch, exemplars, kw


SK = "sketch-array"  # placeholders: replaced by a sketch and synthetic_dem() in the test
EX = "hills"

BAD = {
    "float sketch": bad(TypeError, r"sketch: .*dtype float64.*uint8", np.full((64, 64), 128.0), EX),
    "1-D sketch": bad(ValueError, r"sketch: an array of 1 dimensions.*2-D", np.full(64, 128, np.uint8), EX),
    "RGB sketch": bad(ValueError, r"sketch: an array of 3 dimensions, shape \[64, 64, 3\]",
                      np.full((64, 64, 3), 128, np.uint8), EX),
    "tiny sketch": bad(ValueError, r"sketch: a sketch of 8 x 8: each side must be within 16",
                       np.full((8, 8), 128, np.uint8), EX),
    "sketch of a number": bad(TypeError, r"sketch: give a 2-D uint8 numpy array.*not an object of type int", 42, EX),
    "missing sketch": bad(FileNotFoundError, r"sketch: .*no-such-sketch\.png: no such file", "no-such-sketch.png", EX),
    "missing exemplars": bad(FileNotFoundError, r"exemplars: .*no-such-dems: no such file or folder", SK,
                             "no-such-dems"),
    "empty exemplar dict": bad(ValueError, r"exemplars: an empty dict", SK, {}),
    "empty exemplar list": bad(ValueError, r"exemplars: an empty list", SK, []),
    "1-D exemplar": bad(ValueError, r"exemplars\[\"a\"\]: an array of 1 dimensions", SK, {"a": np.zeros(300)}),
    "complex exemplar": bad(TypeError, r"exemplars\[0\]: an array of dtype complex128",
                            SK, [np.zeros((64, 64), complex)]),
    "infinite exemplar": bad(ValueError, r"exemplars\[\"a\"\]: 1 cells are infinite",
                             SK, {"a": np.where(np.arange(64 * 64).reshape(64, 64) == 100, np.inf, 1.0)}),
    "all-void exemplar": bad(ValueError, r"every cell is NaN", SK, {"a": np.full((64, 64), np.nan, np.float32)}),
    "exemplar under a patch": bad(ValueError, r"exemplars\[\"a\"\]: 8 x 8 cells: an exemplar needs at least 16",
                                  SK, {"a": np.zeros((8, 8), np.float32)}),
    "exemplar key": bad(TypeError, r"exemplars: a key of type int", SK, {3: np.zeros((64, 64), np.float32)}),
    "exemplar cell size": bad(ValueError, r"exemplars\[\"a\"\]: cell size -5 m", SK,
                              {"a": (np.zeros((64, 64), np.float32), -5)}),
    "exemplars of a number": bad(TypeError, r"exemplars: give a path to a DEM library", SK, 7),
    "size too small": bad(ValueError, r"size: an output of 8 x 8: each side must be within 16", SK, EX, size=(8, 8)),
    "size too large": bad(ValueError, r"size: an output of 100000 x 64", SK, EX, size=(100000, 64)),
    "negative size": bad(ValueError, r"size \(-64, 64\)", SK, EX, size=(-64, 64)),
    "odd patch": bad(ValueError, r"patch size 33 must be even", SK, EX, patch_size=33),
    "negative seed": bad(ValueError, r"seed -1: give an integer from 0", SK, EX, seed=-1),
    "negative threads": bad(ValueError, r"threads -2", SK, EX, threads=-2),
    "float seed": bad(TypeError, r"seed: 'float' object cannot be interpreted as an integer", SK, EX, seed=1.5),
    "zero cell size": bad(ValueError, r"cell size 0 m", SK, EX, cell_size=0.0),
    "strong erosion": bad(ValueError, r"erosion strength 20", SK, EX, erode=20.0),
    "reversed range": bad(ValueError, r"elevation range 900:100", SK, EX, elevation_range=(900, 100)),
    "bad max_memory": bad(ValueError, r"max_memory: 'lots'", SK, EX, max_memory="lots"),
    "negative max_memory": bad(ValueError, r"max_memory: -5: give a positive number of bytes", SK, EX, max_memory=-5),
    "max_side": bad(ValueError, r"max_side 8: give 16 to 65536", SK, EX, max_side=8),
    "tiny max_memory": bad(MemoryError, r"needs about \d+ MiB .* more than the --max-memory budget", SK, EX,
                           max_memory=1000),
    "list seed": bad(TypeError, r"seed: ", SK, EX, seed=[1]),
    "size of three": bad(ValueError, r"size: expected a sequence of length 2", SK, EX, size=[64, 64, 64]),
    "size of a number": bad(TypeError, r"size: ", SK, EX, size=64),
    "int flag": bad(TypeError, r"large_scale: ", SK, EX, large_scale=1),
    "cell size of a str": bad(TypeError, r"cell_size: ", SK, EX, cell_size="90 m"),
    "cache_dir of a number": bad(TypeError, r"cache_dir: ", SK, EX, cache_dir=5),
    "not a token": bad(TypeError, r"cancel: give a ridgeline.CancelToken, not an object of type Event", SK, EX,
                       cancel=threading.Event()),
    "uncallable progress": bad(TypeError, r"progress: give a callable", SK, EX, progress=3),
    "strokes without size": bad(ValueError, r"sketch: a list of strokes needs size=", STROKES, EX),
    "unknown pen": bad(ValueError, r"sketch: stroke 0: pen 'mountain': use ridge, valley or eraser",
                       [{"pen": "mountain", "width": 3, "points": [[1, 1]]}], EX, size=(64, 64)),
    "stroke not a dict": bad(TypeError, r"sketch: stroke 1 is of type list", [STROKES[0], [1, 2]], EX,
                             size=(128, 96)),
    "misspelt key": bad(ValueError, r"sketch: stroke 0: unknown key 'elevation'",
                        [{"pen": "ridge", "width": 3, "points": [[1, 1]], "elevation": [5]}], EX, size=(64, 64)),
    "no points": bad(ValueError, r"sketch: stroke 0: no 'points'", [{"pen": "ridge", "width": 3}], EX, size=(64, 64)),
    "widths per point": bad(ValueError, r"sketch: stroke 0: 1 widths for 2 points",
                            [{"pen": "ridge", "width": 3, "points": [[1, 1], [9, 9]], "widths": [3]}], EX,
                            size=(64, 64)),
    "thick pen": bad(ValueError, r"sketch: stroke 0: pen width 100", [{"pen": "ridge", "width": 100, "points": [[1, 1]]}],
                     EX, size=(64, 64)),
    "bad points": bad(TypeError, r"sketch: stroke 0: points: give a list of \[x, y\] pairs",
                      [{"pen": "ridge", "width": 3, "points": [1, 2, 3]}], EX, size=(64, 64)),
    "document side": bad(ValueError, r"sketch: 'width' -3", {"width": -3, "height": 64, "strokes": []}, EX),
}


@pytest.mark.parametrize("case", list(BAD), ids=list(BAD))
def test_bad_inputs_raise_the_right_exception_naming_the_problem(case):
    exc, match, sketch, exemplars, kw = BAD[case]
    sketch = ridge_sketch(64, 64) if isinstance(sketch, str) and sketch == SK else sketch
    exemplars = synthetic_dem() if isinstance(exemplars, str) and exemplars == EX else exemplars
    with pytest.raises(exc, match=match):
        ridgeline.synthesize(sketch, exemplars, **{"cell_size": 90, **kw})


def test_a_bad_json_sketch_names_the_file(tmp_path):
    crops = synthetic_dem()
    p = tmp_path / "broken.json"
    p.write_text('{"width": 64, "height": 64, "strokes": [{"pen": "ridge"}]}')
    with pytest.raises(ValueError, match=r"sketch: .*broken\.json: not a vector sketch"):
        ridgeline.synthesize(p, crops, cell_size=90)
    p.write_text(json.dumps({"width": 64, "height": 64, "strokes": [{"pen": "ridge", "width": 0, "points": [[1, 1]]}]}))
    with pytest.raises(ValueError, match=r"sketch: .*broken\.json: stroke 0: pen width 0"):
        ridgeline.synthesize(p, crops, cell_size=90)


def test_a_file_that_is_not_an_image_is_refused_naming_it(tmp_path):
    crops = synthetic_dem()
    p = tmp_path / "sketch.png"
    p.write_bytes(b"not a png at all")
    with pytest.raises(ValueError, match=re.escape(str(p))):
        ridgeline.synthesize(p, crops, cell_size=90)


def test_version_and_docstrings():
    cargo = (REPO / "Cargo.toml").read_text()
    version = re.search(r'\[workspace\.package\][^\[]*?version = "([^"]+)"', cargo).group(1)
    assert ridgeline.__version__ == version
    assert "float32" in ridgeline.synthesize.__doc__ and "exemplars" in ridgeline.synthesize.__doc__
    assert ridgeline.__doc__ and ridgeline.CancelToken.__doc__ and ridgeline.Cancelled.__doc__
    assert ridgeline.STAGES[0] == "exemplars" and "hole filling" in ridgeline.STAGES
