"""Kinematic models: conventions, the chain compiler and S-Model <-> DH conversions."""
