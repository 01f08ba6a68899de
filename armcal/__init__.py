"""armcal: kinematic calibration of industrial robot arms.

The method follows Stone's S-Model dissertation and Goswami, Quaid & Peshkin's
ball-bar paper (see docs/); internal units are millimetres and radians.
"""

__version__ = "0.1.0"
