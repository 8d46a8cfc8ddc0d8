"""Figures and movies of trajectories (matplotlib, Agg backend; MP4 via imageio-ffmpeg).

The filament is drawn as a thick polyline coloured by local curvature, with the motor axis
(e_z through the anchor) as a dashed line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._plot import pyplot


def curvature(positions: np.ndarray) -> np.ndarray:
    """Discrete curvature |Δt|/h at the inner beads of one configuration (n+1, 3)."""
    b = np.diff(positions, axis=0)
    h = np.linalg.norm(b, axis=1)
    t = b / h[:, None]
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", t[:-1], t[1:]), -1, 1))
    k = ang / (0.5 * (h[:-1] + h[1:]))
    return np.concatenate([[k[0]], k, [k[-1]]])


def _draw(ax, pos, lim, title=None, cmax=3.0):
    from matplotlib import cm
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

    ax.cla()
    k = curvature(pos)
    segs = np.stack([pos[:-1], pos[1:]], axis=1)
    ax.add_collection3d(Line3DCollection(segs, colors=cm.viridis(np.clip(k[:-1] / cmax, 0, 1)),
                                         linewidths=3))
    ax.plot([0, 0], [0, 0], [lim[2][0], lim[2][1]], "k--", lw=0.8)
    ax.scatter(*pos[0], color="red", s=25)
    ax.set_xlim(*lim[0])
    ax.set_ylim(*lim[1])
    ax.set_zlim(*lim[2])
    ax.set_xlabel("x [µm]")
    ax.set_ylabel("y [µm]")
    ax.set_zlabel("z [µm]")
    try:
        ax.set_box_aspect((lim[0][1] - lim[0][0], lim[1][1] - lim[1][0], lim[2][1] - lim[2][0]))
    except AttributeError:  # pragma: no cover - old matplotlib
        pass
    if title:
        ax.set_title(title, fontsize=9)


def _limits(positions: np.ndarray):
    lo, hi = positions.reshape(-1, 3).min(0), positions.reshape(-1, 3).max(0)
    half = max(0.6 * (hi[:2] - lo[:2]).max(), 1.0)
    cx, cy = 0.5 * (lo[:2] + hi[:2])
    return [(cx - half, cx + half), (cy - half, cy + half), (lo[2] - 0.3, max(hi[2], 0) + 0.3)]


def movie(t: np.ndarray, positions: np.ndarray, path: str | Path, fps: int = 20,
          max_frames: int = 200, title: str = "") -> int:
    """Write an MP4 of the trajectory; returns the number of frames written."""
    import imageio.v2 as imageio

    plt = pyplot()
    idx = np.linspace(0, len(t) - 1, min(max_frames, len(t))).round().astype(int)
    lim = _limits(positions[idx])
    fig = plt.figure(figsize=(4.8, 6.4), dpi=80)
    ax = fig.add_subplot(projection="3d")
    path = Path(path)
    from .io import atomic_path

    with atomic_path(path) as tmp:
        with imageio.get_writer(str(tmp), format="FFMPEG", fps=fps, codec="libx264",
                                macro_block_size=8, pixelformat="yuv420p") as w:
            for i in idx:
                _draw(ax, positions[i], lim, f"{title}  t = {t[i] * 1e3:.1f} ms")
                fig.canvas.draw()
                w.append_data(np.asarray(fig.canvas.buffer_rgba())[..., :3])
    plt.close(fig)
    return len(idx)


def snapshots(t: np.ndarray, positions: np.ndarray, out_dir: str | Path, count: int = 4,
              title: str = "") -> list[Path]:
    """PNG snapshots at ``count`` evenly spaced times."""
    plt = pyplot()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    idx = np.linspace(0, len(t) - 1, count).round().astype(int)
    lim = _limits(positions[idx])
    files = []
    for i in idx:
        fig = plt.figure(figsize=(4.8, 6.4), dpi=100)
        ax = fig.add_subplot(projection="3d")
        _draw(ax, positions[i], lim, f"{title}  t = {t[i] * 1e3:.1f} ms")
        p = out_dir / f"snapshot_{i:05d}.png"
        fig.savefig(p)
        plt.close(fig)
        files.append(p)
    return files


def time_series_figure(runs: dict, path: str | Path) -> None:
    """Thrust and end-to-end distance versus time for several labelled trajectories."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(6.4, 5.6), sharex=True)
    for label, tr in runs.items():
        axes[0].plot(tr.t, tr.thrust, label=label)
        r = np.linalg.norm(tr.positions[:, -1] - tr.positions[:, 0], axis=-1)
        axes[1].plot(tr.t, r, label=label)
    axes[0].set_ylabel("thrust F [pN]")
    axes[1].set_ylabel("end-to-end r [µm]")
    axes[1].set_xlabel("t [s]")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    path = Path(path)
    for ext in (".png", ".pdf"):
        fig.savefig(path.with_suffix(ext))
    plt.close(fig)
