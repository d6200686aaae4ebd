"""A frame strip of one arm pour through MuJoCo's offscreen renderer.

Needs an OpenGL backend: set ``MUJOCO_GL=egl`` (Debian: ``libegl1``) or ``MUJOCO_GL=osmesa``
(``libosmesa6``) on a machine without a display. :func:`frame_strip` raises
:class:`~dmprs.errors.DmprsError` saying so when none works.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import DmprsError
from dmprs.plots import pyplot
from dmprs.sim import arm_scene

#: the camera: looking at the bottle and the glass from in front of the robot, slightly above
CAMERA = {"lookat": (0.75, -0.12, 0.25), "distance": 0.9, "azimuth": 160.0, "elevation": -15.0}


def frame_strip(t: NDArray[np.float64], q: NDArray[np.float64], qd: NDArray[np.float64],
                liquid: arm_scene.SettledLiquid, times: tuple[float, ...], path: str | Path, *,
                hold: float = 0.5, width: int = 320, height: int = 240) -> Path:
    """Simulates the joint trajectory (as :func:`arm_scene.simulate_pour` does) and writes the
    frames at ``times`` (s, multiples of 20 ms) side by side as one PNG at ``path``.
    """
    import mujoco


    try:
        renderer = mujoco.Renderer(liquid.model, height, width)
    except Exception as exc:  # noqa: BLE001 - any GL failure means "no backend here"
        raise DmprsError(f"no OpenGL backend for MuJoCo's renderer ({exc}); set MUJOCO_GL=egl or osmesa "
                         "and install libegl1 or libosmesa6") from None
    camera = mujoco.MjvCamera()
    for key, value in CAMERA.items():
        setattr(camera, key, value)
    wanted = [round(x / 0.02) for x in times]
    frames: dict[int, Any] = {}

    def grab(model: Any, data: Any, now: float) -> None:
        k = round(now / 0.02)
        if k in wanted and k not in frames:
            renderer.update_scene(data, camera)
            frames[k] = renderer.render().copy()

    arm_scene.simulate_pour(t, q, qd, liquid, hold=hold, on_sample=grab)
    renderer.close()
    plt = pyplot()
    fig, axes = plt.subplots(1, len(wanted), figsize=(2.2 * len(wanted), 2.0))
    for ax, k in zip(np.atleast_1d(axes), wanted, strict=True):
        if k in frames:
            ax.imshow(frames[k])
        ax.set_title(f"t = {k * 0.02:.1f} s", fontsize=8)
        ax.axis("off")
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110, bbox_inches="tight")
    plt.close(fig)
    return out
