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
