"""Figures and movies of trajectories (matplotlib, Agg backend; MP4 via imageio-ffmpeg).

A movie frame shows the filament in 3D as a thick polyline coloured by local curvature
(colour bar in 1/µm), the motor axis e_z through the anchor as a dashed line, and, where
the thrust is given, the thrust F(t) of Sec. 3.1 with a cursor at the frame's time. The
motor axis runs horizontally, so the long filament fills a 16:9 frame.

A polymorphic run (``polymorph``, :mod:`flagellum.rod.polymorph`) colours each segment by
its form instead (:data:`FORM_COLORS`, with a legend of the form names); a cell body
(``body``: the record's ``body_position``, ``body_axis`` and the body's semi-axes) is drawn
as the outline of its spheroid (lab view).

Two views (``view``):

- ``"lab"``: the lab frame. The motor turns the filament at ω ≈ 660–1000 rad/s (a
  revolution every 6–10 ms), so the rotation only reads when the frames lie a fraction
  of a revolution apart; the title states the frame spacing in frames per revolution.
- ``"corotating"``: each configuration is turned about the anchor by the rigid rotation
  that best maps it onto the previous frame (Kabsch), which removes the fast rotation
  about the helix axis and the precession about e_z. What remains is the change of shape
  (relaxation, buckling); the motor axis is drawn as it appears in that frame. The coil
  still turns about its own (bent) axis, which no rigid rotation removes, so the local
  helix axis (the beads averaged over one turn) is drawn as well: it carries the slow
  buckled shape.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._plot import pyplot
from .errors import ParameterError

#: movie sizes: name → (width, height) [pixels]
SIZES = {"720p": (1280, 720), "1080p": (1920, 1080)}
#: the views of :func:`movie`
VIEWS = ("lab", "corotating")
#: top of the curvature colour scale [1/µm] (the paper's helix has κ0 = 1.3/µm)
CURVATURE_MAX = 3.0
#: colour of each polymorphic form, in the order of the run's forms (normal first)
FORM_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728")
_DPI = 100  # 720p; 1080p scales the dpi, so the layout and the font sizes stay the same


def curvature(positions: np.ndarray) -> np.ndarray:
    """Discrete curvature |Δt|/h at the inner beads of one configuration (n+1, 3)."""
    b = np.diff(positions, axis=0)
    h = np.linalg.norm(b, axis=1)
    t = b / h[:, None]
    ang = np.arccos(np.clip(np.einsum("ij,ij->i", t[:-1], t[1:]), -1, 1))
    k = ang / (0.5 * (h[:-1] + h[1:]))
    return np.concatenate([[k[0]], k, [k[-1]]])


def corotate(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Positions (n_t, N+1, 3) relative to the anchor with the rigid rotation removed.

    Frame k is turned by the rotation R_k that best maps it onto the turned frame k−1
    (least squares over the beads, Kabsch); frame 0 stays as it is. Returns the turned
    positions and the motor axis e_z as seen in that frame, (n_t, 3).
    """
    x = np.asarray(positions, float) - np.asarray(positions, float)[:, :1]
    out, axis = np.empty_like(x), np.empty((len(x), 3))
    out[0], axis[0] = x[0], (0.0, 0.0, 1.0)
    for k in range(1, len(x)):
        u, _, vt = np.linalg.svd(x[k].T @ out[k - 1])
        d = np.sign(np.linalg.det(u @ vt)) or 1.0
        # lab → co-rotating frame for row vectors (x[k] @ rot ≈ out[k−1]), reflection excluded
        rot = u @ np.diag([1.0, 1.0, d]) @ vt
        out[k], axis[k] = x[k] @ rot, rot[2]
    return out, axis


