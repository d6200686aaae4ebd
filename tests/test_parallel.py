"""pmap gives the same results, in order, on every backend; failures name the run."""

import pytest

from dmprs.errors import InvalidInputError
from dmprs.parallel import ParallelError, pmap


def square(x: int) -> int:
    return x * x


def fails_on_three(x: int) -> int:
    if x == 3:
        raise ValueError("three is bad")
    return x


def matchbox_regime(duration: float) -> str:
    from dmprs.tasks.matchbox import simulate_batch

    return simulate_batch([duration])[0]["regime"]


def test_serial_and_local_processes_agree():
    items = list(range(12))
    seen = []
    assert pmap(square, items, backend="serial") == [x * x for x in items]
    assert pmap(square, items, backend="local", workers=2, on_result=lambda i, r: seen.append(i)) == [x * x for x in items]
    assert sorted(seen) == items


def test_the_rust_core_works_in_worker_processes():
    durations = [0.14, 0.105, 0.07]
    assert pmap(matchbox_regime, durations, workers=2) == pmap(matchbox_regime, durations, backend="serial")


@pytest.mark.parametrize("backend", ["serial", "local"])
def test_a_failing_run_is_named(backend):
    with pytest.raises(ParallelError, match=r"run 3 \(3\) failed: ValueError: three is bad"):
        pmap(fails_on_three, range(6), backend=backend, workers=2)


@pytest.mark.parametrize("backend", ["serial", "local"])
def test_the_runs_are_handed_out_in_the_order_given_and_returned_in_the_items_order(backend):
    items = list(range(10))
    order = [7, 2, 9, 0, 1, 3, 4, 5, 6, 8]
    seen = []
    got = pmap(square, items, backend=backend, workers=1, order=order, on_result=lambda i, r: seen.append(i))
    assert got == [x * x for x in items]
    assert seen == order  # one worker: finished in the order handed out


def test_longest_first_puts_the_slowest_parts_first_and_keeps_the_plan_order_otherwise():
    from dmprs.reproduce import plan
    from dmprs.reproduce.run import RUN_SECONDS, longest_first, part_of

    specs = plan(quick=True)
    order = longest_first(specs)
    assert sorted(order) == list(range(len(specs)))
    cost = [RUN_SECONDS.get(part_of(specs[i]), 1.0) for i in order]
    assert cost == sorted(cost, reverse=True)
    for k in range(len(order) - 1):
        if cost[k] == cost[k + 1]:
            assert order[k] < order[k + 1]


def simulated_job(runs: dict[str, tuple[int, float]], workers: int = 2) -> list[tuple[float, str]]:
    """(finish time, part) of every run of a job with ``runs[part] = (count, true seconds per
    run)`` (each run +-20 % around it, deterministically), handed out longest first
    (:data:`RUN_SECONDS`) to ``workers`` that each take the next run when free.
    """
    from dmprs.reproduce.run import RUN_SECONDS

    jobs = sorted(((part, mean * (0.8 + 0.4 * ((7 * k) % 11) / 10)) for part, (n, mean) in runs.items()
                   for k in range(n)), key=lambda job: -RUN_SECONDS.get(job[0], 1.0))
    free = [0.0] * workers
    finished = []
    for part, seconds in jobs:
        w = min(range(workers), key=free.__getitem__)
        free[w] += seconds
        finished.append((free[w], part, seconds))
    return sorted(finished)


def test_the_time_left_is_estimated_from_each_parts_pace_not_from_the_count_of_runs():
    """On a job shaped as the full reproduction's (a few slow arm runs first, hundreds of quick
    ones after), on a machine 1.5x slower than :data:`RUN_SECONDS` expects: at every part's end
    the estimate is within 30 % (or 2 min) of the time the simulated job really has left; the
    count of runs at the pace so far is off many times over.
    """
    from dmprs.reproduce.run import seconds_left

    runs = {"arm_pouring": (60, 45.0), "versus": (259, 7.5), "pouring": (100, 6.0), "growing": (10, 25.0),
            "noisy": (88, 1.5), "baselines": (140, 0.8), "juggling": (100, 0.9), "throwing": (300, 0.15)}
    events = simulated_job(runs)
    end = events[-1][0]
    measured: dict[str, float] = {}
    finished: dict[str, int] = {}
    left = {part: n for part, (n, _) in runs.items()}
    worst_count = 0.0
    for k, (now, part, seconds) in enumerate(events):
        measured[part] = measured.get(part, 0.0) + seconds
        finished[part] = finished.get(part, 0) + 1
        left[part] -= 1
        if left[part] == 0 and now < end:
            truth = end - now
            estimate = seconds_left(now, measured, finished, left)
            assert abs(estimate - truth) < max(0.3 * truth, 120.0), (part, now, estimate, truth)
            by_count = now / (k + 1) * (len(events) - k - 1)
            worst_count = max(worst_count, by_count / truth)
    assert worst_count > 3.0
    assert seconds_left(0.0, {}, {}, left) == 0.0


def test_bad_arguments():
    with pytest.raises(InvalidInputError, match="unknown backend 'gpu'"):
        pmap(square, [1], backend="gpu")
    with pytest.raises(InvalidInputError, match="workers = 0"):
        pmap(square, [1], workers=0)
    assert pmap(square, [], backend="local") == []
    with pytest.raises(InvalidInputError, match="order must be a permutation"):
        pmap(square, [1, 2], order=[0, 0])


def test_a_local_ray_instance_gives_the_same_results():
    ray = pytest.importorskip("ray", reason="Ray is the optional 'ray' extra")
    try:
        assert pmap(square, range(8), backend="ray", workers=2) == [x * x for x in range(8)]
        durations = [0.14, 0.07]
        assert pmap(matchbox_regime, durations, backend="ray") == pmap(matchbox_regime, durations, backend="serial")
    finally:
        ray.shutdown()
