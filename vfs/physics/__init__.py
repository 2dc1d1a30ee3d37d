"""The physics core: pure, vectorised functions over arrays of cases (SI units).

:mod:`~vfs.physics.vehicle` (parameters, yaw inertia), :mod:`~vfs.physics.geometry`
(outlines, Sutherland-Hodgman clipping, contact plane), :mod:`~vfs.physics.impact`
(the Kudlich-Slibar momentum impact), :mod:`~vfs.physics.paths` (recorded paths),
:mod:`~vfs.physics.precrash` (pre-crash re-simulation, contact, penetration) and
:mod:`~vfs.physics.runout` (post-impact motion to rest).  Nothing here reads files
or imports pandas or matplotlib.
"""
