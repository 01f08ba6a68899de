"""Non-geometric effects: the vocabulary, and their terms in the measurement model."""
