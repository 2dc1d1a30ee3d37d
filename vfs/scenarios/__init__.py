"""Scenario catalogue, synthetic accident database generator and the bundled database."""
