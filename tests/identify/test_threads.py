"""A problem's evaluation and a Jacobian's QR shared out to threads (identify/threads.py): the same numbers on one
thread and on four, bit for bit (what is cut into items does not depend on the threads), R^T R = J^T J against
numpy's J^T J; an exception in an item is raised; a forked child still evaluates."""

import multiprocessing
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from conftest import SPECS
from identify_helpers import measure, setup

from armcal.identify import threads
from armcal.identify.identifiability import SHARE, triangular
from armcal.identify.problem import CHUNK, KeyBlock, build_problem


@pytest.fixture
def workers():
    """Restores the process's worker count after a test changes it."""
    before = threads.workers()
    yield
    threads.limit(before)


def _problem():
    """A theodolite campaign of several chunks (two stations, one key each)."""
    s = setup(SPECS / "puma560_theodolite.yaml", [("count: 150\n  seed: 3", "count: 2500\n  seed: 3")])
    return build_problem(s.kinematics, s.device, measure(s.kinematics, s.device, s.plans[0], None, None))


def test_the_evaluation_is_the_same_on_one_thread_and_on_four(workers):
    problem = _problem()
    assert max(len(b._q) for b in problem.blocks) > 3 * CHUNK  # every thread gets chunks
    theta = problem.parameters.nominal + 1e-4 * np.random.default_rng(0).standard_normal(len(problem.parameters.names))
    threads.limit(1)
    r1, J1 = problem.evaluate(theta)
    threads.limit(4)
    r4, J4 = problem.evaluate(theta)
    assert np.array_equal(r1, r4) and np.array_equal(J1, J4)


def test_the_triangular_factor_is_j_s_and_the_same_on_any_number_of_threads(workers):
    rng = np.random.default_rng(1)
    J = rng.normal(size=(3 * SHARE + 123, 40)) * rng.uniform(0.01, 100.0, size=40)
    gram = J.T @ J
    factors = []
    for count in (1, 2, 4):
        threads.limit(count)
        factors.append(triangular(J))
    R = factors[0]
    assert R.shape == (40, 40) and np.allclose(np.tril(R, -1), 0.0)
    assert np.abs(R.T @ R - gram).max() <= 1e-12 * np.abs(gram).max()
    assert all(np.array_equal(R, other) for other in factors[1:])


def test_an_exception_in_an_item_is_raised_here_after_every_thread_is_done(workers):
    threads.limit(2)
    done = []

    def work(item):
        if item == 1:
            raise ZeroDivisionError("in the second item")
        time.sleep(0.05)
        done.append(item)
        return item

    assert threads.each(work, [0, 2, 3]) == [0, 2, 3]
    done.clear()
    with pytest.raises(ZeroDivisionError, match="second item"):
        threads.each(work, [0, 1, 2, 3])
    assert sorted(done) == [0, 2]  # thread 0's items 0 and 2 finished; thread 1 stopped at item 1


def _in_child(connection):
    threads.limit(2)
    connection.send(threads.each(lambda item: item * item, [2, 3]))


def test_a_forked_child_evaluates_with_threads_of_its_own(workers):
    """The pool's threads are not copied by fork: a child that used the parent's pool would wait for ever."""
    threads.limit(2)
    threads.each(abs, [-1, -2])  # the parent's pool has threads now
    parent, child = multiprocessing.get_context("fork").Pipe()
    process = multiprocessing.get_context("fork").Process(target=_in_child, args=(child,), daemon=True)
    process.start()
    assert parent.poll(60), "the forked child did not answer"
    assert parent.recv() == [4, 9]
    process.join(60)


def test_each_inside_an_item_runs_there_and_does_not_wait_for_the_pool(workers):
    """A share that shares out again would wait for pool threads that are all busy with shares: it runs inline."""
    threads.limit(2)
    nested = threads.each(lambda i: threads.each(lambda j: (i, j, threads.share()), [0, 1, 2]), [0, 1])
    assert nested == [[(0, j, 0) for j in range(3)], [(1, j, 1) for j in range(3)]]


