"""A CasADi Function evaluated at many points in one call per chunk, its results written straight into numpy arrays.

Function.map makes one Function of N copies; building it costs time in proportion to N, and reading its results
back as CasADi matrices costs more than the evaluation of a compiled function. So the mappings are made once per
size, for chunks of a power of two points (at most CHUNK; the last point repeated up to the size), and evaluated
through CasADi's FunctionBuffer, which reads and writes numpy memory in place: the same arithmetic, the same numbers.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

CHUNK = 1024  # points of one mapped evaluation: bounds its buffers


class Mapped:
    """``function`` at N points: inputs listed in ``shared`` are one value for all points, the others one row a point."""

    def __init__(self, function: ca.Function, shared: tuple[int, ...] = ()):
        self.function, self.shared, self.mappings = _dense(function), shared, {}

    def __call__(self, *inputs: np.ndarray) -> list[np.ndarray]:
        """Each output (N, columns, rows): a point's output matrix in CasADi's column-major order (a column vector's
        values as (N, 1, rows)). Per-point inputs are (N, k) arrays, row i point i's input."""
        count = next(len(x) for i, x in enumerate(inputs) if i not in self.shared)
        shapes = [(self.function.size2_out(i), self.function.size1_out(i)) for i in range(self.function.n_out())]
        outputs = [np.empty((count, *shape)) for shape in shapes]
        shared = {i: np.ascontiguousarray(inputs[i], dtype=float) for i in self.shared}
        for first in range(0, count, CHUNK):
            points = min(CHUNK, count - first)
            size = 1 << (points - 1).bit_length()
            rows = np.arange(first, first + size).clip(max=first + points - 1)
            arguments = [shared[i] if i in shared else np.ascontiguousarray(x[rows], dtype=float) for i, x in enumerate(inputs)]
            results = [np.empty((size, *shape)) for shape in shapes]
            buffer, run = self._mapping(size).buffer()
            for i, argument in enumerate(arguments):
                buffer.set_arg(i, memoryview(argument))
            for i, result in enumerate(results):
                buffer.set_res(i, memoryview(result))
            run()
            for output, result in zip(outputs, results):
                output[first : first + points] = result[:points]
        return outputs

    def _mapping(self, size: int) -> ca.Function:
        if size not in self.mappings:
            reduce_in = [i in self.shared for i in range(self.function.n_in())]
            self.mappings[size] = self.function.map(size, reduce_in, [False] * self.function.n_out())
        return self.mappings[size]


def _dense(function: ca.Function) -> ca.Function:
    """``function`` with every output dense: a buffer holds an output's structural nonzeros only (a Jacobian's zeros
    are left out), so a sparse output is widened to its matrix first. Its inputs are dense vectors."""
    if all(function.sparsity_out(i).is_dense() for i in range(function.n_out())):
        return function
    inputs = [ca.MX.sym(function.name_in(i), function.size_in(i)) for i in range(function.n_in())]
    return ca.Function(f"{function.name()}_dense", inputs, [ca.densify(output) for output in function(*inputs)])
