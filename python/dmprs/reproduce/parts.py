"""The reproduction's parts beyond the paper's three experiments, in one table, in the order the
report appends their sections.
"""

from __future__ import annotations

from dmprs.reproduce import (
    arm_sequence,
    growing,
    juggling,
    noisy,
    online,
    release_throwing,
    throwing,
    versus_bo,
)
from dmprs.reproduce.part import Part

PARTS: tuple[Part, ...] = (growing.PART, noisy.PART, throwing.PART, juggling.PART, online.PART, versus_bo.PART,
                          release_throwing.PART, arm_sequence.PART)

BY_KIND = {p.kind: p for p in PARTS}
