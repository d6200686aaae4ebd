"""Recording `/joint_states` in the background, matched by joint name.

A thread blocks on the subscription (a Cyclone waitset) until samples arrive, then takes them in
batches: while they keep coming it collects them every `BATCH_PERIOD` rather than waking for each
one (a 1 kHz stream costs 50 wake-ups a second, not 1000), the reader's history holding what
arrives in between. `stop` wakes it and returns the arrays.
"""

from __future__ import annotations

import dataclasses
import math
import threading
import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import AdapterError, InvalidInputError
from dmprs.ros2 import messages
from dmprs.ros2.node import Node
from dmprs.ros2.qos import DEFAULT

#: How long the recording thread blocks before it looks at the stop flag again.
_WAKE_PERIOD = 0.5
#: While samples keep coming, they are taken this often (s); the history must hold what
#: arrives in one period (depth > rate x period).
BATCH_PERIOD = 0.02
#: A joint position or velocity beyond this (rad, m, or per s) is no robot's: such a sample is
#: another publisher's, or garbage, and is skipped and counted.
MAX_VALUE = 1e6
#: A sample stamped this far (s) ahead of the last kept one, beyond the time that passed here
#: between their arrivals, cannot be the same robot's (a stray publisher's clock): skipped.
STAMP_JUMP = 1.0
#: Samples held, before the recording has its first two, while none of them agrees with
#: another: past this many the oldest is taken for another publisher's.
MAX_UNCONFIRMED = 8
#: Name lists whose joint columns are remembered: a stream of ever new lists (a publisher
#: renaming its joints) must not grow the cache without bound.
MAX_CACHED_NAME_LISTS = 64


def joint_columns(cache: dict[tuple[str, ...], list[int] | None], message: Any,
                  joint_names: tuple[str, ...]) -> list[int] | None:
    """Where each of ``joint_names`` sits in a JointState ``message`` (cached per name list in
    ``cache``); None when one is missing or the message has fewer positions than names.
    """
    names = tuple(message.name)
    if names not in cache:
        if len(cache) >= MAX_CACHED_NAME_LISTS:
            cache.clear()
        index = {name: i for i, name in enumerate(names)}
        cache[names] = [index[j] for j in joint_names] if all(j in index for j in joint_names) else None
    return cache[names] if len(message.position) == len(names) else None


def plausible(values: list[float]) -> bool:
    """Whether joint values can be a robot's: finite and within :data:`MAX_VALUE`."""
    return all(math.isfinite(v) and abs(v) <= MAX_VALUE for v in values)


