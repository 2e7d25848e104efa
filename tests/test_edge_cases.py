"""Regression tests for edge cases that used to crash or give wrong answers.

1. Out-of-range face indices read out of bounds in the compiled stages (segfaults), and
   malformed faces or vertex values slipped through: every public entry point must now
   raise a ``ValueError`` naming the problem. The cases run in child processes, so that
   a crash is a test failure rather than the end of the test session.
2. Wasserstein distances of high order (or of tiny or huge diagrams) underflowed to 0 or
   overflowed to inf: costs are now computed in scaled form. References are exact brute
   force over matchings, the bottleneck distance (the limit of large orders) and gudhi's
   optimal-transport implementation (POT).
3. An eigenvalue of unbounded multiplicity (a "book" of many triangles on one edge) made
   the eigen stage grow its block without bound: growth is now capped and the warning
   says "multiplicity at least m".

Two defects found while writing these, older than the change, are covered too: a
ScalarField that shared writeable arrays with its caller (validation bypassed by an
in-place edit, then a crash), and suboptimal Wasserstein matchings at orders above ~10
when the distance is far below the largest persistence.

Only the public API (``from sklearn_meshph import ...``) is used.
"""

import functools
import itertools
import json
import math
import os
import re
import select
import signal
import subprocess
import sys
import textwrap
import time
import traceback
import warnings

import gudhi.wasserstein
import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sklearn_meshph import (
    DiagramDistance,
    LaplacianEigenTransformer,
    RepeatedEigenvalueWarning,
    bottleneck_distance,
    wasserstein_distance,
)

# ---------------------------------------------------------------------------------------
# 1. Malformed meshes and values: a ValueError naming the problem, never a crash.
# ---------------------------------------------------------------------------------------

# Five vertices; ``faces(x)`` is two triangles whose last index is ``x``.
_SETUP = """
import numpy as np
from sklearn_meshph import (
    LowerStarPersistence, ScalarField, clean_mesh, cotangent_laplacian, graph_laplacian,
    lower_star_persistence,
)
V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.5, 1]])
H = V[:, 0] + 0.1 * V[:, 1]
def faces(x, dtype=None):
    return np.array([[0, 1, 2], [1, 2, x]], dtype=dtype)
"""

_OUT_OF_RANGE = r"face 1 has index \[1, 2, {}\] out of range for 5 vertices"
_NOT_INTEGERS = r"face indices must be integers"
_SHAPE = r"values must have shape \(5,\)"
_NOT_FINITE = r"NaN"

