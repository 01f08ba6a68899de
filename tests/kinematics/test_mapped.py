"""kinematics.mapped.Mapped gives, at N points, what CasADi's own Function.map call gives: for outputs with structural
zeros (a Jacobian's), a shared input, N of many chunks, and N across a chunk's end."""

import casadi as ca
import numpy as np
import pytest

from armcal.kinematics.mapped import CHUNK, Mapped


def _function() -> ca.Function:
    """(q (3), p (2)) -> a 4x4 pose, and the Jacobian of its position: zero in q3, a structural zero."""
    q, p = ca.SX.sym("q", 3), ca.SX.sym("p", 2)
    c, s = ca.cos(q[0]), ca.sin(q[0])
    pose = ca.vertcat(ca.horzcat(c, -s, 0, p[0] * c + q[1]), ca.horzcat(s, c, 0, p[1] * s), ca.horzcat(0, 0, 1, q[1] ** 2), ca.horzcat(0, 0, 0, 1))
    return ca.Function("f", [q, p], [pose, ca.jacobian(pose[:3, 3], q)])


@pytest.mark.parametrize("count", [1, 5, 1000, CHUNK + 3])  # 1000: chunks of 512, 256, ..., 8
def test_mapped_outputs_equal_function_map(count):
    function = _function()
    assert not function.sparsity_out(1).is_dense()  # the Jacobian: 4 structural nonzeros of 9
    rng = np.random.default_rng(count)
    Q, p = rng.normal(size=(count, 3)), np.array([2.0, 3.0])
    pose, jacobian = Mapped(function, shared=(1,))(Q, p)
    expected_pose, expected_jacobian = (np.array(ca.densify(out)) for out in function.map(count)(Q.T, p))
    np.testing.assert_array_equal(pose.transpose(0, 2, 1), expected_pose.reshape(4, count, 4).transpose(1, 0, 2))
    np.testing.assert_array_equal(jacobian.transpose(0, 2, 1), expected_jacobian.reshape(3, count, 3).transpose(1, 0, 2))
