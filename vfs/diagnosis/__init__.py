"""Diagnosis of missing physical effects: variants of the model, calibration, claims, the
selection over library effects and learned laws, identification and learning of laws, and the
error ledger (``vfs diagnose``, ``vfs calibrate``, ``vfs identify``, ``vfs learn``,
``vfs ledger``).
"""
