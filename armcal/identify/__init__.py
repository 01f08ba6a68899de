"""Identification: problem assembly, Levenberg-Marquardt, identifiability, uncertainty."""