# name: (code, pattern the ValueError's message must match)
_MALFORMED = {
    # Crashes before the fix (segfaults; symmetric-7 an IndexError). The first two are
    # the reported ones.
    "sublevel-7": (
        "LowerStarPersistence(filtration='sublevel')"
        ".fit_transform([ScalarField(V, [[0, 1, 2], [1, 2, 7]], V[:, 0])])",
        _OUT_OF_RANGE.format(7),
    ),
    "sublevel-1e8": (
        "LowerStarPersistence(filtration='sublevel')"
        ".fit_transform([ScalarField(V, [[0, 1, 2], [1, 2, 10**8]], V[:, 0])])",
        _OUT_OF_RANGE.format(10**8),
    ),
    "extended-7": (
        "LowerStarPersistence(filtration='extended')"
        ".fit_transform([ScalarField(V, [[0, 1, 2], [1, 2, 7]], V[:, 0])])",
        _OUT_OF_RANGE.format(7),
    ),
    "extended-1e8": (
        "LowerStarPersistence(filtration='extended')"
        ".fit_transform([ScalarField(V, [[0, 1, 2], [1, 2, 10**8]], V[:, 0])])",
        _OUT_OF_RANGE.format(10**8),
    ),
    "symmetric-7": (
        "LowerStarPersistence().fit_transform([ScalarField(V, faces(7), H)])",
        _OUT_OF_RANGE.format(7),
    ),
    "clean_mesh-1e8": ("clean_mesh(V, faces(10**8))", _OUT_OF_RANGE.format(10**8)),
    # Silently wrong before the fix (negative indices wrap around, the extended
    # filtration also corrupted the heap; an out-of-range index vanished in cleaning)
    # or another error (float faces: a numba typing error).
    "sublevel-negative": (
        "LowerStarPersistence(filtration='sublevel')"
        ".fit_transform([ScalarField(V, [[0, 1, 2], [1, 2, -1]], V[:, 0])])",
        _OUT_OF_RANGE.format(-1),
    ),
    "extended-negative": (
        "LowerStarPersistence(filtration='extended')"
        ".fit_transform([ScalarField(V, [[0, 1, 2], [1, 2, -1]], V[:, 0])])",
        _OUT_OF_RANGE.format(-1),
    ),
    "clean_mesh-7": ("clean_mesh(V, faces(7))", _OUT_OF_RANGE.format(7)),
    "clean_mesh-negative": ("clean_mesh(V, faces(-1))", _OUT_OF_RANGE.format(-1)),
    "clean_mesh-float": ("clean_mesh(V, faces(3.5, float))", _NOT_INTEGERS),
    # The other entry points.
    "lower_star_persistence-7": (
        "lower_star_persistence((V, faces(7)), H)",
        _OUT_OF_RANGE.format(7),
    ),
    "lower_star_persistence-1e8": (
        "lower_star_persistence((V, faces(10**8)), H)",
        _OUT_OF_RANGE.format(10**8),
    ),
    "lower_star_persistence-negative": (
        "lower_star_persistence((V, faces(-1)), H)",
        _OUT_OF_RANGE.format(-1),
    ),
    "lower_star_persistence-float": (
        "lower_star_persistence((V, faces(3.5, float)), H)",
        _NOT_INTEGERS,
    ),
    "lower_star_persistence-nan-face": (
        "lower_star_persistence((V, faces(np.nan, float)), H)",
        _NOT_INTEGERS,
    ),
    "lower_star_persistence-short-values": (
        "lower_star_persistence((V, faces(3)), H[:4])",
        _SHAPE,
    ),
    "lower_star_persistence-long-values": (
        "lower_star_persistence((V, faces(3)), np.append(H, 0.0))",
        _SHAPE,
    ),
    "lower_star_persistence-nan-values": (
        "lower_star_persistence((V, faces(3)), np.append(H[:4], np.nan))",
        _NOT_FINITE,
    ),
    "cotangent_laplacian-7": ("cotangent_laplacian(V, faces(7))", _OUT_OF_RANGE.format(7)),
    "cotangent_laplacian-1e8": (
        "cotangent_laplacian(V, faces(10**8))",
        _OUT_OF_RANGE.format(10**8),
    ),
    "cotangent_laplacian-negative": (
        "cotangent_laplacian(V, faces(-1))",
        _OUT_OF_RANGE.format(-1),
    ),
    "cotangent_laplacian-float": ("cotangent_laplacian(V, faces(3.5, float))", _NOT_INTEGERS),
    "cotangent_laplacian-nan-face": (
        "cotangent_laplacian(V, faces(np.nan, float))",
        _NOT_INTEGERS,
    ),
    "graph_laplacian-7": ("graph_laplacian(faces(7), 5)", _OUT_OF_RANGE.format(7)),
    "graph_laplacian-1e8": ("graph_laplacian(faces(10**8), 5)", _OUT_OF_RANGE.format(10**8)),
    "graph_laplacian-negative": ("graph_laplacian(faces(-1), 5)", _OUT_OF_RANGE.format(-1)),
    "graph_laplacian-float": ("graph_laplacian(faces(3.5, float), 5)", _NOT_INTEGERS),
    "graph_laplacian-nan-face": ("graph_laplacian(faces(np.nan, float), 5)", _NOT_INTEGERS),
    # (mesh, values) pairs and ScalarField values.
    "pair-7": (
        "LowerStarPersistence(filtration='sublevel').fit_transform([((V, faces(7)), H)])",
        _OUT_OF_RANGE.format(7),
    ),
    "pair-extended-1e8": (
        "LowerStarPersistence(filtration='extended').fit_transform([((V, faces(10**8)), H)])",
        _OUT_OF_RANGE.format(10**8),
    ),
    "pair-float-face": (
        "LowerStarPersistence(filtration='sublevel').fit_transform([((V, faces(3.5, float)), H)])",
        _NOT_INTEGERS,
    ),
    "pair-short-values": (
        "LowerStarPersistence(filtration='sublevel').fit_transform([((V, faces(3)), H[:4])])",
        _SHAPE,
    ),
    "pair-long-values": (
        "LowerStarPersistence(filtration='extended')"
        ".fit_transform([((V, faces(3)), np.append(H, 0.0))])",
        _SHAPE,
    ),
    "pair-nan-values": (
        "LowerStarPersistence(filtration='sublevel')"
        ".fit_transform([((V, faces(3)), np.append(H[:4], np.nan))])",
        _NOT_FINITE,
    ),
    "pair-nan-values-extended": (
        "LowerStarPersistence(filtration='extended')"
        ".fit_transform([((V, faces(3)), np.append(H[:4], np.nan))])",
        _NOT_FINITE,
    ),
    "scalar_field-short-values": ("ScalarField(V, faces(3), H[:4])", _SHAPE),
    "scalar_field-nan-values": ("ScalarField(V, faces(3), np.append(H[:4], np.nan))", _NOT_FINITE),
}

