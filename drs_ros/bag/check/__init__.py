"""``drs-bag check``: a bag's bytes verified, then its run checked against the model."""
