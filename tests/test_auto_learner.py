"""The default learner ``auto``: the root finder expanding its limits for a one-dimensional query
(it finds a root beyond the demos' queries, where the plain root finder stops at its limit), and
Broyden's secant for n-D queries; ``dmprs learn`` and ``make_learner()`` use it unless told
otherwise, and the paper's learner of each experiment stays named.
"""

import numpy as np

from dmprs import experiments, learners
from dmprs.experiments.base import DEFAULT_LEARNER, LEARNERS, LearnerSettings
from dmprs.loop import learn

# demos whose outcomes lie below the desired 1.5: the root lies beyond the upper limit
BEYOND = {"amplitudes": (0.5, 1.0), "desired": 1.5}


def test_auto_is_the_default_and_the_papers_learner_stays_named():
    s = experiments.make("analytic")
    assert DEFAULT_LEARNER == "auto" and s.paper_learner == "error"
    lrn = s.make_learner()
    assert isinstance(lrn, learners.IllinoisRootFinder)
    assert isinstance(s.make_learner(s.paper_learner), learners.ErrorLearning)
    two_d = LEARNERS["auto"].make(LearnerSettings(), np.zeros(2), {})
    assert isinstance(two_d, learners.ErrorLearning)


def test_auto_finds_a_root_beyond_the_demos_where_the_root_finder_stops_at_its_limit():
    plain = experiments.run("analytic", learner="root", max_trials=20, **BEYOND)
    assert not plain.converged and "hit-bound" in plain.stop_reason
    auto = experiments.run("analytic", max_trials=20, **BEYOND)
    assert auto.converged and auto.n_trials <= 4
    s = experiments.make("analytic", **BEYOND)
    lrn = s.make_learner()
    result = learn(s.task, s.generalizer, s.desired_query, lrn, max_trials=20)
    assert result.converged and lrn.expansions[0] == 0 and lrn.expansions[1] >= 1
    assert lrn.bracket[1] > s.desired_query[0]  # the upper limit moved beyond the widened bracket


def test_auto_takes_the_root_finders_steps_when_no_limit_needs_expanding():
    s = experiments.make("analytic", amplitudes=(1.5, 2.5), desired=0.8)
    runs = [experiments.run("analytic", learner=name, max_trials=20, amplitudes=(1.5, 2.5), desired=0.8)
            for name in ("auto", "root")]
    assert [t.query.tolist() for t in runs[0].trials] == [t.query.tolist() for t in runs[1].trials]
    assert runs[0].converged and s.make_learner().expansions == (0, 0)
