"""Analysis of simulated cases: statistics, injury risk, effectiveness, comparison with
reconstructions and the Euro NCAP scoring (the diagnosis of missing effects is
:mod:`vfs.diagnosis`).
"""
