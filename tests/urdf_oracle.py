"""yourdfpy, an independent URDF library, as the test oracle of URDF files: loaded without meshes (no trimesh
mesh loading, no package:// lookups), its forward kinematics of named links at joint configurations."""

from pathlib import Path

import numpy as np
import yourdfpy


def load(path: Path) -> yourdfpy.URDF:
    """The URDF at ``path`` as yourdfpy reads it: the kinematic scene graph only, no meshes."""
    return yourdfpy.URDF.load(str(path), build_scene_graph=True, load_meshes=False,
                              build_collision_scene_graph=False, load_collision_meshes=False)


def poses(model: yourdfpy.URDF, Q: np.ndarray, links: list[str], root: str) -> dict[str, np.ndarray]:
    """Poses (N, 4, 4) of ``links`` in ``root`` at the actuated joint values Q (N, n; rad or m), positions in mm."""
    out = {link: np.empty((len(Q), 4, 4)) for link in links}
    for i, q in enumerate(Q):
        model.update_cfg(np.asarray(q, dtype=float))
        for link in links:
            out[link][i] = model.get_transform(link, root)
    for T in out.values():
        T[:, :3, 3] *= 1000.0
    return out


def joint_values(Q: np.ndarray, joint_types) -> np.ndarray:
    """armcal's joint values (rad, mm) as URDF's (rad, m)."""
    return Q / np.where(np.array(joint_types) == "prismatic", 1000.0, 1.0)


def differences(found: np.ndarray, expected: np.ndarray) -> tuple[float, float]:
    """(largest position difference in mm, largest difference of rotation-matrix entries) of two pose stacks."""
    return (float(np.max(np.abs(found[:, :3, 3] - expected[:, :3, 3]))),
            float(np.max(np.abs(found[:, :3, :3] - expected[:, :3, :3]))))
