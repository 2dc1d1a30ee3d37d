"""Gymnasium environments in which AEB policies are trained and tested on the cases.

``vfs/AEB-v0`` is registered with gymnasium when ``vfs`` is imported
(:mod:`vfs.gym.registration`); the environments (:mod:`vfs.gym.env`), the
brake policies (:mod:`vfs.gym.policies`) and their evaluation as a study
(:mod:`vfs.gym.evaluate`) are imported only when used.  docs/gym.md documents
observation, action, reward and episode end.
"""

from vfs.gym.registration import ENV_ID, register_envs

__all__ = ["ENV_ID", "register_envs"]
