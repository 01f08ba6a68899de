"""Parallel consecutive axes in a ``dh`` chain, modelled with Hayati's beta.

Where joint i's axis is parallel to joint i+1's (alpha_i within PARALLEL_DEG of
0 or 180 deg), the common normal of Stone (2.9) is not unique: d_i and d_{i+1}
are exactly redundant at the nominal, and a real tilt of a few hundredths of a
degree between the axes moves the common normal by metres, so a fit slides d_i
and d_{i+1} along a valley (Stone's pseudo-DH d of kilometres, Table 6-3, is the
same singularity). Hayati & Mirmirani (1985) model such a joint with Rot(y, beta_i)
after Rot(x, alpha_i) (the mdh link, conventions.mdh_link) and d_i held: the
offset along the parallel axes is carried by d_{i+1}. armcal adds beta_i (free,
at 0, so the nominal poses are unchanged) where the spec gives none, and holds
d_i when beta_i and d_{i+1} are free.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from armcal.kinematics.chain import DeclaredChain

PARALLEL_DEG = 5.0  # consecutive axes closer than this to parallel get Hayati's beta


@dataclass(frozen=True)
class ParallelAxes:
    joint: int  # 1-based: joint i's axis is parallel to joint i+1's
    name: str  # joint i's name: its beta is added, its d held
    beta_added: bool  # the spec gave no beta: armcal added it
    d_held: bool

    @property
    def reason(self) -> str:
        """Why d_i is held, for the identifiability section."""
        return (
            f"axes {self.joint} and {self.joint + 1} are parallel: Hayati's {self.name}.beta replaces d "
            f"(Hayati & Mirmirani 1985); the offset along them is carried by the next joint's d"
        )


def parallel_axes(chain: DeclaredChain) -> list[ParallelAxes]:
    """The joints of a ``dh`` chain whose axis is parallel (within PARALLEL_DEG) to the next joint's."""
    if chain.convention != "dh":
        return []
    out = []
    for i, (joint, following) in enumerate(zip(chain.joints[:-1], chain.joints[1:]), start=1):
        if abs(math.sin(joint.parameters["alpha"].value)) > math.sin(math.radians(PARALLEL_DEG)):
            continue
        beta = joint.parameters.get("beta")
        beta_free = beta is None or beta.vary
        out.append(ParallelAxes(i, joint.name, beta is None, beta_free and joint.parameters["d"].vary and following.parameters["d"].vary))
    return out
