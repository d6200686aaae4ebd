"""What a fuzz target's runner raises when a call behaved badly without raising an exception of its
own; :mod:`tests.fuzz_tally` counts each kind in its own column.
"""

from __future__ import annotations


class AcceptedGarbage(AssertionError):
    """A call accepted what it must refuse: it wrote outside the directory it was given, wrote
    through a link, overwrote files dmprs did not write, left files behind, read input that cannot
    be meant (a zero stamp among set ones, a NaN, a duplicate joint, a 2-frame episode, a FIFO, a
    bomb), or took an action it should have refused. Counted as "garbage accepted".
    """


class UnclearMessage(AssertionError):
    """A refusal whose message does not name the file, field, row or argument. Counted as a
    leaked type: an error a user cannot act on is as bad as one of the wrong kind.
    """
