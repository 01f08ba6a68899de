"""A CasADi Function evaluated at many points in one call per chunk, its results written straight into numpy arrays.

Function.map makes one Function of N copies; building it costs time in proportion to N, and reading its results
back as CasADi matrices costs more than the evaluation of a compiled function. So the mappings are made once per
size, for chunks of a power of two points (at most CHUNK): N points are the chunks of N's binary digits, so no point
is evaluated twice (padding each call up to the next power of two cost up to twice the evaluations; a solver's
calls shrink as its points converge). They are evaluated through CasADi's FunctionBuffer, which reads and writes
numpy memory in place: the same arithmetic, the same numbers, whatever the chunks.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from armcal.support.compiled import current

CHUNK = 1024  # points of one mapped evaluation: bounds its buffers


class Mapped:
    """``function`` at N points: inputs listed in ``shared`` are one value for all points, the others one row a point."""

    def __init__(self, function: ca.Function, shared: tuple[int, ...] = ()):
        self.given, self.shared = function, shared
        self.evaluated = _Evaluated(function, shared)

    def __call__(self, *inputs: np.ndarray) -> list[np.ndarray]:
        """Each output (N, columns, rows): a point's output matrix in CasADi's column-major order (a column vector's
        values as (N, 1, rows)). Per-point inputs are (N, k) arrays, row i point i's input."""
        count = next(len(x) for i, x in enumerate(inputs) if i not in self.shared)
        evaluated = self.evaluated  # one version for the whole call, whatever another thread swaps in meanwhile
        landed = current(self.given, count)  # the library a background build made for it, once there: the same numbers
        if landed is not evaluated.source:
            evaluated = self.evaluated = _Evaluated(landed, self.shared)
        function = evaluated.function
        shapes = [(function.size2_out(i), function.size1_out(i)) for i in range(function.n_out())]
        outputs = [np.empty((count, *shape)) for shape in shapes]
        shared = {i: np.ascontiguousarray(inputs[i], dtype=float) for i in self.shared}
        for first, size in _chunks(count):
            rows = slice(first, first + size)
            arguments = [shared[i] if i in shared else np.ascontiguousarray(x[rows], dtype=float) for i, x in enumerate(inputs)]
            results = [np.empty((size, *shape)) for shape in shapes]
            buffer, run = evaluated.mapping(size).buffer()
            for i, argument in enumerate(arguments):
                buffer.set_arg(i, memoryview(argument))
            for i, result in enumerate(results):
                buffer.set_res(i, memoryview(result))
            run()
            for output, result in zip(outputs, results):
                output[rows] = result
        return outputs


class _Evaluated:
    """What a Mapped evaluates (the given function, or its library once landed), dense, and its mappings by size."""

    def __init__(self, source: ca.Function, shared: tuple[int, ...]):
        self.source, self.function, self.mappings = source, _dense(source), {}
        self.reduce_in = [i in shared for i in range(self.function.n_in())]

    def mapping(self, size: int) -> ca.Function:
        if size not in self.mappings:
            self.mappings[size] = self.function.map(size, self.reduce_in, [False] * self.function.n_out())
        return self.mappings[size]


def _chunks(count: int) -> list[tuple[int, int]]:
    """(first point, size) of the chunks that cover ``count`` points: CHUNK at a time, then the rest's binary digits,
    largest first (1000 points: 512, 256, 128, 64, 32, 8)."""
    first, rest = count - count % CHUNK, count % CHUNK
    chunks = [(start, CHUNK) for start in range(0, first, CHUNK)]
    for size in (1 << bit for bit in reversed(range(rest.bit_length()))):
        if rest & size:
            chunks.append((first, size))
            first += size
    return chunks


def _dense(function: ca.Function) -> ca.Function:
    """``function`` with every output dense: a buffer holds an output's structural nonzeros only (a Jacobian's zeros
    are left out), so a sparse output is widened to its matrix first. Its inputs are dense vectors."""
    if all(function.sparsity_out(i).is_dense() for i in range(function.n_out())):
        return function
    inputs = [ca.MX.sym(function.name_in(i), function.size_in(i)) for i in range(function.n_in())]
    return ca.Function(f"{function.name()}_dense", inputs, [ca.densify(output) for output in function(*inputs)])
