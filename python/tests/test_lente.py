"""The Python package: loading, rendering, images, errors, progress,
interrupts and the GIL."""

import os
import pathlib
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import lente


def test_render_returns_a_float32_image_that_jupyter_shows(cbox):
    scene = lente.load(cbox, res=32)
    assert (scene.width, scene.height) == (32, 32)
    image = scene.render(spp=8, seed=1, progress=False)
    assert isinstance(image, np.ndarray) and isinstance(image, lente.Image)
    assert image.shape == (32, 32, 3) and image.dtype == np.float32
    assert np.all(np.isfinite(image)) and image.mean() > 0.05
    assert image.spp == 8 and image.seconds > 0
    png = image._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    # numpy operations give numpy arrays back.
    assert float((image * 2).mean()) == pytest.approx(2 * float(image.mean()))


def test_renders_are_deterministic_and_independent_of_threads(cbox):
    scene = lente.load(cbox, res=24)
    a = scene.render(spp=4, seed=3, threads=1, progress=False)
    b = scene.render(spp=4, seed=3, threads=2, progress=False)
    c = scene.render(spp=4, seed=4, threads=2, progress=False)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)


def test_sample_slices_merge_into_the_whole_render(cbox):
    scene = lente.load(cbox, res=24)
    whole = scene.render(spp=12, seed=0, progress=False)
    parts = [
        scene.render_film(samples=(0, 5), seed=0),
        scene.render_film(samples=(5, 12), seed=0),
    ]
    merged = lente.merge(parts)
    assert merged.spp == 12
    # Equal up to the order of float additions (relative 1e-5).
    np.testing.assert_allclose(merged, whole, rtol=1e-5, atol=1e-7)
    with pytest.raises(ValueError):
        scene.render(spp=4, samples=(0, 4))
    with pytest.raises(ValueError):
        scene.render(samples=(4, 4))


def test_aovs_come_with_the_image_and_leave_it_unchanged(cbox):
    scene = lente.load(cbox, res=16)
    plain = scene.render(spp=4, progress=False)
    image = scene.render(spp=4, aovs=["albedo", "nn:sh_normal"], progress=False)
    assert np.array_equal(plain, image)
    assert sorted(image.aovs) == ["albedo.B", "albedo.G", "albedo.R", "nn.X", "nn.Y", "nn.Z"]
    assert image.aovs["nn.Z"].shape == (16, 16)
    with pytest.raises(ValueError, match="unknown AOV"):
        scene.render(spp=1, aovs="shininess", progress=False)


def test_params_errors_and_warnings(cbox, tmp_path):
    assert lente.load(cbox, res=40).width == 40
    bad = tmp_path / "bad.xml"
    bad.write_text('<scene version="3.0.0">\n  <shape type="sphere">\n    <float name="radius" value="x"/>\n  </shape>\n</scene>\n')
    with pytest.raises(lente.SceneError, match=r"bad\.xml:3:"):
        lente.load(bad)
    with pytest.raises(lente.SceneError, match="cannot read"):
        lente.load(tmp_path / "missing.xml")
    warned = tmp_path / "warned.xml"
    warned.write_text(
        '<scene version="3.0.0"><integrator type="prb"/>'
        '<shape type="sphere"><float name="radius" value="1"/></shape></scene>\n'
    )
    with pytest.warns(lente.SceneWarning, match="path tracer"):
        lente.load(warned)


def test_images_write_and_read_back(cbox, tmp_path):
    image = lente.load(cbox, res=16).render(spp=2, progress=False)
    lente.write(tmp_path / "a.exr", image)
    assert np.array_equal(lente.read(tmp_path / "a.exr"), image)
    image.write(tmp_path / "a.png")
    assert lente.read(tmp_path / "a.png").shape == (16, 16, 3)
    lente.write(tmp_path / "grey.pfm", image[..., 0])
    with pytest.raises(ValueError, match="H x W x 3"):
        lente.write(tmp_path / "x.exr", np.zeros((2, 2, 5), np.float32))
    with pytest.raises(lente.RenderError):
        lente.write(tmp_path / "x.tiff", image)


def test_progress_callback_sees_every_pass(cbox):
    seen = []
    lente.load(cbox, res=16).render(spp=24, progress=lambda done, total: seen.append((done, total)))
    assert seen and seen[-1] == (24, 24)
    assert all(a[0] < b[0] for a, b in zip(seen, seen[1:]))


def test_the_gil_is_released_while_rendering(cbox):
    scene = lente.load(cbox, res=64)
    ticks = 0
    stop = threading.Event()

    def count():
        nonlocal ticks
        while not stop.is_set():
            ticks += 1
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    start = time.time()
    scene.render(spp=64, progress=False)
    took = time.time() - start
    stop.set()
    t.join()
    # A thread holding no GIL would tick about 1000 times a second.
    assert ticks > 100 * took, (ticks, took)


def test_ctrl_c_stops_a_render_with_keyboard_interrupt(cbox):
    script = textwrap.dedent(
        f"""
        import signal, sys, time, lente
        # A process started in the background by a non-interactive shell
        # inherits SIGINT ignored, and Python then keeps it ignored: make
        # Ctrl-C raise KeyboardInterrupt whatever this process inherited.
        signal.signal(signal.SIGINT, signal.default_int_handler)
        scene = lente.load({cbox!r}, res=64)
        print("rendering", flush=True)
        start = time.time()
        try:
            scene.render(spp=1000000, progress=False)
        except KeyboardInterrupt:
            print(f"interrupted after {{time.time() - start:.2f}} s", flush=True)
            sys.exit(3)
        """
    )
    child = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True)
    assert child.stdout.readline().strip() == "rendering"
    time.sleep(1.0)
    child.send_signal(signal.SIGINT)
    try:
        out, _ = child.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        # Do not leave a million-spp render running after the failure.
        child.kill()
        raise
    assert child.returncode == 3, out
    assert out.startswith("interrupted after")


def test_strips_stack_into_the_whole_image_bit_for_bit(cbox):
    scene = lente.load(cbox, res=48)
    whole = scene.render(spp=4, seed=2, aovs="albedo", progress=False)
    strips = [
        scene.render(spp=4, seed=2, aovs="albedo", rows=r, progress=False)
        for r in [(0, 7), (7, 40), (40, 48)]
    ]
    assert [s.shape[0] for s in strips] == [7, 33, 8]
    stacked = lente.stack(strips)
    assert np.array_equal(stacked, whole)
    assert np.array_equal(stacked.aovs["albedo.G"], whole.aovs["albedo.G"])
    with pytest.raises(ValueError, match="rows"):
        scene.render(spp=1, rows=(10, 60), progress=False)