# Not fixed yet: a ScalarField keeps the caller's face array (no copy when it is already
# C-contiguous int64) and its arrays stay writeable, so an index set out of range after
# validation is read out of bounds. A field must own its validated arrays: changing the
# caller's array afterwards changes nothing (the case runs through), and changing the
# field's own is refused (numpy's ValueError for a read-only array).
_ALIASED = {
    "scalar_field-caller-array-mutated": (
        "f = faces(3)\n"
        "field = ScalarField(V, f, H)\n"
        "f[1, 2] = 10**8\n"
        "LowerStarPersistence(filtration='extended').fit_transform([field])",
        None,
    ),
    "scalar_field-own-array-mutated": (
        "field = ScalarField(V, faces(3), H)\n"
        "field.faces[1, 2] = 10**8\n"
        "LowerStarPersistence(filtration='extended').fit_transform([field])",
        "read-only",
    ),
}
_CASES = {**_MALFORMED, **_ALIASED}

# Seconds a child running one case (or one isolated test) may take before it is killed
# and the case fails as a deadlock: each takes well under a second.
_CHILD_TIMEOUT = 60.0

# Imports the package once, then runs each case in a forked child and reports, per
# case, what the child raised and how it exited: a crash in one case is that case's
# failure only, and so is a hang (the child is killed after the timeout). Without fork,
# each case gets a fresh interpreter.
_RUNNER = """
import json, os, signal, subprocess, sys, time
cases = json.loads(sys.argv[1])
setup = sys.argv[2]
timeout = float(sys.argv[3])
CHILD = '''
import json, sys
name, code, setup = sys.argv[1:4]
namespace = {}
exec(setup, namespace)
try:
    exec(code, namespace)
    result = {"raised": None, "message": ""}
except BaseException as error:
    result = {"raised": type(error).__name__, "message": str(error)}
result["case"] = name
print(json.dumps(result), flush=True)
'''
if hasattr(os, "fork"):
    exec(setup, {})  # import the package once, before forking
    for name, code in cases.items():
        sys.stdout.flush()
        pid = os.fork()
        if pid == 0:
            try:
                sys.argv = ["-", name, code, setup]
                exec(CHILD, {"__name__": "__child__"})
            finally:
                sys.stdout.flush()
                os._exit(0)
        deadline = time.monotonic() + timeout
        while not (done := os.waitpid(pid, os.WNOHANG))[0] and time.monotonic() < deadline:
            time.sleep(0.005)
        if done[0]:
            code = os.waitstatus_to_exitcode(done[1])
        else:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            code = "timeout"
        print(json.dumps({"case": name, "exit": code}), flush=True)
else:
    for name, code in cases.items():
        try:
            child = subprocess.run(
                [sys.executable, "-c", CHILD, name, code, setup],
                capture_output=True,
                text=True,
                timeout=timeout,
            )
        except subprocess.TimeoutExpired:
            print(json.dumps({"case": name, "exit": "timeout"}), flush=True)
            continue
        sys.stdout.write(child.stdout)
        print(json.dumps({"case": name, "exit": child.returncode}), flush=True)
"""


