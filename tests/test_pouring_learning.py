"""Pouring learned as in the paper (Fig. 9): golden-section error learning pours 0.2 l +- 10 ml
from bottles of 0.4, 0.5 and 0.7 l within 7 trials. The demonstrations' calibration (about 15 s
of simulation) runs once per process.
"""

import pytest

from dmprs import experiments


@pytest.mark.parametrize("volume", [0.4, 0.5, 0.7])
def test_golden_section_pours_two_decilitres(volume):
    r = experiments.run("pouring", bottle_volume=volume, learner="golden", max_trials=7)
    assert r.converged, [t.signals.get("poured_volume") for t in r.trials]
    last = r.trials[-1]
    assert abs(last.signals["poured_volume"] - 0.2) < 0.010
    assert r.trials[0].query[0] == pytest.approx(volume)  # the first trial is Ĝ(true volume)
    assert last.query[0] != pytest.approx(volume)  # what is learned is a virtual volume


def test_outside_the_demonstrations_the_paper_mode_fails_and_robust_mode_expands_its_bracket():
    # docs/method.md §6.2 #5: with q0 outside [q_l, q_h] the algorithm box inverts the bracket.
    paper = experiments.run("pouring", bottle_volume=0.25, learner="golden", max_trials=6)
    assert not paper.converged
    # the robust mode expands the bracket below the demos: with liquid 4 it succeeds; with
    # liquid 0 the expanded bracket asks for a tilt beyond the bottle's limit, which the adapter
    # rejects, and the run ends there, nothing poured (the README's table: 1 of 5 liquids)
    robust = experiments.run("pouring", bottle_volume=0.25, learner="golden-robust", max_trials=6, liquid_seed=4)
    assert robust.converged
    beyond = experiments.run("pouring", bottle_volume=0.25, learner="golden-robust", max_trials=6, liquid_seed=0)
    assert not beyond.converged and beyond.trials[-1].status == "rejected"
    assert "above the maximum 2.4" in beyond.stop_reason