def test_a_block_whose_channels_read_every_sample_gives_the_per_channel_numbers(monkeypatch):
    """The residuals of all channels at once (KeyBlock._complete_chunk) against the channel-by-channel path."""
    problem = _problem()
    assert all(len(c.rows) == len(b._q) for b in problem.blocks for c in b.channels)  # every block takes the first
    theta = problem.parameters.nominal + 1e-4 * np.random.default_rng(4).standard_normal(len(problem.parameters.names))
    r1, J1 = problem.evaluate(theta)
    per_channel = lambda block, first, theta, wanted, r, J, start: KeyBlock._chunk(block, first, theta, wanted[0], r, J, start)  # noqa: E731
    monkeypatch.setattr(KeyBlock, "_complete_chunk", per_channel)
    r2, J2 = problem.evaluate(theta)
    assert np.array_equal(r1, r2) and np.array_equal(J1, J2)


def test_problems_of_one_function_share_its_calls_and_keep_their_own_numbers(monkeypatch):
    """Two problems of the same compiled functions (a diagnosis's folds) share the mapped calls (KeyBlock._mapped):
    evaluated in turn at different points, each gives the numbers it gives alone."""
    monkeypatch.setenv("ARMCAL_COMPILE", "now")  # the machine code's calls, as a warm run has them
    s = setup(SPECS / "puma560_theodolite.yaml", [("count: 150\n  seed: 3", "count: 600\n  seed: 3")])
    data = measure(s.kinematics, s.device, s.plans[0], None, None)
    functions = {}
    subset = data.subset(np.arange(0, len(data), 3))
    whole = build_problem(s.kinematics, s.device, data, functions=functions)
    part = build_problem(s.kinematics, s.device, subset, functions=functions)
    assert part.blocks[0]._calls is whole.blocks[0]._calls
    rng = np.random.default_rng(6)
    near = [whole.parameters.nominal + 1e-4 * rng.standard_normal(len(whole.parameters.names)) for _ in range(2)]
    alone = [build_problem(s.kinematics, s.device, d).evaluate(theta) for d, theta in ((data, near[0]), (subset, near[1]))]  # calls of their own
    for _ in range(2):
        for problem, theta, (r, J) in zip((whole, part), near, alone):
            r_here, J_here = problem.evaluate(theta)
            assert np.array_equal(r, r_here) and np.array_equal(J, J_here)


def test_problems_of_one_function_evaluated_by_two_callers_at_once_keep_their_own_numbers(monkeypatch):
    """Two callers' threads (a Dask worker's tasks of one study share its compiled functions) evaluating problems of
    the same functions at the same time, at different points: each gives the numbers it gives alone, bit for bit."""
    monkeypatch.setenv("ARMCAL_COMPILE", "now")  # the machine code's calls, as a warm run has them
    s = setup(SPECS / "puma560_theodolite.yaml", [("count: 150\n  seed: 3", "count: 600\n  seed: 3")])
    data = measure(s.kinematics, s.device, s.plans[0], None, None)
    functions = {}
    problems = [build_problem(s.kinematics, s.device, data.subset(np.arange(k, len(data), 2)), functions=functions) for k in (0, 1)]
    rng = np.random.default_rng(7)
    near = [problems[0].parameters.nominal + 1e-4 * rng.standard_normal(len(problems[0].parameters.names)) for _ in problems]
    alone = [problem.evaluate(theta) for problem, theta in zip(problems, near)]
    start = threading.Barrier(2)

    def evaluated(k: int) -> bool:
        start.wait()
        return all(all(np.array_equal(a, b) for a, b in zip(alone[k], problems[k].evaluate(near[k]))) for _ in range(40))

    with ThreadPoolExecutor(2) as callers:
        assert all(callers.map(evaluated, (0, 1)))
