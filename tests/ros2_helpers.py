"""Shared by the ROS 2 tests: a simulated controller's loop, run in the background for the
duration of a ``with`` block.
"""

from __future__ import annotations

import threading
from typing import Self


class ControllerThread(threading.Thread):
    """A background loop that runs until the ``with`` block ends (``run`` polls ``halt``)."""

    def __init__(self) -> None:
        super().__init__(daemon=True)
        self.halt = threading.Event()

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.halt.set()
        self.join()