def increasing(stamps: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Which samples to keep so that the times strictly increase: a sample stamped at or before
    one already kept (a repeat, a reordering) adds nothing.
    """
    t = np.asarray(stamps, dtype=float)
    if not len(t):
        return np.zeros(0, bool)
    return np.concatenate([[True], t[1:] > np.maximum.accumulate(t)[:-1]])


@dataclasses.dataclass(frozen=True)
class JointRecording:
    """Joint states in the recorder's joint order: `times` (n,) from the header stamps,
    `positions` and `velocities` (n, joints; velocities NaN where a message had none).
    """

    joint_names: tuple[str, ...]
    times: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray


class JointStateRecorder:
    """`JointStateRecorder(node, ["j1", "j2"]).start()`, later `.stop()` -> JointRecording.

    Messages that lack one of the joints are counted in `skipped` and left out, and so are
    samples that cannot be the robot's (counted in `implausible` as well): a position or
    velocity that is not finite or beyond :data:`MAX_VALUE`, or a stamp that jumps ahead of the
    last kept one by more than :data:`STAMP_JUMP` beyond the time that passed here.

    The first sample has no kept one to be judged against, and a stray one taken as the
    robot's would make every real sample look implausible (or stamped before it). So the
    recording starts only once two samples agree (stamps within :data:`STAMP_JUMP` of each
    other beyond the time that passed here): the samples before that agree with none are
    another publisher's, skipped and counted.
    """

    def __init__(self, node: Node, joint_names: list[str], topic: str = "/joint_states", depth: int = 1000):
        if not joint_names or len(set(joint_names)) != len(joint_names):
            raise InvalidInputError(f"joint_names {joint_names!r} must be distinct and not empty")
        self.joint_names = tuple(joint_names)
        self.depth = depth
        self.subscription = node.create_subscription(messages.JointState, topic, DEFAULT.with_depth(depth))
        self.skipped = 0
        self.implausible = 0
        self._last: tuple[float, float] | None = None  # (stamp, arrival) of the last kept sample
        # before the first two samples that agree: (stamp, arrival, row) of those not yet judged
        self._unconfirmed: list[tuple[float, float, tuple[float, list[float], list[float]]]] = []
        self._rows: list[tuple[float, list[float], list[float]]] = []
        self._columns: dict[tuple[str, ...], list[int] | None] = {}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        #: time.monotonic() when samples last arrived (or when recording started)
        self.last_arrival = time.monotonic()

    def _record(self, message: Any, arrival: float) -> None:
        columns = joint_columns(self._columns, message, self.joint_names)
        if columns is None:
            self.skipped += 1
            return
        t = message.header.stamp.sec + message.header.stamp.nanosec * 1e-9
        q = [float(message.position[c]) for c in columns]
        v = [float(message.velocity[c]) for c in columns] if len(message.velocity) == len(message.name) else []
        jumped = self._last is not None and t - self._last[0] > arrival - self._last[1] + STAMP_JUMP
        if not (plausible(q) and plausible(v) and math.isfinite(t)) or jumped:
            self._reject()
            return
        if self._last is None:
            self._confirm((t, arrival, (t, q, v)))
            return
        self._last = (t, arrival)
        self._rows.append((t, q, v))

    @property
    def latest_stamp(self) -> float | None:
        """The stamp of the last sample kept (the robot's clock as last seen), None before one."""
        last = self._last
        return None if last is None else last[0]

    def _reject(self, count: int = 1) -> None:
        self.skipped += count
        self.implausible += count

    def _confirm(self, sample: tuple[float, float, tuple[float, list[float], list[float]]]) -> None:
        """Starts the recording with the newest held sample that agrees with ``sample`` (the
        older ones held are another publisher's), or holds ``sample`` until one agrees with it.
        """
        t, arrival, row = sample
        for i in range(len(self._unconfirmed) - 1, -1, -1):
            t0, arrival0, row0 = self._unconfirmed[i]
            # as for a kept sample: not far ahead of the time that passed here, nor behind (a clock
            # may stand still while a simulation computes, never run backwards)
            if -STAMP_JUMP < t - t0 <= arrival - arrival0 + STAMP_JUMP:
                self._reject(len(self._unconfirmed) - 1)
                self._unconfirmed = []
                self._rows += [row0, row]
                self._last = (t, arrival)
                return
        self._unconfirmed.append(sample)
        if len(self._unconfirmed) > MAX_UNCONFIRMED:
            self._unconfirmed.pop(0)
            self._reject()

    def _run(self) -> None:
        while not self._stop.is_set():
            batch = self.subscription.take(max_samples=self.depth)
            arrival = time.monotonic()
            for message in batch:
                self._record(message, arrival)
            if batch:
                self.last_arrival = time.monotonic()
                self._stop.wait(BATCH_PERIOD)
            else:
                self.subscription.wait(_WAKE_PERIOD)
        arrival = time.monotonic()
        for message in self.subscription.take():
            self._record(message, arrival)

    def start(self) -> JointStateRecorder:
        """Start recording in a background thread; returns the recorder."""
        if self._thread is not None:
            raise AdapterError("the recorder is already running")
        self.last_arrival = time.monotonic()
        self._thread = threading.Thread(target=self._run, name="joint-state-recorder", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> JointRecording:
        """Stop recording and return everything recorded."""
        if self._thread is None:
            raise AdapterError("the recorder was not started")
        self._stop.set()
        self.subscription.interrupt()
        self._thread.join()
        self._thread = None
        if self._unconfirmed:  # no two samples agreed: only the newest can still be the robot's
            self._reject(len(self._unconfirmed) - 1)
            self._rows.append(self._unconfirmed[-1][2])
            self._unconfirmed = []
        n, width = len(self._rows), len(self.joint_names)
        positions = np.array([row[1] for row in self._rows], dtype=float).reshape(n, width)
        velocities = np.full((n, width), np.nan)
        for i, row in enumerate(self._rows):
            if row[2]:
                velocities[i] = row[2]
        times = np.array([row[0] for row in self._rows], dtype=float)
        return JointRecording(self.joint_names, times, positions, velocities)