@pytest.fixture(scope="module")
def malformed_outcomes():
    """For each case of ``_CASES``: its exit code and what it raised."""
    cases = {name: code for name, (code, _) in _CASES.items()}
    run = subprocess.run(
        [
            sys.executable,
            "-c",
            textwrap.dedent(_RUNNER),
            json.dumps(cases),
            _SETUP,
            str(_CHILD_TIMEOUT),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    outcomes = {}
    for line in run.stdout.splitlines():
        if line.startswith("{"):
            record = json.loads(line)
            outcomes.setdefault(record.pop("case"), {}).update(record)
    return outcomes, run.stderr[-2000:]


@pytest.mark.parametrize("name", [*_MALFORMED, *_ALIASED])
def test_malformed_input_raises_value_error(malformed_outcomes, name):
    """Each case raises a ValueError matching its pattern (with pattern None: runs
    through), in a process that exits normally."""
    outcomes, stderr = malformed_outcomes
    _, pattern = _CASES[name]
    outcome = outcomes.get(name, {})
    assert outcome.get("exit") != "timeout", (
        f"{name}: the case did not end within {_CHILD_TIMEOUT:g} s (a deadlock?)"
    )
    assert outcome.get("exit") == 0, (
        f"{name}: the process running the case died (exit code {outcome.get('exit')}; "
        f"negative: killed by that signal)\n{stderr}"
    )
    if pattern is None:
        assert outcome.get("raised") is None, outcome
        return
    assert outcome.get("raised") == "ValueError", (
        f"{name}: expected ValueError, got {outcome.get('raised')}: {outcome.get('message')}"
    )
    assert re.search(pattern, outcome["message"]), outcome["message"]


# ---------------------------------------------------------------------------------------
# 2. Wasserstein distances at any order and any magnitude.
# ---------------------------------------------------------------------------------------


@functools.cache
def _load_kernels():
    """Compile (or load from numba's cache) the distance kernels once, in this process,
    on harmless input, rather than in every forked child."""
    a, b = np.array([[0.0, 1.0], [0.5, np.inf]]), np.array([[0.0, 2.0], [0.0, np.inf]])
    for internal_p in (np.inf, 2.0):
        wasserstein_distance(a, b, order=3.0, internal_p=internal_p)
        wasserstein_distance(a, b, order=3.0, internal_p=internal_p, matching=True)
    bottleneck_distance(a, b)
    for metric in ("wasserstein", "bottleneck"):
        DiagramDistance(metric=metric).fit_transform([(a, b), (b, a)])


def _isolated(test):
    """Run the test in a forked child process where fork exists.

    Before the fix, high orders and huge magnitudes could make the compiled solver read
    out of bounds (overflowed costs, inf - inf = NaN): that must fail the test, not end
    the session; a child that hangs (a deadlock) is killed after ``_CHILD_TIMEOUT``
    seconds and fails the test, rather than hanging the session.
    """

    @functools.wraps(test)
    def wrapper(*args, **kwargs):
        if not hasattr(os, "fork"):
            return test(*args, **kwargs)
        _load_kernels()
        read, write = os.pipe()
        pid = os.fork()
        if pid == 0:  # the child: run the test, report, exit without cleanup
            os.close(read)
            status, report = 0, b""
            try:
                test(*args, **kwargs)
            except BaseException:
                status, report = 1, traceback.format_exc().encode()
            finally:
                while report:
                    report = report[os.write(write, report) :]
                os._exit(status)
        os.close(write)
        chunks, deadline = [], time.monotonic() + _CHILD_TIMEOUT
        hung = False
        while True:  # read the report until the child closes the pipe, or the deadline
            if not select.select([read], [], [], max(deadline - time.monotonic(), 0.0))[0]:
                hung = True
                os.kill(pid, signal.SIGKILL)
                break
            if not (chunk := os.read(read, 1 << 16)):
                break
            chunks.append(chunk)
        os.close(read)
        code = os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1])
        if hung:
            pytest.fail(f"the test did not end within {_CHILD_TIMEOUT:g} s (a deadlock?)")
        if code < 0:
            pytest.fail(f"the test's process was killed by signal {-code} (a crash)")
        if code:
            pytest.fail(b"".join(chunks).decode(), pytrace=False)

    return wrapper


def _ground(p, r):
    return max(abs(p[0] - r[0]), abs(p[1] - r[1]))


def _to_diagonal(p):
    return (p[1] - p[0]) / 2.0


def _brute_force_wasserstein(a, b, order):
    """Exact q-Wasserstein distance (L-infinity ground metric) of two tiny finite
    diagrams: the minimum over every matching (each point to a point of the other
    diagram or to the diagonal) of ``m (sum (c / m)^q)^(1/q)``, ``m`` the largest cost
    of the matching; the scaled form neither underflows nor overflows, and ``order=inf``
    gives the bottleneck distance."""
    a = [tuple(map(float, p)) for p in a]
    b = [tuple(map(float, p)) for p in b]
    best = math.inf
    for k in range(min(len(a), len(b)) + 1):
        for rows in itertools.combinations(range(len(a)), k):
            for cols in itertools.permutations(range(len(b)), k):
                costs = [_ground(a[i], b[j]) for i, j in zip(rows, cols, strict=True)]
                costs += [_to_diagonal(a[i]) for i in range(len(a)) if i not in rows]
                costs += [_to_diagonal(b[j]) for j in range(len(b)) if j not in cols]
                largest = max(costs, default=0.0)
                if largest == 0.0:
                    value = 0.0
                elif math.isinf(order):
                    value = largest
                else:
                    total = math.fsum((c / largest) ** order for c in costs)
                    value = largest * total ** (1.0 / order)
                best = min(best, value)
    return best


def _random_diagram(rng, n, scale=1.0):
    births = rng.uniform(-1.0, 1.0, n) * scale
    return np.column_stack([births, births + rng.uniform(0.0, 1.0, n) * scale])


# The reported examples: order 1000 gave 0.0 (the answer is 0.25) and order 400 with
# costs near 50 gave inf (the answer is 50).
_SMALL = ([[0.0, 1.0]], [[0.0, 1.25], [0.5, 0.75]])
_FIFTY = ([[0.0, 100.0]], [[0.0, 150.0], [10.0, 20.0]])


