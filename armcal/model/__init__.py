"""The measurement model: an instrument's readings of the robot's chain, with the effects."""
