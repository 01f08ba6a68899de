"""Results of a run: the results.json contract and the calibrated spec."""