def beads_per_turn(positions: np.ndarray) -> int | None:
    """Bonds per helical turn of one configuration (N+1, 3): the first lag at which the
    bond tangents turn back to their start (maximum of their autocorrelation); None for a
    filament that does not coil."""
    b = np.diff(positions, axis=0)
    t = b / np.linalg.norm(b, axis=1)[:, None]
    c = np.array([np.mean(np.einsum("ij,ij->i", t[:-lag], t[lag:])) for lag in range(1, len(t) // 2)])
    peaks = [i for i in range(1, len(c) - 1) if c[i - 1] < c[i] >= c[i + 1] and c[i] > 0.3]
    return peaks[0] + 1 if peaks else None


def helix_axis(positions: np.ndarray, turn: int) -> np.ndarray:
    """The local helix axis of one configuration (N+1, 3): the means of ``turn`` consecutive
    beads (one period of the coil, :func:`beads_per_turn`), (N+2−turn, 3). It stays put
    while the coil turns about it."""
    c = np.cumsum(np.concatenate([np.zeros((1, 3)), positions]), axis=0)
    return (c[turn:] - c[:-turn]) / turn


def frame_spacing(t: np.ndarray, idx: np.ndarray, motor_speed: np.ndarray | None) -> str:
    """The lab-frame spacing of the frames ``idx`` in words (frames per motor revolution)."""
    if len(idx) < 2:
        return "lab frame"
    dt = float(np.median(np.diff(t[idx])))
    text = f"lab frame, a frame every {dt * 1e3:.3g} ms"
    # the median skips the start-up transient of the motor speed
    omega = float(np.median(np.abs(motor_speed[idx]))) if motor_speed is not None else 0.0
    if omega > 0 and dt > 0:
        per_rev = 2 * np.pi / (omega * dt)
        if per_rev >= 1:
            text += f" ≈ {per_rev:.2g} per motor revolution"
        else:
            text += f" ≈ {1 / per_rev:.2g} motor revolutions"
        if per_rev < 3:
            text += " (rotation aliased)"
    return text


class _Frame:
    """One figure (3D filament, colour bar, thrust trace) whose artists are updated per frame."""

    def __init__(self, lim, size="720p", t=None, thrust=None, axis_label="motor axis",
                 turn=None, forms=None, body_shape=None):
        from matplotlib import cm, colors
        from matplotlib.ticker import MaxNLocator
        from mpl_toolkits.mplot3d.art3d import Line3DCollection

        plt = pyplot()
        w, h = SIZES[size]
        self.dpi = _DPI * h / 720
        self.fig = fig = plt.figure(figsize=(w / self.dpi, h / self.dpi), dpi=self.dpi)
        with_trace = thrust is not None and len(thrust) > 1
        self.ax = ax = fig.add_axes([-0.03, 0.03, 0.73 if with_trace else 0.85, 0.87],
                                    projection="3d")
        self.norm = colors.Normalize(0.0, CURVATURE_MAX)
        self.cmap = cm.viridis
        # display axes (X, Y, Z) = lab (z, x, y): the motor axis runs horizontally
        self.lines = Line3DCollection([np.zeros((2, 3))], linewidths=4, capstyle="round")
        ax.add_collection3d(self.lines, autolim=False)
        (self.axis_line,) = ax.plot([], [], [], "k--", lw=1.0, label="motor axis")
        self.turn, self.helix_axis = turn, None
        if turn:
            (self.helix_axis,) = ax.plot([], [], [], "-", color="darkorange", lw=2.5,
                                         label="helix axis (beads averaged over one turn)")
        ax.scatter([0], [0], [0], color="red", s=40, depthshade=False, label="anchor (motor)")
        self.forms, self.body_shape, self.body_lines = forms, body_shape, None
        if body_shape is not None:
            self.body_lines = Line3DCollection([np.zeros((2, 3))], linewidths=1.2, colors="0.35")
            ax.add_collection3d(self.body_lines, autolim=False)
            ax.plot([], [], [], "-", color="0.35", lw=1.2, label="cell body")
        if forms:
            from matplotlib.patches import Patch

            self.form_handles = [Patch(color=FORM_COLORS[i % len(FORM_COLORS)], label=f)
                                 for i, f in enumerate(forms)]
        ax.set_xlim(*lim[2])
        ax.set_ylim(*lim[0])
        ax.set_zlim(*lim[1])
        box = [b - a for a, b in (lim[2], lim[0], lim[1])]
        # true proportions; a wide (buckled) box is drawn smaller so that its labels stay inside
        ax.set_box_aspect(box, zoom=min(1.35, 0.95 / (0.35 + max(box[1:]) / box[0])))
        ax.view_init(elev=25, azim=-60)
        ax.set_xlabel(f"z [µm]  ({axis_label})", fontsize=12, labelpad=10)
        ax.set_ylabel("x [µm]", fontsize=12, labelpad=8)
        ax.set_zlabel("y [µm]", fontsize=12, labelpad=6)
        for a in (ax.yaxis, ax.zaxis):  # the short axes: few ticks, so that they do not smear
            a.set_major_locator(MaxNLocator(3))
        ax.tick_params(labelsize=10, pad=2)
        ax.legend(loc="upper left", bbox_to_anchor=(0.06, 0.86), fontsize=11, frameon=False)
        if forms:  # the forms' legend where the curvature colour bar would be
            fig.legend(handles=self.form_handles, title="polymorphic form", fontsize=11,
                       title_fontsize=12, frameon=False,
                       loc="lower right" if with_trace else "center right",
                       bbox_to_anchor=(0.98, 0.08) if with_trace else (0.98, 0.5))
        else:
            if with_trace:
                cax = fig.add_axes([0.77, 0.26, 0.21, 0.025])
            else:
                cax = fig.add_axes([0.9, 0.2, 0.015, 0.55])
            cb = fig.colorbar(cm.ScalarMappable(self.norm, self.cmap), cax=cax, extend="max",
                              orientation="horizontal" if with_trace else "vertical")
            cb.set_label("curvature κ [1/µm]", fontsize=12)
            cb.ax.tick_params(labelsize=10)
        self.cursor = None
        if with_trace:
            tax = fig.add_axes([0.8, 0.45, 0.18, 0.38])
            tax.plot(np.asarray(t) * 1e3, thrust, color="0.3", lw=1.0)
            (self.cursor,) = tax.plot([], [], "o", color="crimson", ms=6)
            self.cursor_line = tax.axvline(t[0] * 1e3, color="crimson", lw=0.8)
            tax.set_xlabel("t [ms]", fontsize=11)
            tax.set_ylabel("thrust F [pN]", fontsize=11)
            tax.tick_params(labelsize=9)
            tax.grid(alpha=0.3)
            tax.set_title("thrust on the anchor", fontsize=11)
        self.title = fig.text(0.02, 0.965, "", fontsize=15, va="top", weight="bold")
        self.subtitle = fig.text(0.02, 0.915, "", fontsize=12, va="top")

    def draw(self, pos, axis_dir, title, subtitle, t=None, thrust=None, form=None, body=None):
        """Show one configuration (N+1, 3) [µm, relative to the anchor] and its texts;
        ``form`` (N,) the form index of each segment, ``body`` (centre relative to the
        anchor, axis) of the cell body."""
        p = pos[:, [2, 0, 1]]
        self.lines.set_segments(np.stack([p[:-1], p[1:]], axis=1))
        if form is not None:
            self.lines.set_color([FORM_COLORS[int(f) % len(FORM_COLORS)] for f in form])
        else:
            k = curvature(pos)
            self.lines.set_color(self.cmap(self.norm(0.5 * (k[:-1] + k[1:]))))
        if self.body_lines is not None and body is not None:
            curves = body_outline(body[0], body[1], *self.body_shape)[:, :, [2, 0, 1]]
            self.body_lines.set_segments(np.concatenate([np.stack([c[:-1], c[1:]], axis=1)
                                                         for c in curves]))
        a = np.asarray(axis_dir)[[2, 0, 1]]
        ends = np.array(self.ax.get_xlim()) / max(a[0], 0.2)  # across the box, through the anchor
        self.axis_line.set_data_3d(*(np.outer(ends, a).T))
        if self.helix_axis is not None:
            self.helix_axis.set_data_3d(*helix_axis(p, self.turn).T)
        self.title.set_text(title)
        self.title.set_fontsize(15 if len(title) <= 100 else 12)
        self.subtitle.set_text(subtitle)
        if self.cursor is not None and t is not None:
            self.cursor.set_data([t * 1e3], [thrust])
            self.cursor_line.set_xdata([t * 1e3, t * 1e3])
        self.fig.canvas.draw()
        return np.asarray(self.fig.canvas.buffer_rgba())[..., :3]

    def close(self):
        pyplot().close(self.fig)


def body_outline(centre, axis, radius: float, aspect: float, points: int = 48) -> np.ndarray:
    """(4, points, 3) curves on a prolate spheroid of equatorial semi-axis ``radius`` and polar
    semi-axis ``aspect``·``radius`` about the unit ``axis``: two meridians, the equator and a
    circle of latitude near the rear pole (where the motor sits)."""
    e = np.asarray(axis, float) / np.linalg.norm(axis)
    e1 = np.cross(e, [1.0, 0.0, 0.0] if abs(e[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(e, e1)
    u = np.linspace(0.0, 2 * np.pi, points)[:, None]
    a, c = radius, aspect * radius
    lat = -0.8  # cos of the rear circle's polar angle
    curves = [c * np.cos(u) * e + a * np.sin(u) * e1, c * np.cos(u) * e + a * np.sin(u) * e2,
              a * (np.cos(u) * e1 + np.sin(u) * e2),
              c * lat * e + a * np.sqrt(1 - lat * lat) * (np.cos(u) * e1 + np.sin(u) * e2)]
    return np.asarray(centre, float) + np.stack(curves)


def _limits(positions: np.ndarray, extra: np.ndarray | None = None):
    """Axis ranges (x, y, z) [µm] holding every configuration, the anchor and the motor axis
    (and the points ``extra`` (…, 3), e.g. a body's outline)."""
    flat = np.concatenate([positions.reshape(-1, 3), np.zeros((1, 3))]
                          + ([np.asarray(extra).reshape(-1, 3)] if extra is not None else []))
    lo, hi = flat.min(0), flat.max(0)
    half = max(0.55 * (hi[:2] - lo[:2]).max(), 1.0)
    cx, cy = 0.5 * (lo[:2] + hi[:2])
    return [(cx - half, cx + half), (cy - half, cy + half), (min(lo[2], 0) - 0.3, hi[2] + 0.3)]


def _check(view, size):
    if view not in VIEWS:
        raise ParameterError("view", view, "one of " + ", ".join(VIEWS))
    if size not in SIZES:
        raise ParameterError("size", size, "one of " + ", ".join(SIZES))


def _frames(t, positions, idx, title, view, size, thrust, motor_speed, trace, spacing=True,
            polymorph=None, forms=None, body=None):
    """Yield the RGB image (height, width, 3) of each record in ``idx``.

    ``trace`` is the slice of records the thrust trace shows; ``spacing``: the lab view's
    title states the frame spacing (for a movie, not for snapshots). ``polymorph`` (n_t, N)
    and ``forms``: colour the segments by form; ``body``: draw the cell body (lab view).
    """
    _check(view, size)
    from .rod.polymorph import forms_of

    form = None
    if polymorph is not None:
        form = forms_of(np.asarray(polymorph, float)[idx])
        if forms is None:
            forms = tuple(str(i) for i in range(int(form.max()) + 1))
    pos = np.asarray(positions, float)[idx]
    cell = None
    if body is not None and view == "lab":  # the centre relative to the anchor (bead 0)
        cell = (np.asarray(body["position"], float)[idx] - pos[:, 0], np.asarray(body["axis"], float)[idx])
    if view == "corotating":
        pos, axes = corotate(pos)
        how, axis_label = "co-rotating view (rigid rotation about the anchor removed)", \
            "motor axis at the first frame"
    else:
        pos, axes = pos - pos[:, :1], np.tile([0.0, 0.0, 1.0], (len(idx), 1))
        how = frame_spacing(t, idx, motor_speed) if spacing else "lab frame"
        axis_label = "motor axis"
    turn = beads_per_turn(pos[0]) if view == "corotating" else None
    shape = (float(body["radius"]), float(body["aspect"])) if cell is not None else None
    extra = None
    if cell is not None:  # the body's outline in every frame bounds the box
        extra = np.concatenate([body_outline(cell[0][j], cell[1][j], *shape).reshape(-1, 3)
                                for j in range(len(idx))])
    frame = _Frame(_limits(pos, extra), size, t[trace], None if thrust is None else thrust[trace],
                   axis_label, turn, forms if form is not None else None, shape)
    head = f"{title} · {how}" if title else how
    try:
        for j, i in enumerate(idx):
            yield frame.draw(pos[j], axes[j], head, f"t = {t[i] * 1e3:.1f} ms", t[i],
                             None if thrust is None else float(thrust[i]),
                             None if form is None else form[j],
                             None if cell is None else (cell[0][j], cell[1][j]))
    finally:
        frame.close()


def movie(t: np.ndarray, positions: np.ndarray, path: str | Path, fps: int = 20,
          max_frames: int = 200, title: str = "", *, view: str = "lab", size: str = "720p",
          thrust: np.ndarray | None = None, motor_speed: np.ndarray | None = None,
          poster: bool = True, polymorph: np.ndarray | None = None, forms=None,
          body: dict | None = None) -> int:
    """Write an MP4 (H.264) of the trajectory; returns the number of frames written.

    ``max_frames`` frames are taken evenly over the records (all of them when there are
    fewer). ``title`` (e.g. torque and regime) heads every frame, followed by the view
    and the time. ``size`` is a key of :data:`SIZES`, ``view`` one of :data:`VIEWS`.
    With ``thrust`` (per record) a thrust trace with a cursor is drawn; ``motor_speed``
    (per record) lets the lab view state the frames per revolution. With ``poster`` the
    last frame is also written as a PNG next to the movie (same name, ``.png``).
    ``polymorph`` (per record, (n_t, N) order parameters) with the names of its ``forms``
    colours the segments by form; ``body`` (``position`` and ``axis`` per record, the
    semi-axis ``radius`` and ``aspect``) draws the cell body in the lab view.
    """
    import imageio.v2 as imageio

    from .io import atomic_path

    _check(view, size)
    t = np.asarray(t, float)
    thrust = None if thrust is None else np.asarray(thrust, float)
    idx = np.linspace(0, len(t) - 1, min(max_frames, len(t))).round().astype(int)
    path = Path(path)
    last = None
    with atomic_path(path) as tmp:
        with imageio.get_writer(str(tmp), format="FFMPEG", fps=fps, codec="libx264",
                                macro_block_size=8, pixelformat="yuv420p", quality=8) as w:
            for last in _frames(t, positions, idx, title, view, size, thrust, motor_speed,
                                slice(idx[0], idx[-1] + 1), polymorph=polymorph, forms=forms,
                                body=body):
                w.append_data(last)
    if poster and last is not None:
        with atomic_path(path.with_suffix(".png")) as tmp:
            imageio.imwrite(str(tmp), last, format="PNG")
    return len(idx)


def snapshots(t: np.ndarray, positions: np.ndarray, out_dir: str | Path, count: int = 4,
              title: str = "", *, view: str = "lab", size: str = "720p",
              thrust: np.ndarray | None = None, motor_speed: np.ndarray | None = None,
              first_record: int = 0, polymorph: np.ndarray | None = None, forms=None,
              body: dict | None = None) -> list[Path]:
    """PNG snapshots at ``count`` evenly spaced times, laid out as the movie frames
    (``polymorph``, ``forms``, ``body``: as for :func:`movie`).

    The files are named ``snapshot_KKKKK.png`` by record number, ``first_record`` being the
    number of the first record passed.
    """
    import imageio.v2 as imageio

    from .io import atomic_path

    _check(view, size)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    t = np.asarray(t, float)
    thrust = None if thrust is None else np.asarray(thrust, float)
    idx = np.unique(np.linspace(0, len(t) - 1, count).round().astype(int))
    files = []
    for i, img in zip(idx, _frames(t, positions, idx, title, view, size, thrust, motor_speed,
                                   slice(None), spacing=False, polymorph=polymorph, forms=forms,
                                   body=body)):
        p = out_dir / f"snapshot_{first_record + i:05d}.png"
        with atomic_path(p) as tmp:
            imageio.imwrite(str(tmp), img, format="PNG")
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