@pytest.mark.parametrize("order", [1.0, 2.0, 3.5, 50.0, 400.0, 1000.0, 1e5])
@pytest.mark.parametrize("pair", [_SMALL, _FIFTY], ids=["small", "fifty"])
@_isolated
def test_wasserstein_large_order_matches_brute_force(pair, order):
    a, b = pair
    expected = _brute_force_wasserstein(a, b, order)
    assert wasserstein_distance(a, b, order=order) == pytest.approx(expected, rel=1e-12, abs=0)
    assert wasserstein_distance(b, a, order=order) == pytest.approx(expected, rel=1e-12, abs=0)


@_isolated
def test_wasserstein_reported_values():
    assert wasserstein_distance(*_SMALL, order=1000) == pytest.approx(0.25, rel=1e-12, abs=0)
    assert wasserstein_distance(*_FIFTY, order=400) == pytest.approx(50.0, rel=1e-12, abs=0)


@pytest.mark.parametrize("order", [1.5, 7.0, 60.0, 300.0, 1000.0])
@pytest.mark.parametrize("scale", [1e-3, 1.0, 30.0])
@_isolated
def test_wasserstein_random_tiny_diagrams_match_brute_force(order, scale):
    rng = np.random.default_rng([int(order * 10), int(np.log10(scale)) + 10])
    for _ in range(6):
        a = _random_diagram(rng, rng.integers(0, 4), scale)
        b = _random_diagram(rng, rng.integers(0, 4), scale)
        expected = _brute_force_wasserstein(a, b, order)
        got = wasserstein_distance(a, b, order=order)
        assert got == pytest.approx(expected, rel=1e-12, abs=0), (a, b)


@pytest.mark.parametrize(
    "order, scale",
    [(order, scale) for order in (50.0, 200.0, 1000.0, 1e5) for scale in (1e-3, 1.0, 1e3)],
)
@_isolated
def test_wasserstein_large_order_approaches_bottleneck(order, scale):
    """``B <= W_q <= N^(1/q) B`` with ``N`` the number of points: the optimal matching
    of W_q has a cost of at least B, and the bottleneck matching has at most N costs,
    each at most B."""
    rng = np.random.default_rng([int(order), int(np.log10(scale)) + 10, 1])
    for _ in range(15):
        a = _random_diagram(rng, rng.integers(0, 12), scale)
        b = _random_diagram(rng, rng.integers(1, 12), scale)
        w = wasserstein_distance(a, b, order=order)
        bottleneck = bottleneck_distance(a, b)
        n_points = len(a) + len(b)
        assert bottleneck * (1 - 1e-12) <= w <= n_points ** (1 / order) * bottleneck * (1 + 1e-12)


# Small pairs whose q-Wasserstein distance comes out above the optimum. The first three
# at orders between 100 and 10^4 (the first gives 0.26 at orders 200 and 400, where the
# answer is 0.24, its value at order 100: W_q cannot grow with q); the last two at
# order 12 already (the fourth is a diagram against itself plus a point on the
# diagonal, at distance 0 for every order: order 12 gives 0.132).
_SUBOPTIMAL_PAIRS = [
    ([[-0.42, 0.11], [-0.43, 0.13]], [[-0.23, 0.29], [-0.36, 0.37]], 0.24),
    ([[0.11, 0.87], [-0.27, 0.69]], [[0.01, 0.3], [-0.25, 0.29]], 0.39),
    ([[-0.74, 0.09], [-0.85, -0.37], [0.83, 1.56]], [[-0.37, 0.24], [-0.36, 0.28]], 0.37),
    ([[0, 6], [0, 6.125]], [[0, 0], [0, 6], [0, 6.125]], 0.0),
    ([[0, 0], [0, 0], [0, 6], [0, 6.125]], [[0, 6], [0, 6.125], [0, 0.25], [0, 0]], 0.125),
]


@pytest.mark.parametrize("a, b, bottleneck", _SUBOPTIMAL_PAIRS, ids=["a", "b", "c", "d", "e"])
@_isolated
def test_wasserstein_is_optimal_far_below_the_largest_persistence(a, b, bottleneck):
    assert bottleneck_distance(a, b) == pytest.approx(bottleneck, rel=1e-12)
    for order in (3.0, 12.0, 20.0, 50.0, 100.0, 200.0, 400.0, 1000.0, 1e4):
        expected = _brute_force_wasserstein(a, b, order)
        got = wasserstein_distance(a, b, order=order)
        assert got == pytest.approx(expected, rel=1e-12, abs=1e-300), order


def _distance(a, b, order, internal_p=np.inf):
    if order == "bottleneck":
        return bottleneck_distance(a, b)
    return wasserstein_distance(a, b, order=order, internal_p=internal_p)


