"""Measured data files: their columns, reading with located errors, writing."""
