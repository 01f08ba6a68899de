"""Paul's transforms: ZYX Euler angles read from a rotation give it back to rounding error, also near gimbal lock."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from armcal.kinematics.transforms import pose_from_matrix, xyz_zyx


@pytest.mark.parametrize("pitch", [0.3, 1.570796325, -1.570796325, np.pi / 2, -np.pi / 2, 1.5707963267948])
def test_euler_angles_give_the_rotation_back_near_gimbal_lock(pitch):
    """Rotations Rz(yaw) Ry(pitch) Rx(roll) made by scipy as a product of two (rounded as a chain of URDF joints
    is) with ry near +-90 deg, where rz and rx are each ill-determined: the angles rebuild the matrix to 4e-15 (about 18 units of the last place of 1; sin, cos and atan2
    differ between libraries and processors in their last bit, and measured here the worst is 5.6e-16)."""
    rng = np.random.default_rng(3)
    for yaw, roll in rng.uniform(-np.pi, np.pi, (200, 2)):
        R = (Rotation.from_euler("ZYX", [yaw, pitch / 2, 0.0]) * Rotation.from_euler("YX", [pitch / 2, roll])).as_matrix()
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R, [1.0, -2.0, 3.0]
        x, y, z, rz, ry, rx = pose_from_matrix(T)
        assert abs(ry) <= np.pi / 2 + 1e-12
        assert np.abs(xyz_zyx(x, y, z, rz, ry, rx) - T).max() < 4e-15