@pytest.mark.parametrize(
    ("order", "internal_p"),
    [(1.0, np.inf), (2.0, np.inf), (3.5, np.inf), (2.0, 2.0), (1.0, 1000.0), (7.0, 1000.0)]
    + [("bottleneck", np.inf)],
)
@pytest.mark.parametrize("scale", [1e-300, 1e-200, 1e200, 1e300])
@_isolated
def test_distances_scale_with_tiny_and_huge_diagrams(order, internal_p, scale):
    """Every coordinate float64 holds, any order and internal_p: d(s a, s b) = s d(a, b)
    (the diagrams of 1e300 have persistence near float64's largest value)."""
    rng = np.random.default_rng(11)
    pairs = [tuple(map(np.asarray, _SMALL))]
    pairs += [(_random_diagram(rng, 9), _random_diagram(rng, 6)) for _ in range(5)]
    for a, b in pairs:
        expected = scale * _distance(a, b, order, internal_p)
        assert expected > 0 and math.isfinite(expected)
        got = _distance(scale * a, scale * b, order, internal_p)
        assert got == pytest.approx(expected, rel=1e-12, abs=0)


@pytest.mark.parametrize("order", [1.0, 2.0, 3.5])
@pytest.mark.parametrize("scale", [1e-200, 1e200])
@_isolated
def test_diagram_distance_scales_with_essential_points(order, scale):
    """The l_q combination of the parts (and the essential gaps) is scaled too."""
    rng = np.random.default_rng(5)
    samples = [
        (_random_diagram(rng, 5), np.array([[rng.uniform(), np.inf], [2.0, np.inf]]))
        for _ in range(3)
    ]
    scaled = [tuple(scale * d for d in sample) for sample in samples]
    expected = DiagramDistance(metric="wasserstein", order=order).fit_transform(samples)
    got = DiagramDistance(metric="wasserstein", order=order).fit_transform(scaled)
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got, scale * expected, rtol=1e-12)


# Before the fix this pair gave 0.125 (order 1) and the same pair scaled by 10 gave 42.5
# (order 1; the answer is about 8.75) with internal_p=1000.
_GROUND_EXAMPLE = (
    np.array([[0.0, 1.0], [2.0, 5.0]]),
    np.array([[0.0, 1.25], [0.5, 0.75], [2.5, 5.5]]),
)


@pytest.mark.parametrize("order", [1.0, 2.0, 3.5])
@pytest.mark.parametrize("scale", [1.0, 10.0, 1e-3])
@_isolated
def test_large_internal_p_is_close_to_internal_p_inf(order, scale):
    """Each L-1000 ground cost (diagonal ones included) lies between the L-inf one and
    2^(1/1000) times it, and so does the distance."""
    a, b = (scale * d for d in _GROUND_EXAMPLE)
    reference = wasserstein_distance(a, b, order=order, internal_p=np.inf)
    got = wasserstein_distance(a, b, order=order, internal_p=1000.0)
    assert reference * (1 - 1e-12) <= got <= 2 ** (1 / 1000) * reference * (1 + 1e-12)
    assert got == pytest.approx(reference, rel=1e-3)


@_isolated
def test_order_inf_is_the_bottleneck_distance():
    rng = np.random.default_rng(3)
    pairs = [_SMALL, _FIFTY, ([], [[0.5, 1.0]])]
    pairs += [(_random_diagram(rng, 8), _random_diagram(rng, 5)) for _ in range(10)]
    for a, b in pairs:
        assert wasserstein_distance(a, b, order=np.inf) == bottleneck_distance(a, b)
    diagrams = [np.asarray(d, dtype=float) for pair in pairs[3:] for d in pair]
    np.testing.assert_array_equal(
        DiagramDistance(metric="wasserstein", order=np.inf).fit_transform(diagrams),
        DiagramDistance(metric="bottleneck").fit_transform(diagrams),
    )


@pytest.mark.parametrize("internal_p", [1.0, 2.0, 1000.0])
@_isolated
def test_order_inf_with_finite_internal_p_raises(internal_p):
    with pytest.raises(ValueError, match="internal_p"):
        wasserstein_distance(*_SMALL, order=np.inf, internal_p=internal_p)
    with pytest.raises(ValueError, match="internal_p"):
        DiagramDistance(metric="wasserstein", order=np.inf, internal_p=internal_p).fit(
            [np.array(_SMALL[0])]
        )


_coordinate = st.floats(-10.0, 10.0, allow_nan=False, allow_subnormal=False)
_persistence = st.floats(0.0, 10.0, allow_nan=False, allow_subnormal=False)
_finite = st.lists(st.tuples(_coordinate, _persistence), max_size=6).map(
    lambda points: np.array([(b, b + p) for b, p in points], dtype=float).reshape(-1, 2)
)


