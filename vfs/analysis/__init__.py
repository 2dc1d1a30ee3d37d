"""Analysis of simulated cases: statistics, injury risk, effectiveness, comparison with
reconstructions, calibration, diagnosis of missing effects and the error ledger.
"""
