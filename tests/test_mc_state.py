"""Exact raw states: photon ranges, merging, resuming and files give the bits of one run.

A result is a pure function of (stack, source, tallies, seed, photons): split the photons into
chunk-aligned ranges of any sizes, trace them with any number of threads, merge the states in
range order, and the totals, every histogram and the state itself are bit-identical to one run.
"""

import pickle

import numpy as np
import pytest
import subsurf
from subsurf import Layer, ParameterError, PencilBeam, Stack, Tallies, TallyState, simulate, simulate_range
from subsurf.io import results_equal

C = subsurf.state.CHUNK_PHOTONS
STACK = Stack([Layer(1.4, 0.5, 6.0, 0.8, 0.3), Layer(1.33, 1.0, 4.0, 0.0, float("inf"))], 1.0, 1.0)
TALLIES = Tallies(nr=6, dr=0.1, nz=5, dz=0.1, na=4, nt=4, dt=2.0, brdf=(3, 2), max_order=2)
N = 3 * C + 77  # the last chunk is cut
KW = dict(seed=5, source=PencilBeam(0.4, 1.0), tallies=TALLIES)


def _same(a, b):
    """Totals, stderrs, histograms, events, photons and states agree bit for bit."""
    assert results_equal(a, b, provenance=False)


@pytest.fixture(scope="module")
def whole():
    return simulate(STACK, photons=N, threads=1, **KW)


@pytest.mark.parametrize("threads", [2, 3])
def test_thread_count_does_not_change_bits(whole, threads):
    _same(simulate(STACK, photons=N, threads=threads, **KW), whole)


@pytest.mark.parametrize("cuts", [[C], [C, 3 * C], [2 * C, 3 * C]])
def test_ranges_merged_in_order_give_the_bits_of_one_run(whole, cuts):
    bounds = [0, *cuts, N]
    states = [simulate_range(STACK, a, b, threads=1 + i % 2, **KW) for i, (a, b) in enumerate(zip(bounds, bounds[1:]))]
    assert [s.start for s in states] == bounds[:-1] and states[-1].stop == N
    merged = TallyState.concat(states)
    assert merged == whole.state and merged.photons == N
    # finishing a merged state traces nothing and gives the result of one run
    _same(simulate(STACK, photons=N, resume=merged, **KW), whole)
    # a state travels: pickle and plain arrays
    back = pickle.loads(pickle.dumps(states[0]))
    assert back == states[0] and TallyState.from_dict(states[0].to_dict()) == states[0]


def test_merge_and_resume_rules(whole):
    a = simulate_range(STACK, 0, C, **KW)
    b = simulate_range(STACK, C, 2 * C, **KW)
    with pytest.raises(ParameterError, match="range order"):
        b.merge(a)
    other = simulate_range(STACK, C, 2 * C, seed=6, source=KW["source"], tallies=TALLIES)
    with pytest.raises(ParameterError, match="another configuration"):
        a.merge(other)
    with pytest.raises(ParameterError, match="multiple of the chunk size"):
        simulate_range(STACK, 100, C, **KW)
    cut = simulate_range(STACK, 0, 100, **KW)  # ends inside a chunk: can only be the last range
    with pytest.raises(ParameterError, match="do not follow"):
        cut.merge(simulate_range(STACK, C, 2 * C, **KW))
    with pytest.raises(ParameterError, match="inside a chunk"):
        simulate(STACK, photons=N, resume=cut, **KW)
    with pytest.raises(ParameterError, match="from photon 0"):
        simulate(STACK, photons=N, resume=b, **KW)
    with pytest.raises(ParameterError, match="another configuration"):
        simulate(STACK, photons=N, resume=a, seed=7, source=KW["source"], tallies=TALLIES)
    with pytest.raises(ParameterError, match="fewer than"):
        simulate(STACK, photons=C - 1, resume=a, **KW)


def test_partial_result_saved_to_a_file_resumes_to_the_same_bits(tmp_path, whole):
    part = simulate(STACK, photons=2 * C, **KW)  # a prefix of the run, as an interrupted run holds
    path = subsurf.save(part, tmp_path / "part.h5")
    back = subsurf.load(path)
    assert back.state == part.state and back.roulette == part.roulette
    assert back.rd_r.overflow == (True,) and np.array_equal(back.rd_r.measures[0], part.rd_r.measures[0])
    _same(simulate(STACK, photons=N, resume=back, **KW), whole)
    # a merge of different seeds is not one run: no state to resume
    other = simulate(STACK, photons=C, seed=9, source=KW["source"], tallies=TALLIES)
    assert subsurf.merge(part, other).state is None