@st.composite
def _diagram_pairs(draw):
    """Two diagrams with the same number of essential points (death inf)."""
    n_essential = draw(st.integers(0, 2))
    pair = []
    for _ in range(2):
        essential = draw(st.lists(_coordinate, min_size=n_essential, max_size=n_essential))
        infinite = np.array([[e, np.inf] for e in essential], dtype=float).reshape(-1, 2)
        pair.append(np.vstack([draw(_finite), infinite]))
    return pair


def _gudhi_wasserstein(a, b, order):
    with warnings.catch_warnings():
        # POT warns "Problem infeasible" when both finite parts are empty; the value
        # (the essential part alone) is right.
        warnings.simplefilter("ignore")
        return gudhi.wasserstein.wasserstein_distance(a, b, order=order, internal_p=np.inf)


def _exact_wasserstein(a, b, order):
    """Brute force with essential points: finite parts over every matching, essential
    points matched by sorted birth, combined in scaled form."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    finite_a, finite_b = np.isfinite(a[:, 1]), np.isfinite(b[:, 1])
    births_a, births_b = np.sort(a[~finite_a, 0]), np.sort(b[~finite_b, 0])
    if len(births_a) != len(births_b):
        return math.inf
    parts = [_brute_force_wasserstein(a[finite_a], b[finite_b], order)]
    parts += np.abs(births_a - births_b).tolist()
    largest = max(parts)
    if largest == 0.0:
        return 0.0
    return largest * math.fsum((p / largest) ** order for p in parts) ** (1.0 / order)


def _reference(a, b, order):
    """gudhi's distance (POT's network simplex), unless it is above ours: POT stops
    within a relative ~1e-6 of the optimal total when the costs span many orders of
    magnitude (three points on the diagonal against ``[[0, 1], [2, 6]]`` at order 20
    give 2.0000000954 for 2.0000000000001), and then the brute force decides."""
    expected = _gudhi_wasserstein(a, b, order)
    got = wasserstein_distance(a, b, order=order)
    if got != pytest.approx(expected, rel=1e-9, abs=1e-12):
        assert got < expected  # gudhi's value is the cost of a matching: an upper bound
        expected = _exact_wasserstein(a, b, order)
    return expected


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(pair=_diagram_pairs(), order=st.floats(1.0, 20.0))
def test_wasserstein_matches_gudhi(pair, order):
    a, b = pair
    expected = _reference(a, b, order)
    assert wasserstein_distance(a, b, order=order) == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_reference_falls_back_to_brute_force():
    """The case where POT's optimum is off (see ``_reference``)."""
    a, b = np.zeros((3, 2)), np.array([[0.0, 1.0], [2.0, 6.0]])
    exact = _exact_wasserstein(a, b, 20.0)
    assert exact == pytest.approx(2 * (1 + 4.0**-20) ** (1 / 20), rel=1e-15)
    assert _reference(a, b, 20.0) == exact
    assert wasserstein_distance(a, b, order=20.0) == pytest.approx(exact, rel=1e-12)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(parts=st.lists(_diagram_pairs(), min_size=1, max_size=3), order=st.floats(1.0, 20.0))
def test_diagram_distance_of_tuples_matches_gudhi(parts, order):
    """A tuple of diagrams: the l_q norm of the per-diagram distances."""
    left = tuple(a for a, _ in parts)
    right = tuple(b for _, b in parts)
    per_part = [_reference(a, b, order) for a, b in parts]
    largest = max(per_part)
    expected = 0.0
    if largest > 0:
        total = math.fsum((d / largest) ** order for d in per_part)
        expected = largest * total ** (1.0 / order)
    got = DiagramDistance(metric="wasserstein", order=order).fit([right]).transform([left])
    assert got[0, 0] == pytest.approx(expected, rel=1e-9, abs=1e-12)


def _seeded_diagram(seed, n, scale):
    rng = np.random.default_rng(seed)
    births = rng.random(n) * scale
    return np.column_stack([births, births + rng.random(n) * scale])


# Orders 1 and 2 on ordinary diagrams: the same bits as before the scaled form (values
# computed with the previous release).
_BITWISE = [
    ((1, 7, 1.0), (2, 5, 1.0), "0x1.cae8007b4dc3ep+0", "0x1.5c8be8562e052p-1"),
    ((3, 40, 100.0), (4, 33, 100.0), "0x1.002644165bda6p+9", "0x1.74cf9096fa808p+6"),
    ((5, 12, 1e-3), (6, 0, 1e-3), "0x1.acecca1ae192ap-9", "0x1.1b6c0fb03b984p-10"),
]


