"""Movies and posters: HD size, frame count, decodable, not blank, frames differ; the
co-rotating view and the helix axis; ``flagellum render`` windows and ``flagellum demo``."""

import json

import numpy as np
import pytest
from conftest import assert_one_line_error

from flagellum import Filament, Params
from flagellum.cli import run
from flagellum.helix import discrete_helix
from flagellum.motor import Motor
from flagellum.simulator import Simulator
from flagellum.viz import SIZES, beads_per_turn, corotate, frame_spacing, helix_axis


@pytest.fixture(scope="module")
def run_file(tmp_path_factory):
    """A tiny simulation (L = 2 µm, 0.005 s) written to HDF5: 11 beads, 26 records."""
    path = tmp_path_factory.mktemp("run") / "run.h5"
    Simulator(Params(Filament(length=2.0)), Motor(0.5)).run(0.005, save_every=2e-4, output=path,
                                                            progress=False)
    return path


def _read_movie(path):
    """(frame count, (height, width), first frame, last frame) of an MP4, read back by imageio."""
    import imageio.v2 as imageio

    reader = imageio.get_reader(str(path), format="FFMPEG")
    n, first, last = 0, None, None
    for frame in reader:
        first = frame if first is None else first
        last, n = frame, n + 1
    reader.close()
    return n, first.shape[:2], first, last


def _check_poster(png, size):
    import imageio.v2 as imageio

    img = np.asarray(imageio.imread(str(png)), float) / 255
    assert img.shape[:2] == size[::-1]
    assert img[..., :3].mean(-1).var() > 2e-3  # not blank


@pytest.mark.parametrize("view,size", [("lab", "720p"), ("corotating", "1080p")])
def test_render_movie_is_hd_decodable_and_moves(run_file, tmp_path, capsys, view, size):
    mp4 = tmp_path / "m.mp4"
    frames = 12 if size == "720p" else 4
    assert run(["render", str(run_file), "--movie", str(mp4), "--frames", str(frames),
                "--view", view, "--size", size, "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["frames"] == frames and out["view"] == view and out["size"] == size
    assert out["poster"] == str(tmp_path / "m.png")
    n, shape, first, last = _read_movie(mp4)
    assert n == frames and shape == SIZES[size][::-1]
    assert np.abs(first.astype(float) - last).mean() > 0.05  # the filament and the time move
    _check_poster(tmp_path / "m.png", SIZES[size])


def test_render_window_and_snapshots(run_file, tmp_path, capsys):
    snaps = tmp_path / "s"
    assert run(["render", str(run_file), "--snapshots", str(snaps), "--count", "2",
                "--start", "0.002", "--end", "0.004", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert len(out["snapshots"]) == 2 and "movie" not in out
    for p in out["snapshots"]:
        _check_poster(p, SIZES["720p"])


def test_render_rejects_bad_views_and_windows(run_file, tmp_path, capsys):
    for extra, name in ((["--start", "1", "--end", "2"], "start"), (["--end", "nan"], "end"),
                        (["--view", "top"], "view"), (["--size", "4k"], "size")):
        code = run(["render", str(run_file), "--movie", str(tmp_path / "m.mp4"), *extra])
        assert_one_line_error(code, capsys.readouterr().err, name)
    assert not list(tmp_path.iterdir())


def test_corotate_removes_a_rigid_rotation():
    dh = discrete_helix(Filament(length=4.0))
    rng = np.random.default_rng(1)
    rots = [np.linalg.qr(rng.normal(size=(3, 3)))[0] for _ in range(4)]
    rots = [q * np.sign(np.linalg.det(q)) for q in rots]  # proper rotations
    frames = np.stack([dh.positions @ q.T for q in [np.eye(3)] + rots])
    out, axes = corotate(frames)
    np.testing.assert_allclose(out, np.broadcast_to(frames[0], out.shape), atol=1e-10)
    for q, a in zip(rots, axes[1:]):
        np.testing.assert_allclose(a, q.T @ [0, 0, 1], atol=1e-10)  # e_z as seen in that frame


def test_helix_axis_of_the_stress_free_helix():
    f = Filament()
    dh = discrete_helix(f, origin="axis")
    turn = beads_per_turn(dh.positions)
    per_turn = 2 * np.pi / np.hypot(f.kappa0, f.tau0) / f.segment_length  # ≈ 12.7 bonds
    assert abs(turn - per_turn) <= 1
    axis = helix_axis(dh.positions, turn)
    assert np.abs(axis[:, :2]).max() < 0.15 * dh.radius  # on the z axis, up to a part of a turn
    assert beads_per_turn(np.outer(np.arange(20.0), [0, 0, 1])) is None  # a straight rod


def test_frame_spacing_states_frames_per_revolution():
    t = np.arange(10) * 1e-3
    assert "≈ 6.3 per motor revolution" in frame_spacing(t, np.arange(10), np.full(10, 1000.0))
    assert "aliased" in frame_spacing(t, np.arange(0, 10, 3), np.full(10, 1000.0))


def test_demo_movies_and_posters(tmp_path):
    from flagellum.demo import run_demo

    res = run_demo(tmp_path, progress=False, runs=(("short", 1.0, 0.01, 0.01 / 400),), frames=6)
    assert set(res) == {"short"}
    n, shape, first, last = _read_movie(tmp_path / "short.mp4")
    assert n == 6 and shape == (720, 1280)
    assert np.abs(first.astype(float) - last).mean() > 0.05
    _check_poster(tmp_path / "short.png", SIZES["720p"])