@pytest.mark.parametrize("left, right, order1, order2", _BITWISE)
def test_orders_1_and_2_unchanged_bitwise(left, right, order1, order2):
    a, b = _seeded_diagram(*left), _seeded_diagram(*right)
    assert wasserstein_distance(a, b, order=1.0) == float.fromhex(order1)
    assert wasserstein_distance(a, b, order=2.0) == float.fromhex(order2)
    for order in (1.0, 2.0):
        expected = _gudhi_wasserstein(a, b, order)
        assert wasserstein_distance(a, b, order=order) == pytest.approx(expected, rel=1e-12)


def test_diagram_distance_orders_1_and_2_unchanged_bitwise():
    samples = [
        (_seeded_diagram(7, 9, 1.0), np.array([[0.25, np.inf]])),
        (_seeded_diagram(8, 6, 1.0), np.array([[0.5, np.inf]])),
    ]
    for order, value in [(1.0, "0x1.07367a81f63f7p+1"), (2.0, "0x1.7f1a3318f949bp-1")]:
        matrix = DiagramDistance(metric="wasserstein", order=order).fit_transform(samples)
        assert matrix[0, 1] == float.fromhex(value)


# ---------------------------------------------------------------------------------------
# 3. Eigenvalues of unbounded multiplicity.
# ---------------------------------------------------------------------------------------


def _book(k):
    """``k`` triangles sharing the edge (0, 1), their apexes on a circle around it: a
    non-manifold mesh whose Laplacian has an eigenvalue of multiplicity ``k - 1`` (the
    functions vanishing on the edge whose apex values sum to zero)."""
    angles = 2 * np.pi * np.arange(k) / k
    apexes = np.column_stack([np.cos(angles), np.sin(angles), np.full(k, 0.5)])
    vertices = np.vstack([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0], apexes])
    faces = np.column_stack([np.zeros(k, int), np.ones(k, int), 2 + np.arange(k)])
    return vertices, faces


def _repeated_warnings(caught):
    return [str(w.message) for w in caught if issubclass(w.category, RepeatedEigenvalueWarning)]


def test_book_of_many_triangles_caps_the_multiplicity():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        (field,) = LaplacianEigenTransformer().fit_transform([_book(1500)])
    assert field.n_vertices == 1502 and field.values.shape == (1502, 3)
    messages = _repeated_warnings(caught)
    assert messages, "no RepeatedEigenvalueWarning"
    assert all("multiplicity at least" in message for message in messages), messages


def test_small_multiplicity_is_reported_exactly():
    """On a sphere eigenvalue 1 has multiplicity 3 and eigenvalue 4 multiplicity 5 (its
    eigenspace crosses the end of the first block of eigenpairs, which grows)."""
    sphere = trimesh.creation.icosphere(3)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        LaplacianEigenTransformer(eigen_index=(1, 4)).fit_transform([sphere])
    messages = _repeated_warnings(caught)
    assert len(messages) == 2, messages
    assert "eigenvalue 1 " in messages[0] and "multiplicity 3 " in messages[0]
    assert "eigenvalue 4 " in messages[1] and "multiplicity 5 " in messages[1]
    assert not any("at least" in message for message in messages), messages


@pytest.mark.parametrize("n_jobs", [0, 10**9, -(10**9)])
def test_an_n_jobs_joblib_refuses_is_refused_by_name(n_jobs):
    """n_jobs=0 reached joblib's "n_jobs == 0 in Parallel has no meaning", 10**9 its
    "Numeric literal ... is too large"."""
    from sklearn_meshph import DiagramDistance, DiagramStatistics, LaplacianEigenTransformer

    X = [np.array([[0.0, 1.0]])] * 3
    for estimator in (DiagramStatistics(n_jobs=n_jobs), DiagramDistance(n_jobs=n_jobs)):
        with pytest.raises(ValueError, match="'n_jobs' parameter of .* Got -?1?0+ instead"):
            estimator.fit_transform(X)
    with pytest.raises(ValueError, match="'n_jobs' parameter"):
        LaplacianEigenTransformer(n_jobs=n_jobs).fit([])


def test_numpy_scalars_as_parameters_pass_without_warnings():
    """A float32 bandwidth compared with the bound 2.7e153 overflowed in the cast (a
    RuntimeWarning); a float32 share of features was refused by the forest."""
    import warnings

    from sklearn_meshph import DistanceKernel
    from sklearn_meshph.leaf_forest import LeafSizeForest

    square = np.array([[0.0, 1.0], [1.0, 0.0]])
    rows = np.random.default_rng(0).random((20, 3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        kernel = DistanceKernel(bandwidth=np.float32(0.5)).fit_transform(square)
        forest = LeafSizeForest(max_features=np.float32(0.5), n_estimators=3, random_state=0)
        forest.fit(rows, [0, 1] * 10)
    np.testing.assert_allclose(kernel, DistanceKernel(bandwidth=0.5).fit_transform(square))
